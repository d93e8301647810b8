// Grooves and trenches (world.hpp): the substrate's engraved lines, their
// depth profile, and the rods they seat and hold.

#include "world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "world_internal.hpp"

namespace afm::sim {

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

}  // namespace afm::sim
