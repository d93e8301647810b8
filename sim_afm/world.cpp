#include "world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

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
    z_speed_nm_per_s_ = s.z_speed_nm_per_s;
    tip_mu_ = s.tip_substrate.mu;

    const bool adhesion = s.has_effect("adhesion");
    tip_adhesion_nN_ = adhesion ? s.tip_substrate.adhesion_nN : 0.0;
    const ContactSpec &ps = s.particle_substrate;
    const double ps_adh = adhesion ? ps.adhesion_nN : 0.0;
    // Section 5: F_th = mu_ps (F_adh,ps + F_down) + tau_ps A_c. tau [MPa] *
    // A [nm^2] = 1e6 N/m^2 * 1e-18 m^2 = 1e-12 N = 1e-3 nN. Pushed sideways
    // F_down = 0 (each particle's threshold_nN, F_th(0)); with down_force
    // the cone's flank presses the particle the tip pushes (press_cone):
    // at psi = gamma + theta_t from the horizontal (theta_t the lever's
    // twist under the last sample's lateral force) by H tan psi, so the
    // push H that moves it is F_th(0) / (1 - mu_ps tan psi), and none does
    // past psi_max = atan(1 / mu_ps) (the cone squeezes it). A particle
    // pushed by another is not pressed: F_th(0).
    down_force_ = s.has_effect("down_force");
    gamma_rad_ = s.probe.tip_half_angle_deg * M_PI / 180.0;
    cos_gamma_ = std::cos(gamma_rad_);
    sin_gamma_ = std::sin(gamma_rad_);
    tan_gamma_ = std::tan(gamma_rad_);
    particle_mu_ = ps.mu;
    const double threshold = ps.mu * ps_adh + ps.shear_strength_MPa * ps.contact_area_nm2 * 1e-3;
    for (const auto &p : s.particles) {
        particles_.push_back(Particle{p.id, Eigen::Vector2d(p.x_nm, p.y_nm), p.radius_nm, threshold});
        max_radius_ = std::max(max_radius_, p.radius_nm);
    }
    // Cells as large as the widest contact (particle-particle), so a contact
    // query visits at most 3 x 3 cells.
    grid_ = Grid(2 * max_radius_ + s.probe.tip_radius_nm);
    landmarks_ = s.landmarks;
    for (std::size_t i = 0; i < particles_.size(); ++i) grid_.insert(static_cast<int>(i), particles_[i].c);

    build_wires(s);
    if (s.substrate == "tilted_glass") {
        tan_slope_ = std::tan(s.slope_deg * M_PI / 180.0);
        normal_ = Eigen::Vector3d(0.0, tan_slope_, 1.0).normalized();   // height -y tan: the normal leans to +y
    }
    trench_grid_ = Grid(50.0);
    if (s.has_effect("roughness")) {
        rough_ = std::make_unique<RoughSurface>(s.roughness_rms_nm, s.roughness_corr_nm, s.seed);
        base_ = &World::base_rough;
        normal_at_ = &World::normal_rough;
    } else {
        base_ = &World::base_plane;
        normal_at_ = &World::normal_plane;
    }
    if (s.substrate_map) {
        measured_ = std::make_unique<MeasuredSurface>(*s.substrate_map);
        base_ = &World::base_measured;
        normal_at_ = &World::normal_measured;
    }

    const Vec2 start = s.start_nm();
    piezo_ = target_ = Eigen::Vector2d(start.x, start.y);
    apex_ = piezo_;

    mechanics_ = s.has_effect("bending_offset") ? &World::relax : &World::relax_rigid;
    imaging_ = s.has_effect("tip_convolution") ? &World::height_convolved : &World::height_true;
    per_sample_ = build_sample_effects(s, lever_);
}

void World::build_wires(const Scene &s)
{
    // Wires: built only when the scene has some; rigid rods unless
    // wire_flexibility is listed. f in nN/um -> nN/nm.
    const double f_wire = s.wire_friction_nN_per_um() * 1e-3;
    for (const auto &w : s.wires) {
        const Eigen::Vector2d a(w.x0_nm, w.y0_nm), b(w.x1_nm, w.y1_nm);
        if (s.has_effect("wire_flexibility"))
            wires_.push_back(std::make_unique<FlexibleWire>(w.id, a, b, w.diameter_nm, f_wire, s.wire_model.youngs_modulus_GPa,
                                                            s.wire_model.segments, s.wire_model.relax_sweeps));
        else
        {
            auto rod = std::make_unique<RigidWire>(w.id, a, b, w.diameter_nm, f_wire, s.wire_model.friction_points);
            rod->numeric = s.wire_model.solver == "numeric";
            wires_.push_back(std::move(rod));
        }
    }
    if (down_force_)
        for (auto &w : wires_) w->mu = s.wire_model.mu;
    if (s.has_effect("lithography")) {
        for (auto &w : wires_)
            w->trap = [this](const Eigen::Vector2d &p, double d, Eigen::Vector2d &along, double &hold) {
                return trench_hold(p, d, along, hold);
            };
    }
}

void World::near(const Eigen::Vector2d &p, double radius, std::vector<int> &out) const
{
    out.clear();
    grid_.query(p, radius, out);
}

void World::command(const Eigen::Vector2d &piezo_nm, double load_nN, bool engaged)
{
    // Beyond the scanner's range the set point is clamped to it (counted per
    // sample in step()).
    const double half = kScannerRangeXY_nm / 2;
    target_ = piezo_nm.cwiseMax(-half).cwiseMin(half);
    target_clamped_ = target_ != piezo_nm;
    load_nN_ = load_nN;
    engaged_ = engaged;
}

void World::relax()
{
    // Apex held by the lever (stiffness K_ about its loaded rest position) and
    // by contacts; particles by contacts and their friction threshold. Contact
    // geometry in the sample's frame (apex - drift).
    const Eigen::Vector2d rest = piezo_ + lever_.normal_offset(contact_load());
    if (!touching()) {
        apex_ = rest;
        lateral_force_.setZero();
        for (auto &p : particles_) p.in_contact = false;
        for (auto &w : wires_) w->in_contact = false;
        return;
    }
    const double rt = scene_.probe.tip_radius_nm;
    const bool chains = scene_.has_effect("particle_contacts");
    const Eigen::Vector2d apex0 = apex_;
    const double fz = contact_load();
    press_cone();
    const Eigen::Vector3d normal = (this->*normal_at_)(apex_ - drift_);   // the substrate's, at the apex
    // Candidates: particles that can touch the apex during this sample.
    near(apex_ - drift_, rt + max_radius_ + 1.0, scratch_);
    for (int idx : scratch_) particles_[idx].in_contact = false;
    for (int it = 0; it < relax_iterations_; ++it) {
        double kt = k_lever_max_;
        const Eigen::Vector2d g = apex_pull(rest, rt, &kt);
        slide_apex(g, fz, normal, kt);
        const Eigen::Vector2d as2 = apex_ - drift_;
        push_particles(as2, rt, chains);
        push_wires(as2, rt);
    }
    last_motion_ = unit_or(apex_ - apex0, last_motion_);
    lateral_force_ = -(K_ * (rest - apex_));
    count_ridden();
}

void World::count_ridden()
{
    for (const auto &w : wires_)
        if (w->ridden) {
            ++ridden_samples_;   // a sample in which the tip rode over a wire (once, however many wires or sweeps)
            return;
        }
}

Eigen::Vector2d World::apex_pull(const Eigen::Vector2d &rest, double rt, double *kt)
{
    // The force on the apex from the lever and from every contact, and the
    // stiffness it meets (*kt, from the lever's).
    const Eigen::Vector2d as = apex_ - drift_;
    Eigen::Vector2d g = K_ * (rest - apex_);
    for (int idx : scratch_) {
        const Particle &p = particles_[idx];
        const Eigen::Vector2d d = as - p.c;
        const double reach = rt + p.r;
        const double dn = d.norm();
        if (dn >= reach) continue;
        g += k_contact_ * (reach - dn) * unit_or(d, -last_motion_);
        *kt += k_contact_;
    }
    for (const auto &w : wires_) {
        double pen, u;
        Eigen::Vector2d n;
        w->pulled = false;
        if (!w->near(as, rt) || !w->contact(as, rt, pen, n, u)) continue;
        if (w->ridden) continue;   // the tip rode over it at the last push (push_wires)
        g += k_contact_ * pen * n;
        *kt += k_contact_;
        w->pulled = true;
    }
    return g;
}

void World::slide_apex(const Eigen::Vector2d &g, double fz, const Eigen::Vector3d &normal, double kt)
{
    // Substrate: the tip stays while the force it must supply, S = (-g,
    // F_z) (lever and contacts horizontal, the set point vertical), lies in
    // its friction cone about the surface normal n: |S_t| <= mu (S . n +
    // F_adh). Otherwise it slides along the surface, against S_t.
    const Eigen::Vector3d S(-g.x(), -g.y(), fz);
    const double sn = S.dot(normal);
    const Eigen::Vector3d St = S - sn * normal;
    const double capacity = tip_mu_ * std::max(0.0, sn + tip_adhesion_nN_);
    const double stn = St.norm();
    if (stn > capacity) {
        const Eigen::Vector2d mh = -St.head<2>();
        const double mhn = mh.norm();
        if (mhn > 1e-12) apex_ += (stn - capacity) / kt * (mh / mhn);
    }
}

void World::push_particles(const Eigen::Vector2d &as2, double rt, bool chains)
{
    // Particles touching the apex, then (particle_contacts) those they touch.
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
        const double th = p.threshold_nN * (dn < rt + p.r ? cone_factor_ : 1.0);   // the tip's cone presses it (down_force)
        if (kp > 0 && gpn > th) {
            p.c += (gpn - th) / kp * (gp / gpn);
            grid_.update(i, p.c);
        }
    }
}

void World::push_wires(const Eigen::Vector2d &as2, double rt)
{
    for (auto &w : wires_) {
        if (!w->near(as2, rt)) { w->in_contact = false; w->ridden = false; continue; }
        const auto t0 = clock_start();
        // The contact's force is the tip's push once the apex's balance has
        // taken it (pulled); the sweep in which the apex first steps into
        // the wire, before that, overshoots by a penalty artefact, and is
        // no lift-off (a ride already under way stays one).
        const double ride = w->pulled || w->ridden ? ride_push_nN(*w) : std::numeric_limits<double>::infinity();
        w->push(as2, rt, k_contact_, ride);
        clock_add(&t_wires_, t0);
    }
}

void World::relax_rigid()
{
    // Without bending_offset the lever is laterally rigid: the apex is the
    // piezo; particles in reach are pushed out to contact distance.
    const Eigen::Vector2d apex0 = apex_;
    apex_ = piezo_;
    jammed_ = false;
    if (!touching()) {
        lateral_force_.setZero();
        for (auto &w : wires_) w->in_contact = false;
        return;
    }
    const double rt = scene_.probe.tip_radius_nm;
    last_motion_ = unit_or(apex_ - apex0, last_motion_);
    press_cone();
    Eigen::Vector2d f = Eigen::Vector2d::Zero();
    const Eigen::Vector2d as = apex_ - drift_;
    if ((apex_ - apex0).norm() > 1e-12) {
        // A rigid lever forces the tip on even up a slope it cannot climb:
        // then the force is unbounded and step() saturates the outputs.
        const auto fr = sliding_friction(last_motion_, (this->*normal_at_)(as), contact_load());
        jammed_ = !fr;
        if (fr) f = *fr;
    }
    for (auto &w : wires_) {
        double pen, u;
        Eigen::Vector2d n;
        if (!w->near(as, rt)) { w->in_contact = false; continue; }
        const auto t0 = clock_start();
        w->push(as, rt, k_contact_, ride_push_nN(*w));
        clock_add(&t_wires_, t0);
        if (w->contact(as, rt, pen, n, u) && !w->ridden) f += k_contact_ * pen * n;
    }
    count_ridden();
    near(as, rt + max_radius_ + 1.0, scratch_);
    for (int idx : scratch_) {
        Particle &p = particles_[idx];
        const Eigen::Vector2d d = p.c - as;
        const double reach = rt + p.r;
        p.in_contact = d.norm() < reach;
        if (!p.in_contact) continue;
        const Eigen::Vector2d n = unit_or(d, last_motion_);
        const double pen = reach - d.norm();
        const double th = p.threshold_nN * cone_factor_;   // pressed by the cone (down_force)
        if (k_contact_ * pen > th) {
            p.c += (pen - th / k_contact_) * n;
            grid_.update(idx, p.c);
            f -= th * n;
        } else {
            f -= k_contact_ * pen * n;
        }
    }
    lateral_force_ = f;
}

void World::press_cone()
{
    // down_force: the contact normal of the cone with a wire or a particle
    // is psi = gamma + theta_t from the horizontal (physics.md 5 and 7),
    // theta_t = F_y h / k_theta the lever's twist under the lateral force of
    // the last sample.
    if (!down_force_) return;
    const Eigen::Vector2d fC = lever_.R.transpose() * lateral_force_;
    const double psi = gamma_rad_ + std::fabs(lever_.twist(fC.y()));
    const double t = psi < M_PI / 2 ? std::tan(psi) : std::numeric_limits<double>::infinity();
    for (auto &w : wires_) w->press_tan = t;
    const double den = 1.0 - particle_mu_ * t;
    cone_factor_ = den > 0 ? 1.0 / den : std::numeric_limits<double>::infinity();
}

double World::ride_push_nN(const Wire &w) const
{
    // The tip's own vertical balance (eq. 27-28): a push H on the cone's
    // flank, at psi = gamma + theta_t from the horizontal, lifts the tip by
    // H tan psi against its load and its adhesion; past both the apex leaves
    // the substrate and climbs over the wire instead of pressing it, while
    // the wire slides as well as once it is squeezed. So the tip can push at
    // most (load + F_a,ts) / tan psi. Whether the wire needs more is its own
    // friction's answer (Wire::push), never eq. 29-30's closed form.
    // The twist theta_t is the lever's under the push itself (plus the tip's
    // own sliding friction, along the motion), not the last sample's force:
    // a ride-over drops the push, and a twist that followed it would let the
    // tip press again at once. H tan(gamma + |theta_t(H)|) = load + F_a,ts is
    // solved by fixed-point iteration (theta_t grows with H, so it converges
    // from below for the twists a lever can take).
    // Without down_force the cone's flank is not modelled: no limit.
    if (!down_force_ || !(w.press_tan > 0)) return std::numeric_limits<double>::infinity();
    const double lift = std::max(0.0, contact_load() + tip_adhesion_nN_);
    const double across = (lever_.R.transpose() * last_motion_).y();        // frame C's y per unit of push along the motion
    const double friction = tip_mu_ * (contact_load() + tip_adhesion_nN_);
    double H = lift / std::tan(gamma_rad_);
    for (int i = 0; i < 12; ++i) {
        const double psi = gamma_rad_ + std::fabs(lever_.twist((H + friction) * across));
        const double next = psi < M_PI / 2 ? lift / std::tan(psi) : 0.0;
        if (std::fabs(next - H) < 1e-9) break;
        H = next;
    }
    return H;
}

std::optional<Eigen::Vector2d> World::sliding_friction(const Eigen::Vector2d &m, const Eigen::Vector3d &n, double fz) const
{
    // Slip along the surface in the direction whose horizontal part is m:
    // tangent t; contact normal force N from the vertical force F_z,
    // (N - F_adh) n_z - mu N t_z = F_z; the substrate's force is
    // (N - F_adh) n - mu N t. Uphill steeper than 90 deg - atan(mu)
    // (n_z <= mu t_z) no N solves it: the tip jams.
    const Eigen::Vector3d &up = n;
    Eigen::Vector3d t(m.x(), m.y(), -(up.x() * m.x() + up.y() * m.y()) / up.z());
    t.normalize();
    const double den = up.z() - tip_mu_ * t.z();
    if (!(den > 0)) return std::nullopt;
    const double N = (fz + tip_adhesion_nN_ * up.z()) / den;
    const Eigen::Vector3d S = (N - tip_adhesion_nN_) * up - tip_mu_ * N * t;
    return Eigen::Vector2d(S.head<2>());
}

void World::saturate_against(const Eigen::Vector2d &m, double &sn, double &sl) const
{
    // Components of the lever frame below this are rounding of the rotation.
    constexpr double kRotationRounding = 1e-9;
    const Eigen::Vector2d dC = lever_.R.transpose() * (-m);
    if (std::fabs(dC.y()) > kRotationRounding) sl = std::copysign(kSignalLimitV, dC.y());
    if (std::fabs(dC.x()) > kRotationRounding) sn = std::copysign(kSignalLimitV, dC.x());   // eq. 1c: F_x bends like a load
}

World::ZHold World::hold_z(double surface_nm, double fx_C, double fz) const
{
    // z = surface - deflection at the set point; a clamped z changes the
    // deflection by the shortfall, and the normal force by k_n times it.
    const double half = kScannerRangeZ_nm / 2;
    const double z_need = surface_nm - lever_.bend_slope(fx_C, fz) * 2.0 * lever_.l / 3.0;
    ZHold h{std::clamp(z_need, -half, half), fz, false, true, z_need};
    if (h.z_nm == z_need) return h;
    h.clamped = true;
    return short_of(h, fz);
}

World::ZHold World::slew_z(const ZHold &ideal, double fz) const
{
    const double step = z_speed_nm_per_s_ * dt_;
    ZHold h = ideal;
    h.z_nm = piezo_z_ + std::clamp(ideal.z_nm - piezo_z_, -step, step);
    return short_of(h, fz);
}

World::ZHold World::short_of(ZHold h, double fz) const
{
    h.fz_nN = fz + lever_.spring * (h.z_need_nm - h.z_nm);
    h.touching = h.fz_nN > -tip_adhesion_nN_;
    if (!h.touching) h.fz_nN = 0.0;
    return h;
}

Sample World::step()
{
    // Scanner: piezo towards its set point at a bounded speed.
    const Eigen::Vector2d to = target_ - piezo_;
    const double max_step = scanner_speed_nm_per_s_ * dt_;
    piezo_ += to.norm() > max_step ? Eigen::Vector2d(to.normalized() * max_step) : to;

    // 1 sample in kClockEvery is timed (clocks()): xorshift32's low bits
    clock_pick_ ^= clock_pick_ << 13;
    clock_pick_ ^= clock_pick_ >> 17;
    clock_pick_ ^= clock_pick_ << 5;
    timed_ = clock_pick_ % kClockEvery == 0;
    ++samples_;
    timed_samples_ += timed_;
    auto t0 = clock_start();
    (this->*mechanics_)();
    if (!trench_points_.empty()) settle_rods();
    clock_add(&t_mech_, t0);

    // z feedback (ideal) holds the normal force at the set point while the
    // extension it needs lies in the scanner's range. Beyond it z stays at
    // the limit: the normal force departs from the set point by k_n times
    // the shortfall (from the next sample on in the mechanics), and the tip
    // leaves the surface when that pulls harder than the adhesion.
    // A finite z servo (afm.z_speed_nm_per_s) moves z at most v_z dt per
    // sample: the force lags the set point (World's header). Disengaged,
    // z is retracted by kRetractLift_nm at once; a finite servo's tip then
    // counts as lifted, so that engaging again lands it from there.
    Eigen::Vector2d fC = lever_.R.transpose() * lateral_force_;
    ZHold zh = hold_z(height_true(apex_.x(), apex_.y()), fC.x(), engaged_ ? load_nN_ : 0.0);
    if (!engaged_) {
        const double half = kScannerRangeZ_nm / 2, up = zh.z_nm + kRetractLift_nm;
        zh.clamped = zh.clamped || up > half;
        zh.z_nm = std::min(up, half);
    } else if (z_speed_nm_per_s_ > 0 && z_started_) {
        zh = slew_z(zh, load_nN_);
    }
    z_started_ = true;
    piezo_z_ = zh.z_nm;
    z_excess_nN_ = engaged_ && zh.touching ? zh.fz_nN - load_nN_ : 0.0;
    lifted_ = engaged_ ? !zh.touching : z_speed_nm_per_s_ > 0;
    if (target_clamped_ || zh.clamped) ++clamped_samples_;

    // Lever -> photodiode.
    if (lifted_) fC.setZero();
    const double fz = contact_load();
    double sn = lever_.sn_volts(fC.x(), fz);
    double sl = lever_.sl_volts(fC.y());
    if (jammed_ && touching()) saturate_against(last_motion_, sn, sl);
    for (auto &e : per_sample_) {
        t0 = clock_start();
        e->apply(*this, sn, sl);
        clock_add(&e->seconds, t0);
    }
    Sample out;
    out.sn_v = std::clamp(sn, -kSignalLimitV, kSignalLimitV);
    out.sl_v = std::clamp(sl, -kSignalLimitV, kSignalLimitV);
    out.piezo_nm = Eigen::Vector3d(piezo_.x(), piezo_.y(), piezo_z_);
    return out;
}

Eigen::Vector3d World::tip_force() const
{
    if (!touching()) return Eigen::Vector3d::Zero();
    return Eigen::Vector3d(lateral_force_.x(), lateral_force_.y(), contact_load());
}

double World::groove_depth(const Eigen::Vector2d &q) const
{
    // The cone (half angle gamma) swept along the path: at distance w from
    // the path the cut is depth - w / tan(gamma) deep, so the trench is
    // 2 depth tan(gamma) wide at the surface (a V-groove), the depth linear
    // between path points.
    if (trench_points_.empty()) return 0.0;
    const double cot = 1.0 / tan_gamma_;
    double z = 0.0;
    scratch3_.clear();
    trench_grid_.query(q, trench_reach_nm_ + trench_step_nm_, scratch3_);
    for (int k : scratch3_) {
        const auto &[ti, pi] = trench_points_[k];
        const Trench &t = trenches_[ti];
        z = std::max(z, t.depth_nm[pi] - (q - t.p[pi]).norm() * cot);
        if (pi == 0) continue;
        // The piece of path from the previous point, its depth linear along it.
        const double a = segment_param(t.p[pi - 1], t.p[pi], q);
        const Eigen::Vector2d c = t.p[pi - 1] + a * (t.p[pi] - t.p[pi - 1]);
        z = std::max(z, (1 - a) * t.depth_nm[pi - 1] + a * t.depth_nm[pi] - (q - c).norm() * cot);
    }
    return z;
}

double World::height_true(double x, double y) const
{
    const Eigen::Vector2d q = Eigen::Vector2d(x, y) - drift_;
    const double base = base_height(q);
    double z = -groove_depth(q);
    near(q, max_radius_, scratch2_);
    for (int idx : scratch2_) {
        const Particle &p = particles_[idx];
        const double w2 = (q - p.c).squaredNorm();
        if (w2 < p.r * p.r) z = std::max(z, p.r + std::sqrt(p.r * p.r - w2));
    }
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        const auto &w = wires_[i];
        if (!w->near(q, 0.0)) continue;
        const double r = 0.5 * w->d_nm, d = w->axis_distance(q);
        if (d < r) z = std::max(z, wire_axis_height_nm(i) + std::sqrt(r * r - d * d));
    }
    return base + std::max(z, landmark_height(q, false));
}

double World::landmark_height(const Eigen::Vector2d &q, bool dilated) const
{
    // A square pillar of side a and height H: flat top; under the tip, its
    // top edge is met by the tip's profile at horizontal distance d from
    // the pillar, so the apex stands at H - t(d).
    double z = -std::numeric_limits<double>::infinity();
    for (const auto &m : landmarks_) {
        const double dx = std::max(0.0, std::fabs(q.x() - m.x_nm) - m.side_nm / 2);
        const double dy = std::max(0.0, std::fabs(q.y() - m.y_nm) - m.side_nm / 2);
        const double d = std::hypot(dx, dy);
        if (d == 0) z = std::max(z, m.height_nm);
        else if (dilated) {
            const double h = m.height_nm - tip_profile(d);
            if (h > 0) z = std::max(z, h);
        }
    }
    return z;
}

double World::tip_profile(double u) const
{
    // Spherical apex of radius r_t, tangent to a cone of half angle gamma.
    const double rt = scene_.probe.tip_radius_nm;
    const double u0 = rt * cos_gamma_;
    if (u <= u0) return rt - std::sqrt(rt * rt - u * u);
    return rt - rt * sin_gamma_ + (u - u0) / tan_gamma_;
}

double World::bump_convolved(double rho, double r) const
{
    // Dilation by the tip of a sphere (or a cylinder, seen across its axis)
    // of radius r resting on the surface, at horizontal distance rho: the apex
    // height at which the tip first touches. The touching point lies in the
    // vertical plane through the tip axis and the centre; along it the gap
    // s(w) - t(|rho - w|) is concave, so a golden-section search finds it.
    if (tip_profile(std::max(0.0, rho - r)) >= 2 * r) return 0.0;   // tip flank clears the top
    auto gap = [&](double w) { return r + std::sqrt(std::max(0.0, r * r - w * w)) - tip_profile(std::fabs(rho - w)); };
    double a = -r, b = r;
    const double phi = (std::sqrt(5.0) - 1) / 2;
    double c = b - phi * (b - a), d = a + phi * (b - a);
    double fc = gap(c), fd = gap(d);
    for (int i = 0; i < 60 && b - a > 1e-6; ++i) {
        if (fc > fd) { b = d; d = c; fd = fc; c = b - phi * (b - a); fc = gap(c); }
        else { a = c; c = d; fc = fd; d = a + phi * (b - a); fd = gap(d); }
    }
    return std::max(0.0, gap(0.5 * (a + b)));
}

double World::height_convolved(double x, double y) const
{
    // Objects are dilated by the tip; the substrate plane and the trenches
    // are shown undilated (a V-groove cut by this very tip fits it).
    const Eigen::Vector2d q = Eigen::Vector2d(x, y) - drift_;
    double z = -groove_depth(q);
    // The tip's flank reaches sideways by at most its profile at the height
    // of the tallest object.
    near(q, max_radius_ + 2 * max_radius_ * tan_gamma_ + scene_.probe.tip_radius_nm, scratch2_);
    // An object the tip does not touch here (dilation 0) must not fill a
    // groove beside it: only a positive dilation competes with the groove.
    for (int idx : scratch2_) {
        const Particle &p = particles_[idx];
        const double b = bump_convolved((q - p.c).norm(), p.r);
        if (b > 0) z = std::max(z, b);
    }
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        const auto &w = wires_[i];
        const double r = 0.5 * w->d_nm;
        if (!w->near(q, r + 2 * r * tan_gamma_ + scene_.probe.tip_radius_nm)) continue;
        const double b = bump_convolved(w->axis_distance(q), r);
        if (b > 0) z = std::max(z, b + wire_axis_height_nm(i) - r);   // a rod sunk into a groove: lower by its seat
    }
    z = std::max(z, landmark_height(q, true));
    return base_height(q) + z;
}

double World::wire_axis_height_nm(std::size_t i) const
{
    return i < rod_axis_z_.size() ? rod_axis_z_[i] : 0.5 * wires_[i]->d_nm;
}

std::vector<double> World::wire_axis_heights_nm() const
{
    std::vector<double> out;
    for (std::size_t i = 0; i < wires_.size(); ++i) out.push_back(wire_axis_height_nm(i));
    return out;
}

template <class F> bool World::first_trench_piece(const Eigen::Vector2d &q, F accept) const
{
    // The pieces of every trench's path near q (the trench grid), each as
    // the point c of its path nearest q, the groove's depth D there and its
    // direction; the first that `accept(c, D, along)` takes ends the search.
    scratch3_.clear();
    trench_grid_.query(q, trench_reach_nm_ + trench_step_nm_, scratch3_);
    for (int k : scratch3_) {
        const auto &[ti, pi] = trench_points_[k];
        if (pi == 0) continue;
        const Trench &t = trenches_[ti];
        const double a = segment_param(t.p[pi - 1], t.p[pi], q);
        const Eigen::Vector2d c = t.p[pi - 1] + a * (t.p[pi] - t.p[pi - 1]);
        const double D = (1 - a) * t.depth_nm[pi - 1] + a * t.depth_nm[pi];
        if (accept(c, D, Eigen::Vector2d((t.p[pi] - t.p[pi - 1]).normalized()))) return true;
    }
    return false;
}

bool World::trench_seat(const Eigen::Vector2d &q, double d_nm, Eigen::Vector2d *to_centre, double *depth) const
{
    // The V at least as wide as the wire, and the wire's axis over its
    // opening (within half its width of the path: its weight and adhesion
    // then take it down the wall); the way to the groove's path (across it)
    // and the groove's depth there.
    const double tg = std::tan(scene_.probe.tip_half_angle_deg * M_PI / 180.0);
    return first_trench_piece(q, [&](const Eigen::Vector2d &c, double D, const Eigen::Vector2d &along) {
        if (2 * tg * D < d_nm || (q - c).norm() >= tg * D) return false;
        *to_centre = (c - q) - (c - q).dot(along) * along;   // across the groove only: it does not slide along it
        *depth = D;
        return true;
    });
}

void World::settle_rods()
{
    constexpr int kPoints = 17;
    const double g = scene_.probe.tip_half_angle_deg * M_PI / 180.0;
    if (rod_axis_z_.size() != wires_.size()) {
        rod_axis_z_.clear();
        for (const auto &w : wires_) rod_axis_z_.push_back(0.5 * w->d_nm);
    }
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        auto *rod = dynamic_cast<RigidWire *>(wires_[i].get());
        if (!rod) continue;
        const double R = 0.5 * rod->d_nm;
        const Eigen::Vector2d a = rod->nodes().front(), b = rod->nodes().back();
        // Each point's target, moved across the groove onto its path; the
        // rod turns to the targets' line (their regression on the place
        // along the rod) and its centre moves to its foot on that line.
        // A fixed array: settle_rods runs every step, and allocates nothing.
        std::array<std::pair<double, Eigen::Vector2d>, kPoints> targets;
        std::size_t n_targets = 0;
        double depth = 0;
        for (int k = 0; k < kPoints; ++k) {
            Eigen::Vector2d to;
            double D;
            const double t = (k + 0.5) / kPoints;
            const Eigen::Vector2d q = a + t * (b - a);
            if (!trench_seat(q, rod->d_nm, &to, &D)) continue;
            targets[n_targets++] = {t, q + to};
            depth += D;
        }
        if (2 * n_targets < kPoints) {
            rod_axis_z_[i] = R;
            continue;
        }
        depth /= n_targets;
        double tbar = 0;
        Eigen::Vector2d Tbar = Eigen::Vector2d::Zero(), v = Eigen::Vector2d::Zero();
        for (std::size_t k = 0; k < n_targets; ++k) tbar += targets[k].first, Tbar += targets[k].second;
        tbar /= n_targets;
        Tbar /= n_targets;
        for (std::size_t k = 0; k < n_targets; ++k) v += (targets[k].first - tbar) * (targets[k].second - Tbar);
        const double psi = v.squaredNorm() > 0 ? std::atan2(v.y(), v.x()) : rod->psi;
        const Eigen::Vector2d dir(std::cos(psi), std::sin(psi));
        const Eigen::Vector2d c = Tbar + (rod->centre - Tbar).dot(dir) * dir;
        if ((c - rod->centre).norm() > 1e-9 || std::fabs(psi - rod->psi) > 1e-12) rod->place(c, psi);
        // On both walls (they touch it below the surface when the V's half
        // width D tan gamma >= R cos gamma; trench_seat asks for >= R).
        rod_axis_z_[i] = -depth + R / std::sin(g);
    }
}

bool World::trench_hold(const Eigen::Vector2d &q, double d_nm, Eigen::Vector2d &along, double &hold) const
{
    // A wire point sits in a trench when the V is at least as wide as the
    // wire there and the wire's axis lies within the part that wide. To leave
    // sideways it must climb a wall inclined at theta = 90 deg - gamma
    // against its friction angle beta = atan(mu_wire): per unit of the load
    // that makes its friction f, that costs tan(theta + beta) instead of
    // tan(beta) (capped at 1000 when theta + beta reaches 90 deg).
    if (trench_points_.empty()) return false;
    const double tg = std::tan(scene_.probe.tip_half_angle_deg * M_PI / 180.0);
    return first_trench_piece(q, [&](const Eigen::Vector2d &c, double D, const Eigen::Vector2d &dir) {
        const double width = 2 * tg * D;
        if (width < d_nm || (q - c).norm() > 0.5 * (width - d_nm)) return false;
        along = dir;
        const double theta = M_PI / 2 - std::atan(tg), beta = std::atan(scene_.wire_model.mu);
        hold = theta + beta < M_PI / 2 - 1e-3 ? std::tan(theta + beta) / std::tan(beta) : 1000.0;
        hold = std::min(hold, 1000.0);
        return true;
    });
}

void World::engrave()
{
    // Depth law (documented in the scene: sample.lithography): linear in the
    // load above the threshold, depth = depth_nm_per_nN (F - F_th); the cone
    // leaves a V of width 2 depth tan(gamma).
    const double excess = touching() ? contact_load() - scene_.litho.threshold_nN : 0.0;
    if (excess <= 0) {
        cutting_ = false;
        return;
    }
    const double depth = scene_.litho.depth_nm_per_nN * excess;
    const double width = 2 * depth * std::tan(scene_.probe.tip_half_angle_deg * M_PI / 180.0);
    const Eigen::Vector2d q = apex_ - drift_;
    if (!cutting_) {
        trenches_.push_back(Trench{static_cast<int>(trenches_.size()) + 1, {}, {}, {}});
        cutting_ = true;
    }
    Trench &t = trenches_.back();
    // A new path point every quarter width (or 0.5 nm), or when the depth
    // changes by 1%.
    const double spacing = std::max(0.5, 0.25 * width);
    if (!t.p.empty() && (q - t.p.back()).norm() < spacing && std::fabs(depth - t.depth_nm.back()) < 0.01 * depth) return;
    if (!t.p.empty()) trench_step_nm_ = std::max(trench_step_nm_, (q - t.p.back()).norm());
    t.p.push_back(q);
    t.depth_nm.push_back(depth);
    t.width_nm.push_back(width);
    trench_points_.emplace_back(static_cast<int>(trenches_.size()) - 1, static_cast<int>(t.p.size()) - 1);
    trench_grid_.insert(static_cast<int>(trench_points_.size()) - 1, q);
    trench_reach_nm_ = std::max(trench_reach_nm_, 0.5 * width);
}

double World::image_height(double x, double y) const
{
    const auto t0 = Clock::now();
    const double z = (this->*imaging_)(x, y);
    t_scan_ += seconds_since(t0);
    return z;
}

ScanPoint World::scan_point(double x, double y) const
{
    const auto t0 = Clock::now();
    // The scanner cannot reach beyond its range: the point is taken at the limit.
    const double half = kScannerRangeXY_nm / 2;
    const double xc = std::clamp(x, -half, half), yc = std::clamp(y, -half, half);
    bool clamped = xc != x || yc != y;
    // The contact normal is the imaged surface's (the locus of the apex):
    // central differences over a step far below the tip radius and every
    // feature's size, far above rounding.
    constexpr double kSlopeStep_nm = 0.01;
    const double h = (this->*imaging_)(xc, yc);
    const double hx = ((this->*imaging_)(xc + kSlopeStep_nm, yc) - (this->*imaging_)(xc - kSlopeStep_nm, yc)) / (2 * kSlopeStep_nm);
    const double hy = ((this->*imaging_)(xc, yc + kSlopeStep_nm) - (this->*imaging_)(xc, yc - kSlopeStep_nm)) / (2 * kSlopeStep_nm);
    const Eigen::Vector3d n = Eigen::Vector3d(-hx, -hy, 1.0).normalized();

    // Sliding in +x at the scan's load (operator.scan_load_nN, else the
    // scene's; the mechanics' contact physics).
    const Eigen::Vector2d m = Eigen::Vector2d::UnitX();
    const double load = scene_.op.scan_load_nN.value_or(scene_.op.load_nN);
    auto f = sliding_friction(m, n, load);
    Eigen::Vector2d fC = f ? Eigen::Vector2d(lever_.R.transpose() * *f) : Eigen::Vector2d::Zero();
    const ZHold zh = hold_z(h, fC.x(), load);
    ScanPoint p;
    // The height image is the z extension plus the set point's deflection:
    // the surface while z follows it, the range's limit when it cannot.
    p.height_nm = zh.clamped ? zh.z_nm + lever_.bend_slope(fC.x(), load) * 2.0 * lever_.l / 3.0 : h;
    clamped = clamped || zh.clamped;
    if (zh.clamped && zh.touching) {
        f = sliding_friction(m, n, zh.fz_nN);   // at the normal force the clamped z leaves
        fC = f ? Eigen::Vector2d(lever_.R.transpose() * *f) : Eigen::Vector2d::Zero();
    }
    if (!zh.touching) {
        p.sn_v = p.sl_v = 0.0;   // off the surface: the lever hangs free
    } else {
        p.sn_v = lever_.sn_volts(fC.x(), zh.fz_nN);
        p.sl_v = lever_.sl_volts(fC.y());
        if (!f) saturate_against(m, p.sn_v, p.sl_v);
    }
    p.sn_v = std::clamp(p.sn_v, -kSignalLimitV, kSignalLimitV);
    p.sl_v = std::clamp(p.sl_v, -kSignalLimitV, kSignalLimitV);
    if (clamped) ++scan_clamped_;
    t_scan_ += seconds_since(t0);
    return p;
}

Eigen::Vector3d World::normal_rough(const Eigen::Vector2d &q) const
{
    const Eigen::Vector2d g = rough_->gradient(q);
    return Eigen::Vector3d(-g.x(), tan_slope_ - g.y(), 1.0).normalized();   // height -y tan + r(q)
}

Eigen::Vector3d World::normal_measured(const Eigen::Vector2d &q) const
{
    Eigen::Vector2d g = measured_->gradient(q);
    if (rough_) g += rough_->gradient(q);
    return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

MeasuredSurface::MeasuredSurface(const GsfGrid &g)
    : nx_(g.xres), ny_(g.yres), dx_nm_(g.xreal_m * 1e9 / g.xres), dy_nm_(g.yreal_m * 1e9 / g.yres)
{
    x0_nm_ = g.xoff_m * 1e9 + 0.5 * dx_nm_;
    ytop_nm_ = (g.yoff_m + g.yreal_m) * 1e9 - 0.5 * dy_nm_;
    // read_gsf keeps every field in gsf.hpp's kGsfRanges; a grid made some other way is held to the same
    if (nx_ < 2 || ny_ < 2 || !(dx_nm_ > 0 && dy_nm_ > 0 && std::isfinite(dx_nm_) && std::isfinite(dy_nm_) && std::isfinite(x0_nm_) &&
                                std::isfinite(ytop_nm_)) || g.values.size() != static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_))
        throw InputError("a measured substrate needs at least 2 x 2 pixels, a finite positive pitch and a finite corner");
    h_nm_.reserve(g.values.size());
    for (const float v : g.values) h_nm_.push_back(static_cast<double>(v) * 1e9);   // m -> nm
}

void MeasuredSurface::cell(const Eigen::Vector2d &q, int *i, int *j, double *t, double *u, bool *out_x, bool *out_y) const
{
    double fx = (q.x() - x0_nm_) / dx_nm_, fy = (ytop_nm_ - q.y()) / dy_nm_;
    *out_x = !(fx >= 0 && fx <= nx_ - 1);
    *out_y = !(fy >= 0 && fy <= ny_ - 1);
    fx = fx >= 0 ? std::min(fx, nx_ - 1.0) : 0.0;   // NaN to 0 too: the cell stays inside the map whatever q is
    fy = fy >= 0 ? std::min(fy, ny_ - 1.0) : 0.0;
    *i = std::min(static_cast<int>(fx), nx_ - 2);
    *j = std::min(static_cast<int>(fy), ny_ - 2);
    *t = fx - *i;
    *u = fy - *j;
}

double MeasuredSurface::height(const Eigen::Vector2d &q) const
{
    int i, j;
    double t, u;
    bool ox, oy;
    cell(q, &i, &j, &t, &u, &ox, &oy);
    const double *r0 = &h_nm_[static_cast<std::size_t>(j) * nx_ + i], *r1 = r0 + nx_;
    return (1 - u) * ((1 - t) * r0[0] + t * r0[1]) + u * ((1 - t) * r1[0] + t * r1[1]);
}

Eigen::Vector2d MeasuredSurface::gradient(const Eigen::Vector2d &q) const
{
    int i, j;
    double t, u;
    bool ox, oy;
    cell(q, &i, &j, &t, &u, &ox, &oy);
    const double *r0 = &h_nm_[static_cast<std::size_t>(j) * nx_ + i], *r1 = r0 + nx_;
    const double dhdx = ((1 - u) * (r0[1] - r0[0]) + u * (r1[1] - r1[0])) / dx_nm_;
    const double dhdy = -((1 - t) * (r1[0] - r0[0]) + t * (r1[1] - r0[1])) / dy_nm_;   // rows run down y
    return Eigen::Vector2d(ox ? 0.0 : dhdx, oy ? 0.0 : dhdy);
}

RoughSurface::RoughSurface(double rms_nm, double corr_nm, uint64_t seed)
{
    // Its own stream, derived from the scene seed ("rough" in ASCII).
    std::mt19937_64 rng(seed ^ 0x726f756768ULL);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    const double sigma_k = std::sqrt(2.0) / corr_nm;           // per component
    const double golden = M_PI * (3.0 - std::sqrt(5.0));        // rad
    const double theta0 = 2 * M_PI * u01(rng);
    for (int i = 0; i < kWaves; ++i) {
        // |k| is Rayleigh(sigma_k): inverse CDF at a jittered quantile.
        const double u = (i + u01(rng)) / kWaves;
        const double kr = sigma_k * std::sqrt(-2.0 * std::log1p(-u));
        const double th = theta0 + i * golden;
        k_.emplace_back(kr * std::cos(th), kr * std::sin(th));
        phase_.push_back(2 * M_PI * u01(rng));
    }
    amp_ = rms_nm * std::sqrt(2.0 / kWaves);
}

double RoughSurface::height(const Eigen::Vector2d &q) const
{
    double z = 0;
    for (int i = 0; i < kWaves; ++i) z += std::cos(k_[i].dot(q) + phase_[i]);
    return amp_ * z;
}

Eigen::Vector2d RoughSurface::gradient(const Eigen::Vector2d &q) const
{
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (int i = 0; i < kWaves; ++i) g -= std::sin(k_[i].dot(q) + phase_[i]) * k_[i];
    return amp_ * g;
}

World::Clock::time_point World::clock_start() const { return timed_ ? Clock::now() : Clock::time_point{}; }

void World::clock_add(double *sum, Clock::time_point t0) const
{
    if (timed_) *sum += seconds_since(t0);
}

std::vector<EffectClock> World::clocks() const
{
    // the timed samples stand for all of them
    const double scale = timed_samples_ > 0 ? static_cast<double>(samples_) / static_cast<double>(timed_samples_) : 0.0;
    std::vector<EffectClock> c;
    c.push_back({scene_.has_effect("bending_offset") ? "mechanics+bending_offset" : "mechanics", t_mech_ * scale});
    if (!wires_.empty())
        c.push_back({scene_.has_effect("wire_flexibility") ? "wires+wire_flexibility" : "wires", t_wires_ * scale});
    for (const auto &e : per_sample_) c.push_back({e->name(), e->seconds * scale});
    c.push_back({scene_.has_effect("tip_convolution") ? "imaging+tip_convolution" : "imaging", t_scan_});
    return c;
}

std::vector<std::string> World::models_built() const
{
    std::vector<std::string> m = {"scanner", "lever", "substrate:" + scene_.substrate};
    if (measured_) m.push_back("substrate_map");
    if (rough_) m.push_back("roughness");
    if (!particles_.empty()) m.push_back("particles");
    if (!wires_.empty())
        m.push_back(scene_.has_effect("wire_flexibility")          ? "wires:flexible_chain"
                    : scene_.wire_model.solver == "numeric" ? "wires:rigid_rod_numeric"
                                                            : "wires:rigid_rod");
    m.push_back(scene_.has_effect("bending_offset") ? "mechanics:compliant_lever" : "mechanics:rigid_lever");
    m.push_back(scene_.has_effect("tip_convolution") ? "imaging:tip_convolution" : "imaging:true_topography");
    for (const auto &e : per_sample_) m.push_back(e->name());
    return m;
}

}  // namespace afm::sim
