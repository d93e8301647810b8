// The tip's contacts (world.hpp): relaxing particles and wires against the
// apex each sample, riding over, pressing with the cone, sliding friction.

#include "world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "world_internal.hpp"

namespace afm::sim {

void World::relax()
{
    // Apex held by the lever (stiffness K_ about its loaded rest position) and
    // by contacts; particles by contacts and their friction threshold. Contact
    // geometry in the sample's frame (apex - drift). Sweeps until the residual
    // is within the tolerances (world.hpp) or the cap.
    const Eigen::Vector2d rest = piezo_ + lever_.normal_offset(contact_load());
    if (!touching()) {
        apex_ = rest;
        lateral_force_.setZero();
        for (auto &p : particles_) p.in_contact = false, p.push_nN = 0, p.chain_nN = 0;
        for (auto &w : wires_) w->in_contact = false, w->lambda_nN = 0;
        return;
    }
    const bool chains = particle_chains_;
    const Eigen::Vector2d apex0 = apex_;
    const double fz = contact_load();
    press_cone();
    const Eigen::Vector3d normal = (this->*normal_at_)(apex_ - drift_);   // the substrate's, at the apex
    // Candidates: particles that can touch the apex during this sample.
    // A contact's force from the last sample starts this one's (a steady
    // push converges at once) while the contact is still closed.
    near(apex_ - drift_, max_reach_nm_ + 1.0, scratch_);
    for (int idx : scratch_) {
        Particle &p = particles_[idx];
        p.in_contact = false;
        if ((apex_ - drift_ - p.c).norm() - p.reach_nm > kSolverGapTol_nm) p.push_nN = 0;
    }
    for (auto &l : wire_links_) l.fresh = l.touched = false;   // a secant within a sample only
    open_wire_contacts();
    for (auto &w : wires_) w->begin_step();        // the sample's pushes share one step (Wire::begin_step)
    int sweeps = 0;
    double force = 0;
    bool converged = false;
    for (;; ++sweeps) {
        const Eigen::Vector2d g = apex_pull(rest);
        const Eigen::Vector2d excess = apex_excess(g, fz, normal);
        force = excess.norm();
        const bool balanced = force <= kSolverForceTol_nN && sweep_gap_nm_ <= kSolverGapTol_nm && wires_settled();
        converged = balanced && wire_gap_nm_ <= kSolverGapTol_nm;
        if ((sweeps > 0 && converged) || sweeps == solver_.cap) break;
        if (sweeps > 0 && balanced) close_wire_contacts();   // in balance with a wire's contact open: its multiplier's step
        slide_apex(excess);
        push_particles(chains);
        push_wires(apex_ - drift_);
        if (!wires_.empty()) measure_wire_links();
    }
    for (auto &w : wires_) w->end_step();
    record_solve(sweeps, force, std::max(sweep_gap_nm_, wire_gap_nm_), converged);
    last_motion_ = unit_or(apex_ - apex0, last_motion_);
    lateral_force_ = -(K_ * (rest - apex_));
    count_ridden();
}

bool World::wires_settled() const
{
    for (const auto &w : wires_)
        if (!w->settled(kSolverForceTol_nN)) return false;
    return true;
}

void World::record_solve(int sweeps, double force_nN, double gap_nm, bool converged)
{
    ++solver_.samples;
    solver_.sweeps += sweeps;
    solver_.max_sweeps = std::max(solver_.max_sweeps, sweeps);
    solver_.worst_force_nN = std::max(solver_.worst_force_nN, force_nN);
    solver_.worst_gap_nm = std::max(solver_.worst_gap_nm, gap_nm);
    solver_.unconverged += !converged;
}

void World::count_ridden()
{
    for (const auto &w : wires_)
        if (w->ridden) {
            ++ridden_samples_;   // a sample in which the tip rode over a wire (once, however many wires or sweeps)
            return;
        }
}

Eigen::Vector2d World::apex_pull(const Eigen::Vector2d &rest)
{
    // The force on the apex from the lever, from every particle's contact
    // force (push_nN, along the line of centres) and from every wire's
    // penalty; which wire contacts press it (wire_links_: they meet its
    // step). sweep_gap_nm_: the worst contact gap, penetration or a gap
    // under load, of the particles and of the chains.
    const Eigen::Vector2d as = apex_ - drift_;
    Eigen::Vector2d g = K_ * (rest - apex_);
    sweep_gap_nm_ = 0;
    wire_gap_nm_ = 0;
    for (int idx : scratch_) {
        const Particle &p = particles_[idx];
        const Eigen::Vector2d d = as - p.c;
        const double gap = d.norm() - p.reach_nm;
        if (gap < 0 || p.push_nN > 0) {
            sweep_gap_nm_ = std::max(sweep_gap_nm_, p.push_nN > 0 ? std::fabs(gap) : -gap);
            g += p.push_nN * unit_or(d, -last_motion_);
        }
        if (particle_chains_)
            for (int j : scratch_) {
                if (j == idx) continue;
                const double e = (p.c - particles_[j].c).norm() - p.r - particles_[j].r;
                sweep_gap_nm_ = std::max(sweep_gap_nm_, -e);
            }
    }
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire &w = *wires_[i];
        WireLink &l = wire_links_[i];
        const double rt = wire_rt_[i];
        l.pressing = l.touched;   // the last step stopped at its surface (l.n its normal there)
        l.touched = false;
        w.pulled = false;
        // ridden: the tip rode over it at the last push (push_wires)
        if (w.ridden || !w.near(as, rt + w.lambda_nN / k_contact_)) continue;
        // Re-linearised each sweep: the force's direction and its stiffness
        // across it (the normal turns as the apex slides along a bend).
        const TipPush tp = w.tip_push(as, rt, k_contact_);
        const double f = tp.force.norm();
        if (!(f > 0)) continue;
        l.pressing = true;
        l.n = tp.force / f;
        const Eigen::Vector2d tau(-l.n.y(), l.n.x());
        l.kt_nN_per_nm = std::max(0.0, tau.dot(tp.stiffness * tau));
        wire_gap_nm_ = std::max(wire_gap_nm_, std::fabs(f - w.lambda_nN) / k_contact_);   // closed under load
        g += tp.force;
        w.pulled = true;
    }
    return g;
}

void World::measure_wire_links()
{
    // After the wires' push at this sweep's apex: each contact's force and
    // the apex's place along its normal; with the last such point of the
    // sample, the secant stiffness of the force against the apex's advance
    // into the wire (a sliding wire's force stays: 0; a held one: k_c).
    constexpr double kLinkMargin_nm = 10;   // a step that left the contact still measures within this of it
    const Eigen::Vector2d as = apex_ - drift_;
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire &w = *wires_[i];
        WireLink &l = wire_links_[i];
        const double rt = wire_rt_[i];
        double pen = 0, u;
        Eigen::Vector2d n;
        if (!w.near(as, rt + kLinkMargin_nm) || w.ridden) {
            l.fresh = false;
            continue;
        }
        w.contact(as, rt, pen, n, u);   // apart too: a point of 0 force, so a step that left the contact measures its chord
        const Eigen::Vector2d F = w.tip_push(as, rt, k_contact_).force;
        const double f = F.norm();
        if (f > 0) n = F / f;
        const double s = as.dot(n);
        if (l.fresh && std::fabs(s - l.s_nm) > 1e-9) l.k_nN_per_nm = std::clamp(-(f - l.f_nN) / (s - l.s_nm), 0.0, k_contact_);
        l.s_nm = s, l.f_nN = f, l.fresh = true;
    }
}

void World::open_wire_contacts()
{
    // A wire contact apart at the sample's start (the apex moved off it, or
    // rode over it) has no force: its multiplier starts again from 0.
    const Eigen::Vector2d as = apex_ - drift_;
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire *w = wires_[i].get();
        const double rt = wire_rt_[i];
        if (w->lambda_nN == 0) continue;
        if (w->ridden || !w->near(as, rt + w->lambda_nN / k_contact_) || !(w->tip_push(as, rt, k_contact_).force.norm() > 0))
            w->lambda_nN = 0;
    }
}

void World::close_wire_contacts()
{
    // The multipliers' step (Wire::lambda_nN): each contact's force after
    // the push becomes its multiplier, so the next push closes what the
    // penalty left open (a ride-over, or a wire apart, takes none).
    const Eigen::Vector2d as = apex_ - drift_;
    for (auto &l : wire_links_) l.fresh = false;   // the forces move: the secants start again
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire *w = wires_[i].get();
        const double rt = wire_rt_[i];
        w->lambda_nN = w->ridden || !w->near(as, rt + w->lambda_nN / k_contact_) ? 0.0 : w->tip_push(as, rt, k_contact_).force.norm();
    }
}

Eigen::Vector2d World::apex_excess(const Eigen::Vector2d &g, double fz, const Eigen::Vector3d &normal) const
{
    // Substrate: the tip stays while the force it must supply, S = (-g,
    // F_z) (lever and contacts horizontal, the set point vertical), lies in
    // its friction cone about the surface normal n: |S_t| <= mu (S . n +
    // F_adh). Otherwise the excess, |S_t| less that capacity, drives it
    // along the surface against S_t (its horizontal direction, frame A).
    const Eigen::Vector3d S(-g.x(), -g.y(), fz);
    const double sn = S.dot(normal);
    const Eigen::Vector3d St = S - sn * normal;
    const double capacity = tip_mu_ * std::max(0.0, sn + tip_adhesion_nN_);
    const double stn = St.norm();
    const Eigen::Vector2d mh = -St.head<2>();
    const double mhn = mh.norm();
    if (stn <= capacity || mhn <= 1e-12) return Eigen::Vector2d::Zero();
    return (stn - capacity) / mhn * mh;
}

void World::slide_apex(const Eigen::Vector2d &excess)
{
    // The apex slips along the excess (against the substrate's friction:
    // the slip direction is the friction's, whatever the lever's
    // anisotropy) by the step that takes the excess up in the stiffness it
    // meets along that direction, but no further than the surface of a
    // wire contact the step would enter.
    const double e = excess.norm();
    if (!(e > 0)) return;
    const Eigen::Vector2d m = excess / e;
    apex_ += stop_at_wires(m, e / step_stiffness(m)) * m;
}

double World::step_stiffness(const Eigen::Vector2d &m) const
{
    // Along m: the lever's, and each pressing wire contact's: along its
    // normal its secant (k_contact_ until measured) for an advance into the
    // wire, k_contact_ for a retreat from it; across it the turning of its
    // normal (kt, the wire held).
    double k = m.dot(K_ * m);
    for (const auto &l : wire_links_) {
        if (!l.pressing) continue;
        const double a = m.dot(l.n), b = m.x() * -l.n.y() + m.y() * l.n.x();
        k += (a > 0 || l.k_nN_per_nm < 0 ? k_contact_ : l.k_nN_per_nm) * a * a + l.kt_nN_per_nm * b * b;
    }
    return k;
}

double World::stop_at_wires(const Eigen::Vector2d &m, double t)
{
    // A wire the apex does not press yet offers no stiffness: a step into
    // it would go as far as the lever alone takes it, deep into the
    // contact. The step stops where the contact's force begins (the axis's
    // distance along the contact's normal, to first order), and the next
    // sweep meets the contact's stiffness (touched).
    const Eigen::Vector2d as = apex_ - drift_;
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire &w = *wires_[i];
        WireLink &l = wire_links_[i];
        const double rt = wire_rt_[i];
        if (l.pressing || w.ridden || !w.near(as, rt + w.lambda_nN / k_contact_ + t)) continue;
        double pen, u;
        Eigen::Vector2d n;
        w.contact(as, rt, pen, n, u);
        const double open = -(pen + w.lambda_nN / k_contact_), a = m.dot(n);   // open >= 0: no force here
        if (a < 0 && open < -a * t) {
            t = std::max(0.0, open / -a);
            l.touched = true;
            l.n = n;
            l.kt_nN_per_nm = 0;
        }
    }
    return t;
}

void World::push_particles(bool chains)
{
    // A projected Gauss-Seidel on the apex's contacts: each contact's force
    // lambda (push_nN) moves by the lever's stiffness along the line of
    // centres times the gap, kept within [0, the particle's resistance];
    // below it the particle holds and the apex is put back on its surface,
    // at it the particle slides and is put on the apex's (the contact
    // closed exactly either way). The resistance is the threshold (pressed
    // by the cone: down_force) plus what the particles it pushes pass on
    // (particle_contacts).
    for (std::size_t q = 0; q < scratch_.size(); ++q) {
        const int i = scratch_[q];
        Particle &p = particles_[i];
        const Eigen::Vector2d as = apex_ - drift_;
        const Eigen::Vector2d d = p.c - as;
        const double reach = p.reach_nm;
        const double gap = d.norm() - reach;
        if (gap < 0 || p.push_nN > 0) {
            const Eigen::Vector2d n = unit_or(d, last_motion_);
            const double resist = p.threshold_nN * cone_factor_ + p.chain_nN;
            const double lam = std::clamp(p.push_nN - n.dot(K_ * n) * gap, 0.0, resist);
            p.push_nN = lam;
            p.in_contact = lam > 0 || gap < 0;
            if (gap < 0 && lam >= resist) {
                p.c = as + reach * n;   // slides: on the apex's surface
                grid_.update(i, p.c);
            } else if (gap < 0) {
                apex_ += gap * n;       // holds: the apex back on its surface
            }
        }
        if (chains) push_neighbours(q);
    }
}

void World::push_neighbours(std::size_t q)
{
    // particle_contacts: a particle that overlaps a neighbour puts it on its
    // surface (a pushed particle moves its neighbours at their own
    // resistance: they join the sweep), and passes the resistance of those
    // it touches ahead on along its push (chain_nN, the next bound of the
    // apex's contact with it).
    const int i = scratch_[q];
    Particle &p = particles_[i];
    const Eigen::Vector2d along = unit_or(p.c - (apex_ - drift_), last_motion_);
    double passed = 0;
    near(p.c, p.r + max_radius_, scratch2_);
    for (int j : scratch2_) {
        if (j == i) continue;
        Particle &o = particles_[j];
        const Eigen::Vector2d e = o.c - p.c;
        const double reach = p.r + o.r;
        const double en = e.norm();
        if (en > reach + kSolverGapTol_nm) continue;
        const Eigen::Vector2d u = unit_or(e, along);
        if (en < reach) {
            o.c = p.c + reach * u;
            grid_.update(j, o.c);
        }
        passed += std::max(0.0, u.dot(along)) * (o.threshold_nN + o.chain_nN);
        if (std::find(scratch_.begin(), scratch_.end(), j) == scratch_.end()) scratch_.push_back(j);
    }
    p.chain_nN = passed;
}

void World::push_wires(const Eigen::Vector2d &as2)
{
    // A wire the apex left within the sample is pushed once more (its step
    // ends in balance without the tip); its multiplier stays the sample's.
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire *w = wires_[i].get();
        const double rt = wire_rt_[i];
        if (!w->near(as2, rt + w->lambda_nN / k_contact_) && !w->in_contact) {
            w->ridden = false;
            continue;
        }
        const auto t0 = clock_start();
        // The contact's force is the tip's push once the apex's balance has
        // taken it (pulled); the sweep in which the apex first steps into
        // the wire, before that, overshoots by a penalty artefact, and is
        // no lift-off (a ride already under way stays one).
        const double ride = w->pulled || w->ridden ? ride_push_nN(i) : std::numeric_limits<double>::infinity();
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
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire *w = wires_[i].get();
        const double rt = wire_rt_[i];
        if (!w->near(as, rt + w->lambda_nN / k_contact_)) { w->in_contact = false, w->lambda_nN = 0; continue; }
        const auto t0 = clock_start();
        w->push(as, rt, k_contact_, ride_push_nN(i));
        clock_add(&t_wires_, t0);
        if (!w->ridden) f += w->tip_push(as, rt, k_contact_).force;
    }
    close_wire_contacts();   // one step a sample: the next sample's push closes this one's penalty
    count_ridden();
    // A particle the apex overlaps slides at its threshold (pressed by the
    // cone: down_force) onto the apex's surface, the contact closed exactly;
    // one it only touches keeps the force of the last push (static, within
    // [0, threshold]); apart, none. Exact in one pass: one sweep.
    near(as, max_reach_nm_ + 1.0, scratch_);
    double gap_worst = 0;
    for (int idx : scratch_) {
        Particle &p = particles_[idx];
        const Eigen::Vector2d d = p.c - as;
        const double reach = p.reach_nm;
        const double gap = d.norm() - reach;
        const Eigen::Vector2d n = unit_or(d, last_motion_);
        if (gap < 0) {
            p.push_nN = p.threshold_nN * cone_factor_;
            p.c = as + reach * n;
            grid_.update(idx, p.c);
        } else if (gap > kSolverGapTol_nm) {
            p.push_nN = 0;
        }
        p.in_contact = p.push_nN > 0;
        f -= p.push_nN * n;
        if (p.push_nN > 0) gap_worst = std::max(gap_worst, std::max(gap, 0.0));
    }
    record_solve(1, 0.0, gap_worst, true);
    lateral_force_ = f;
}

void World::init_reach()
{
    // The apex's circle meets the object's outline in the plane: the reach
    // is R + r. The card models the same (fw_particles, fw_wire: r_tip + r),
    // and its display is held to the truth within a few nm (the fidelity
    // check, test_end_to_end's 5 nm); the 3-D reach
    // (TipGeometry::resting_reach_nm: the cone's flank, 78.4 nm from a
    // 100 nm object under the paper's tip) would put every pushed object
    // 18.4 nm beyond the card's model. It waits for the card's model of
    // the reach (physics.md 14, "What it changes").
    const double rt = scene_.probe.tip_radius_nm;
    max_reach_nm_ = 0;
    for (auto &p : particles_) {
        p.reach_nm = rt + p.r;
        max_reach_nm_ = std::max(max_reach_nm_, p.reach_nm);
    }
    // Cells as large as the widest contact (particle-particle, or the
    // apex's reach), so a contact query visits at most 3 x 3 cells.
    grid_ = Grid(std::max(2 * max_radius_, max_reach_nm_) + 1.0);
    for (std::size_t i = 0; i < particles_.size(); ++i) grid_.insert(static_cast<int>(i), particles_[i].c);
    wire_rt_.assign(wires_.size(), rt);
}

LiftInput World::wire_lift_input(std::size_t i, double friction_nN) const
{
    // The wire's segment nearest the apex, at its axis height over the
    // substrate plane; the apex on that plane (z = 0) where it stands.
    const Wire &w = *wires_[i];
    const Eigen::Vector2d as = apex_ - drift_;
    const auto &x = w.nodes();
    std::size_t best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k + 1 < x.size(); ++k) {
        const Eigen::Vector2d e = x[k + 1] - x[k];
        const double t = std::clamp((as - x[k]).dot(e) / std::max(e.squaredNorm(), 1e-300), 0.0, 1.0);
        const double d = (x[k] + t * e - as).norm();
        if (d < best_d) best_d = d, best = k;
    }
    const double z = wire_axis_height_nm(i);
    LiftInput in;
    in.radius_nm = scene_.probe.tip_radius_nm;
    in.half_angle_rad = gamma_rad_;
    in.apex_xy = as;
    in.motion = last_motion_;
    in.a = Eigen::Vector3d(x[best].x(), x[best].y(), z);
    in.b = Eigen::Vector3d(x[best + 1].x(), x[best + 1].y(), z);
    in.cylinder_radius_nm = 0.5 * w.d_nm;
    in.load_nN = contact_load();
    in.lift_nN = contact_load() + tip_adhesion_nN_;
    in.friction_nN = friction_nN;
    return in;
}

void World::press_cone()
{
    // down_force: the cone presses a wire it pushes by H n_z / |n_h|, n the
    // 3-D contact's normal (tip_geometry) at the lever's pose under the
    // last sample's lateral force; a particle it pushes at psi = gamma +
    // theta_t from the horizontal (physics.md 5), theta_t = F_y h / k_theta
    // the lever's twist under that force.
    if (!down_force_) return;
    const Eigen::Vector2d fC = lever_.R.transpose() * lateral_force_;
    const double psi = gamma_rad_ + std::fabs(lever_.twist(fC.y()));
    const double t = psi < M_PI / 2 ? std::tan(psi) : std::numeric_limits<double>::infinity();
    const Eigen::Vector2d as = apex_ - drift_;
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        Wire &w = *wires_[i];
        if (!w.near(as, wire_rt_[i] + 1.0)) continue;   // the press matters in contact only
        LiftInput in = wire_lift_input(i, 0.0);
        TipPose pose;
        pose.apex_nm = Eigen::Vector3d(in.apex_xy.x(), in.apex_xy.y(), 0.0);
        pose.tilt_rad = lever_.bend_slope(fC.x(), in.load_nN);
        pose.twist_rad = lever_.twist(fC.y());
        pose.alpha_rad = lever_.alpha;
        const Eigen::Vector3d n = TipGeometry(in.radius_nm, in.half_angle_rad, pose).cylinder(in.a, in.b, in.cylinder_radius_nm).normal;
        const double nh = n.head<2>().norm();
        w.press_tan = nh > 0 ? std::max(0.0, n.z()) / nh : std::numeric_limits<double>::infinity();
    }
    const double den = 1.0 - particle_mu_ * t;
    cone_factor_ = den > 0 ? 1.0 / den : std::numeric_limits<double>::infinity();
}

double World::ride_push_nN(std::size_t i) const
{
    // The tip's own vertical balance with the 3-D contact's normal
    // (lift_off_push): a push H through the contact lifts the tip by
    // H n_z / |n_h| against its load and its adhesion; past both the apex
    // leaves the substrate and climbs over the wire instead of pressing it,
    // while the wire slides as well as once it is squeezed. Whether the
    // wire needs more is its own friction's answer (Wire::push), never eq.
    // 29-30's closed form. The pose is the lever's under the push itself
    // (plus the tip's own sliding friction, along the motion), not the
    // last sample's force: a ride-over drops the push, and a twist that
    // followed it would let the tip press again at once.
    // Without down_force the tip's lift is not modelled: no limit.
    if (!down_force_ || !(wires_[i]->press_tan > 0)) return std::numeric_limits<double>::infinity();
    const double friction = tip_mu_ * (contact_load() + tip_adhesion_nN_);
    return lift_off_push(lever_, wire_lift_input(i, friction)).push_nN;
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

World::WireSolver World::wire_solver() const
{
    WireSolver r;
    for (const auto &w : wires_) {
        const auto *f = dynamic_cast<const FlexibleWire *>(w.get());
        if (!f) continue;
        ++r.flexible;
        r.solved += f->solved;
        r.unconverged += f->unconverged;
        r.regularised += f->regularised;
        r.worst_iterations = std::max(r.worst_iterations, f->worst_iterations);
        r.max_iterations = std::max(r.max_iterations, f->max_iterations);
    }
    return r;
}

}  // namespace afm::sim
