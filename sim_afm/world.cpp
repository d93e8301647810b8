// The simulated AFM's world (world.hpp): the scene built into the sample, the
// lever and the piezo, and one sample's step: command, z servo, the tip's
// force, the effects' clocks. Its parts: world_contact.cpp (the tip's
// contacts and pushes), world_imaging.cpp (what a scan sees),
// world_trenches.cpp (grooves, trenches and the rods they hold),
// surfaces.cpp (measured and rough substrates).

#include "world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "world_internal.hpp"

namespace afm::sim {

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
    particle_chains_ = s.has_effect("particle_contacts");
    const double threshold = ps.mu * ps_adh + ps.shear_strength_MPa * ps.contact_area_nm2 * 1e-3;
    for (const auto &p : s.particles) {
        particles_.push_back(Particle{p.id, Eigen::Vector2d(p.x_nm, p.y_nm), p.radius_nm, threshold});
        max_radius_ = std::max(max_radius_, p.radius_nm);
    }
    // Cells as large as the widest contact (particle-particle), so a contact
    // query visits at most 3 x 3 cells.
    landmarks_ = s.landmarks;
    build_wires(s);
    wire_links_.resize(wires_.size());
    init_reach();
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
    piezo_ = target_ = drive_ = Eigen::Vector2d(start.x, start.y);
    apex_ = piezo_;
    piezo_model_ = make_piezo(s, piezo_);
    if (s.has_effect("scan_artefacts")) artefacts_ = std::make_unique<ScanArtefacts>(s);

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
    load_set_nN_ = load_nN;
    load_nN_ = load_nN - zero_load_nN_;
    engaged_ = engaged;
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
    // Scanner: the drive towards its set point at a bounded speed; the
    // piezo where the drive puts it.
    const Eigen::Vector2d to = target_ - drive_;
    const double max_step = scanner_speed_nm_per_s_ * dt_;
    drive_ += to.norm() > max_step ? Eigen::Vector2d(to.normalized() * max_step) : to;
    piezo_ = piezo_model_ ? piezo_model_->step(drive_) : drive_;

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
    out.piezo_nm = Eigen::Vector3d(drive_.x(), drive_.y(), piezo_z_);
    return out;
}

Eigen::Vector3d World::tip_force() const
{
    if (!touching()) return Eigen::Vector3d::Zero();
    return Eigen::Vector3d(lateral_force_.x(), lateral_force_.y(), contact_load());
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
    if (piezo_model_ && piezo_model_->hx) m.push_back("piezo_hysteresis");
    if (piezo_model_ && piezo_model_->cx) m.push_back("piezo_creep");
    if (artefacts_) m.push_back("scan_artefacts");
    return m;
}

}  // namespace afm::sim
