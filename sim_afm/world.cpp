#include "world.hpp"

#include <algorithm>
#include <cmath>

namespace afm::sim {

namespace {
constexpr double kBoltzmann_nN_nm_per_K = 1.380649e-5;  // 1.380649e-23 J/K in nN nm / K

Eigen::Vector2d unit_or(const Eigen::Vector2d &v, const Eigen::Vector2d &fallback)
{
    const double n = v.norm();
    return n > 1e-12 ? Eigen::Vector2d(v / n) : fallback;
}

double seconds_since(std::chrono::steady_clock::time_point t0)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

World::World(const Scene &s)
    : scene_(s), lever_(s.probe), grid_(1.0), rng_(s.seed)
{
    K_ = lever_.stiffness_A();
    k_lever_max_ = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(K_).eigenvalues().maxCoeff();
    k_contact_ = s.particle_contact_stiffness_N_per_m;
    dt_ = 1.0 / s.sample_rate_hz;
    tip_mu_ = s.tip_substrate.mu;

    const bool adhesion = s.has_effect("adhesion");
    tip_adhesion_nN_ = adhesion ? s.tip_substrate.adhesion_nN : 0.0;
    const ContactSpec &ps = s.particle_substrate;
    const double ps_adh = adhesion ? ps.adhesion_nN : 0.0;
    // Section 5: F_th = mu_ps (F_adh,ps + F_down) + tau_ps A_c, pushed sideways (F_down = 0).
    // tau [MPa] * A [nm^2] = 1e6 N/m^2 * 1e-18 m^2 = 1e-12 N = 1e-3 nN.
    const double threshold = ps.mu * ps_adh + ps.shear_strength_MPa * ps.contact_area_nm2 * 1e-3;
    for (const auto &p : s.particles) {
        particles_.push_back(Particle{p.id, Eigen::Vector2d(p.x_nm, p.y_nm), p.radius_nm, threshold});
        max_radius_ = std::max(max_radius_, p.radius_nm);
    }
    // Cells as large as the widest contact (particle-particle), so a contact
    // query visits at most 3 x 3 cells.
    grid_ = Grid(2 * max_radius_ + s.probe.tip_radius_nm);
    for (std::size_t i = 0; i < particles_.size(); ++i) grid_.insert(static_cast<int>(i), particles_[i].c);

    const Vec2 start = s.op.path_nm.front();
    piezo_ = target_ = Eigen::Vector2d(start.x, start.y);
    apex_ = piezo_;

    mechanics_ = s.has_effect("bending_offset") ? &World::relax : &World::relax_rigid;
    imaging_ = s.has_effect("tip_convolution") ? &World::height_convolved : &World::height_true;
    per_sample_ = build_sample_effects(s, lever_);
}

void World::near(const Eigen::Vector2d &p, double radius, std::vector<int> &out) const
{
    out.clear();
    grid_.query(p, radius, out);
}

void World::command(const Eigen::Vector2d &piezo_nm, double load_nN, bool engaged)
{
    target_ = piezo_nm;
    load_nN_ = load_nN;
    engaged_ = engaged;
}

void World::relax()
{
    // Apex held by the lever (stiffness K_ about its loaded rest position) and
    // by contacts; particles by contacts and their friction threshold. Contact
    // geometry in the sample's frame (apex - drift).
    const Eigen::Vector2d rest = piezo_ + lever_.normal_offset(engaged_ ? load_nN_ : 0.0);
    if (!engaged_) {
        apex_ = rest;
        lateral_force_.setZero();
        for (auto &p : particles_) p.in_contact = false;
        return;
    }
    const double tip_capacity = tip_mu_ * (load_nN_ + tip_adhesion_nN_);
    const double rt = scene_.probe.tip_radius_nm;
    const bool chains = scene_.has_effect("particle_contacts");
    const Eigen::Vector2d apex0 = apex_;
    // Candidates: particles that can touch the apex during this sample.
    near(apex_ - drift_, rt + max_radius_ + 1.0, scratch_);
    for (int idx : scratch_) particles_[idx].in_contact = false;
    for (int it = 0; it < relax_iterations_; ++it) {
        // Apex.
        const Eigen::Vector2d as = apex_ - drift_;
        Eigen::Vector2d g = K_ * (rest - apex_);
        double kt = k_lever_max_;
        for (int idx : scratch_) {
            const Particle &p = particles_[idx];
            const Eigen::Vector2d d = as - p.c;
            const double reach = rt + p.r;
            const double dn = d.norm();
            if (dn >= reach) continue;
            g += k_contact_ * (reach - dn) * unit_or(d, -last_motion_);
            kt += k_contact_;
        }
        const double gn = g.norm();
        if (gn > tip_capacity) apex_ += (gn - tip_capacity) / kt * (g / gn);
        // Particles touching the apex, then (particle_contacts) those they touch.
        const Eigen::Vector2d as2 = apex_ - drift_;
        for (std::size_t q = 0; q < scratch_.size(); ++q) {
            const int i = scratch_[q];
            Particle &p = particles_[i];
            Eigen::Vector2d gp = Eigen::Vector2d::Zero();
            double kp = 0;
            const Eigen::Vector2d d = p.c - as2;
            const double dn = d.norm();
            if (dn < rt + p.r) {
                p.in_contact = true;
                gp += k_contact_ * (rt + p.r - dn) * unit_or(d, last_motion_);
                kp += k_contact_;
            }
            if (chains) {
                near(p.c, p.r + max_radius_, scratch2_);
                for (int j : scratch2_) {
                    if (j == i) continue;
                    const Eigen::Vector2d e = p.c - particles_[j].c;
                    const double en = e.norm();
                    const double reach = p.r + particles_[j].r;
                    if (en >= reach) continue;
                    gp += k_contact_ * (reach - en) * unit_or(e, last_motion_);
                    kp += k_contact_;
                    // A neighbour being pushed joins the sweep.
                    if (std::find(scratch_.begin(), scratch_.end(), j) == scratch_.end()) scratch_.push_back(j);
                }
            }
            const double gpn = gp.norm();
            if (kp > 0 && gpn > p.threshold_nN) {
                p.c += (gpn - p.threshold_nN) / kp * (gp / gpn);
                grid_.update(i, p.c);
            }
        }
    }
    last_motion_ = unit_or(apex_ - apex0, last_motion_);
    lateral_force_ = -(K_ * (rest - apex_));
}

void World::relax_rigid()
{
    // Without bending_offset the lever is laterally rigid: the apex is the
    // piezo; particles in reach are pushed out to contact distance.
    const Eigen::Vector2d apex0 = apex_;
    apex_ = piezo_;
    if (!engaged_) {
        lateral_force_.setZero();
        return;
    }
    const double rt = scene_.probe.tip_radius_nm;
    last_motion_ = unit_or(apex_ - apex0, last_motion_);
    Eigen::Vector2d f = Eigen::Vector2d::Zero();
    if ((apex_ - apex0).norm() > 1e-12) f = -tip_mu_ * (load_nN_ + tip_adhesion_nN_) * last_motion_;
    const Eigen::Vector2d as = apex_ - drift_;
    near(as, rt + max_radius_ + 1.0, scratch_);
    for (int idx : scratch_) {
        Particle &p = particles_[idx];
        const Eigen::Vector2d d = p.c - as;
        const double reach = rt + p.r;
        p.in_contact = d.norm() < reach;
        if (!p.in_contact) continue;
        const Eigen::Vector2d n = unit_or(d, last_motion_);
        const double pen = reach - d.norm();
        if (k_contact_ * pen > p.threshold_nN) {
            p.c += (pen - p.threshold_nN / k_contact_) * n;
            grid_.update(idx, p.c);
            f -= p.threshold_nN * n;
        } else {
            f -= k_contact_ * pen * n;
        }
    }
    lateral_force_ = f;
}

Sample World::step()
{
    // Scanner: piezo towards its set point at a bounded speed.
    const Eigen::Vector2d to = target_ - piezo_;
    const double max_step = scanner_speed_nm_per_s_ * dt_;
    piezo_ += to.norm() > max_step ? Eigen::Vector2d(to.normalized() * max_step) : to;

    auto t0 = Clock::now();
    (this->*mechanics_)();
    t_mech_ += seconds_since(t0);

    // Lever -> photodiode. z feedback holds the normal force at the set point.
    const double fz = engaged_ ? load_nN_ : 0.0;
    const Eigen::Vector2d fC = lever_.R.transpose() * lateral_force_;
    double sn = lever_.sn_volts(fC.x(), fz);
    double sl = lever_.sl_volts(fC.y());
    for (auto &e : per_sample_) {
        t0 = Clock::now();
        e->apply(*this, sn, sl);
        e->seconds += seconds_since(t0);
    }
    Sample out;
    out.sn_v = std::clamp(sn, -kSignalLimitV, kSignalLimitV);
    out.sl_v = std::clamp(sl, -kSignalLimitV, kSignalLimitV);
    // Piezo z: the surface under the apex, less the lever's deflection.
    piezo_z_ = height_true(apex_.x(), apex_.y()) - lever_.bend_slope(fC.x(), fz) * 2.0 * lever_.l / 3.0;
    out.piezo_nm = Eigen::Vector3d(piezo_.x(), piezo_.y(), piezo_z_);
    return out;
}

Eigen::Vector3d World::tip_force() const
{
    return Eigen::Vector3d(lateral_force_.x(), lateral_force_.y(), engaged_ ? load_nN_ : 0.0);
}

double World::height_true(double x, double y) const
{
    double z = 0.0;  // flat glass
    const Eigen::Vector2d q = Eigen::Vector2d(x, y) - drift_;
    near(q, max_radius_, scratch2_);
    for (int idx : scratch2_) {
        const Particle &p = particles_[idx];
        const double w2 = (q - p.c).squaredNorm();
        if (w2 < p.r * p.r) z = std::max(z, p.r + std::sqrt(p.r * p.r - w2));
    }
    return z;
}

double World::tip_profile(double u) const
{
    // Spherical apex of radius r_t, tangent to a cone of half angle gamma.
    const double rt = scene_.probe.tip_radius_nm;
    const double g = scene_.probe.tip_half_angle_deg * M_PI / 180.0;
    const double u0 = rt * std::cos(g);
    if (u <= u0) return rt - std::sqrt(rt * rt - u * u);
    return rt - rt * std::sin(g) + (u - u0) / std::tan(g);
}

double World::height_convolved(double x, double y) const
{
    // Dilation of the surface by the tip: the apex height at which the tip
    // first touches. For a sphere, the touching point lies in the vertical
    // plane through the tip axis and the sphere centre; along it the gap
    // s(w) - t(|rho - w|) is concave, so a golden-section search finds it.
    double z = 0.0;
    const Eigen::Vector2d q = Eigen::Vector2d(x, y) - drift_;
    // The tip's flank reaches sideways by at most its profile at the height
    // of the tallest particle.
    const double g = scene_.probe.tip_half_angle_deg * M_PI / 180.0;
    near(q, max_radius_ + 2 * max_radius_ * std::tan(g) + scene_.probe.tip_radius_nm, scratch2_);
    for (int idx : scratch2_) {
        const Particle &p = particles_[idx];
        const double rho = (q - p.c).norm();
        if (tip_profile(std::max(0.0, rho - p.r)) >= 2 * p.r) continue;  // tip flank clears the top
        auto gap = [&](double w) { return p.r + std::sqrt(std::max(0.0, p.r * p.r - w * w)) - tip_profile(std::fabs(rho - w)); };
        double a = -p.r, b = p.r;
        const double phi = (std::sqrt(5.0) - 1) / 2;
        double c = b - phi * (b - a), d = a + phi * (b - a);
        double fc = gap(c), fd = gap(d);
        for (int i = 0; i < 60 && b - a > 1e-6; ++i) {
            if (fc > fd) { b = d; d = c; fd = fc; c = b - phi * (b - a); fc = gap(c); }
            else { a = c; c = d; fc = fd; d = a + phi * (b - a); fd = gap(d); }
        }
        z = std::max(z, gap(0.5 * (a + b)));
    }
    return z;
}

double World::image_height(double x, double y) const
{
    const auto t0 = Clock::now();
    const double z = (this->*imaging_)(x, y);
    t_scan_ += seconds_since(t0);
    return z;
}

double World::scan_sn_v() const { return lever_.sn_volts(0.0, load_nN_); }

double World::scan_sl_v() const
{
    // Scanning towards +x (frame A): friction on the tip along -x.
    const Eigen::Vector2d f = -tip_mu_ * (load_nN_ + tip_adhesion_nN_) * Eigen::Vector2d::UnitX();
    return lever_.sl_volts((lever_.R.transpose() * f).y());
}

std::vector<EffectClock> World::clocks() const
{
    std::vector<EffectClock> c;
    c.push_back({scene_.has_effect("bending_offset") ? "mechanics+bending_offset" : "mechanics", t_mech_});
    for (const auto &e : per_sample_) c.push_back({e->name(), e->seconds});
    c.push_back({scene_.has_effect("tip_convolution") ? "imaging+tip_convolution" : "imaging", t_scan_});
    return c;
}

std::vector<std::string> World::models_built() const
{
    std::vector<std::string> m = {"scanner", "lever", "substrate:" + scene_.substrate};
    if (!particles_.empty()) m.push_back("particles");
    m.push_back(scene_.has_effect("bending_offset") ? "mechanics:compliant_lever" : "mechanics:rigid_lever");
    m.push_back(scene_.has_effect("tip_convolution") ? "imaging:tip_convolution" : "imaging:true_topography");
    for (const auto &e : per_sample_) m.push_back(e->name());
    return m;
}

}  // namespace afm::sim
