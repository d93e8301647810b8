// The planner's rods (planner.hpp, stage 4): a zigzag of end pushes on the
// card's own rod model (fw_wire), with the trenches that hold it.

#include "planner.hpp"

extern "C" {
#include "fw_board.h"
#include "fw_units.h"
#include "fw_wire.h"
}

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <deque>
#include <sstream>

#include "card_setup.hpp"
#include "fidelity.hpp"
#include "pattern.hpp"
#include "planner_internal.hpp"
#include "profile.hpp"

namespace afm {

bool Planner::rod_model(const wire_t &w, fw_wire_t *rod) const
{
    // The rod as the card holds it, the trenches the card recorded (the
    // objects' copy, frame A), which of its pieces they hold.
    const int32_t a[2] = {fwu_pm_from_nm(w.x_nm[0]), fwu_pm_from_nm(w.y_nm[0])};
    const int32_t b[2] = {fwu_pm_from_nm(w.x_nm[w.n - 1]), fwu_pm_from_nm(w.y_nm[w.n - 1])};
    if (fw_wire_init_ends(rod, a, b, fwu_pm_from_nm(w.diameter_nm)) != FW_OK) return false;
    std::vector<fw_trench_point_t> pts;
    for (const auto &t : model_->trenches)
        for (int i = 0; i < t.n; ++i)
            pts.push_back({fwu_pm_from_nm(t.x_nm[i]), fwu_pm_from_nm(t.y_nm[i]), fwu_pm_from_nm(t.depth_nm[i]),
                           fwu_pm_from_nm(t.width_nm[i]), i == 0 ? FW_LITHO_STROKE_START : 0u});
    return fw_wire_hold(rod, &wire_tip_, pts.data(), static_cast<int32_t>(pts.size())) == FW_OK;
}

Planner::EndGains Planner::end_gains(const wire_t &w, double l_nm) const
{
    // How the firmware's model moves its ends per nm of a push at l (with
    // the trenches' hold, the blend and the clamps): a copy pushed by a
    // small step, its ends measured along the normal.
    EndGains g;
    fw_wire_t rod{};
    if (!rod_model(w, &rod)) return g;
    fw_wire_static_t sp{};
    const int32_t l = std::clamp(fwu_pm_from_nm(l_nm), 0, rod.length_pm);
    if (fw_wire_static_point_held(rod.length_pm, l, rod.held, rod.hold_q16, &sp) != FW_OK || !sp.s_defined) return g;
    const int32_t dn = std::max(1, std::min({10000, rod.length_pm / 4, sp.lever_pm}));
    int32_t a0[2], b0[2], a1[2], b1[2];
    fw_wire_ends_pm(&rod, a0, b0);
    const Vec2 n = perp(unit(Vec2{double(b0[0] - a0[0]), double(b0[1] - a0[1])}));
    fw_wire_t moved = rod;
    if (fw_wire_push(&moved, l, dn, nullptr) != FW_OK) return g;
    fw_wire_ends_pm(&moved, a1, b1);
    g.a = dot(Vec2{double(a1[0] - a0[0]), double(a1[1] - a0[1])}, n) / dn;
    g.b = dot(Vec2{double(b1[0] - b0[0]), double(b1[1] - b0[1])}, n) / dn;
    g.ok = true;
    return g;
}

bool Planner::push_wire_end(int wire_id, bool end_b, double dn_nm)
{
    const PlanSpec &ps = s_.op.plan;
    const wire_t *w = nullptr;
    for (const auto &x : model_->wires)
        if (x.id == wire_id) w = &x;
    if (!w || w->n < 2) return false;
    const Vec2 A{w->x_nm[0], w->y_nm[0]}, B{w->x_nm[w->n - 1], w->y_nm[w->n - 1]};
    const double L = norm(B - A);
    const Vec2 a = unit(B - A), n = perp(a);
    const Vec2 Q = end_b ? B - (kEndAt * L) * a : A + (kEndAt * L) * a;
    const double sgn = dn_nm >= 0 ? 1.0 : -1.0;
    const double R = w->diameter_nm / 2 + s_.probe.tip_radius_nm;
    travel(Q - (sgn * (R + ps.approach_nm)) * n, false, ps.travel_speed_nm_per_s);
    travel(tip_, true, ps.speed_nm_per_s);
    // The push point ends dn along the normal, the apex on the rod's surface
    // (the rod moves until the apex sits on it: no pressing in).
    travel(Q + (dn_nm - sgn * R) * n, true, ps.speed_nm_per_s);
    travel(tip_ - (sgn * kBackOff_nm) * n, true, ps.speed_nm_per_s);
    travel(tip_, false, ps.travel_speed_nm_per_s);
    return true;
}

void Planner::run_wires()
{
    for (const WireTargetSpec &t : s_.wire_targets) {
        PlanItem item;
        item.kind = "wire";
        item.id = t.id;
        item.target_nm = {t.x_nm, t.y_nm};
        item.target_angle_deg = t.angle_deg;
        RodPushes st;
        while (push_rod_once(t, item, st)) {}
        if (item.why.empty()) check_rod_by_scan(item, t);
        rep_.items.push_back(item);
    }
}

// The rod's pose and its target's, as one push sees them.
struct Planner::RodPose {
    Vec2 A, B;        // the model's ends
    double L;         // its length
    Vec2 a, n, C;     // its axis, normal and centre
    Vec2 T, As, Bs;   // the target's centre and ends (labelled to need the smaller turn), with the drift
};

Planner::RodPose Planner::rod_pose(const wire_t &w, const PlanItem &item, const WireTargetSpec &t) const
{
    RodPose p;
    p.A = {w.x_nm[0], w.y_nm[0]};
    p.B = {w.x_nm[w.n - 1], w.y_nm[w.n - 1]};
    p.L = norm(p.B - p.A);
    p.a = unit(p.B - p.A);
    p.n = perp(p.a);
    p.C = 0.5 * (p.A + p.B);
    p.T = item.target_nm + drift();
    const RodEnds ends = rod_target_ends(p.A, p.B, p.T, t.angle_deg);
    p.As = ends.a;
    p.Bs = ends.b;
    return p;
}

// Held along its whole length by a trench that also holds the target pose:
// in the trench it was meant for, and no deeper.
bool Planner::held_in_target_trench(const wire_t &w, const RodPose &p) const
{
    fw_wire_t rod{}, at_target{};
    wire_t target_rod = w;
    target_rod.x_nm = {p.As.x, p.Bs.x};
    target_rod.y_nm = {p.As.y, p.Bs.y};
    target_rod.n = 2;
    return rod_model(w, &rod) && rod.held == 0xffffffffu && rod_model(target_rod, &at_target) && at_target.held == 0xffffffffu;
}

// Where the ends must go along the normal (eA, eB). A rod moves only along
// its normal: while its centre is far from the target (carrying), it is
// turned until its normal points the way and then carried along it; near
// (from then on), its ends are pushed to the target's.
void Planner::rod_end_errors(const RodPose &p, RodPushes &st, double *eA, double *eB) const
{
    *eA = dot(p.As - p.A, p.n);
    *eB = dot(p.Bs - p.B, p.n);
    const Vec2 way = p.T - p.C;
    if (st.carrying && norm(way) <= kCarryUntil * s_.op.plan.wire_tolerance_nm) st.carrying = false;
    if (!st.carrying) return;
    Vec2 want = perp(unit(way));   // the axis whose normal is the way
    if (dot(want, p.a) < 0) want = -1.0 * want;
    const double turn = std::atan2(p.a.x * want.y - p.a.y * want.x, dot(p.a, want));
    // Far off the way: turned alone. Else carried and turned together (the
    // zigzag of end pushes swings it either side).
    const double carry = std::fabs(turn) > kTurnTol_deg * kPi / 180 ? 0.0 : dot(way, p.n);
    *eA = carry - (p.L / 2) * std::sin(turn);
    *eB = carry + (p.L / 2) * std::sin(turn);
}

// Why the rod cannot be pushed now ("" if it can): stuck, along the lever's
// axis, or out of pushes.
std::string Planner::rod_refusal(const wire_t &w, const RodPose &p, const PlanItem &item, RodPushes &st) const
{
    if (item.pushes > 0 && norm(p.A - st.lastA) < kStuck_nm && norm(p.B - st.lastB) < kStuck_nm) {
        if (++st.unmoved >= 3) return "stuck: three end pushes in a row left its model where it was";
    } else {
        st.unmoved = 0;
    }
    st.lastA = p.A;
    st.lastB = p.B;
    // Pushed along its normal: along the lever's axis the firmware cannot
    // see the push (F_x unobservable) and its model stays.
    if (std::fabs(dot(p.n, geometry(w.diameter_nm / 2).lever_axis)) > std::cos(kMinLeverAngle_deg * kPi / 180))
        return "its normal lies along the lever's axis, where the firmware cannot see a push: turn it first or change the scan angle";
    if (item.pushes >= 10 * s_.op.plan.max_pushes) {
        std::ostringstream m;
        m.precision(3);
        m << "off its target by " << item.error_nm << " nm after " << item.pushes << " end pushes";
        return m.str();
    }
    return "";
}

// One end push of the rod towards its target; false when it is done: on
// target, or item.why (or item.note) says why it stops.
bool Planner::push_rod_once(const WireTargetSpec &t, PlanItem &item, RodPushes &st)
{
    const PlanSpec &ps = s_.op.plan;
    const wire_t *w = nullptr;
    for (const auto &x : model_->wires)
        if (x.id == t.id) w = &x;
    if (!w || w->n < 2) {
        item.why = "not in the firmware's model";
        return false;
    }
    const RodPose p = rod_pose(*w, item, t);
    item.error_nm = std::max(norm(p.As - p.A), norm(p.Bs - p.B));
    if (item.error_nm <= ps.wire_tolerance_nm) return false;
    if (held_in_target_trench(*w, p)) {
        item.note = "held along its whole length by the trench its target lies in";
        return false;
    }
    item.why = rod_refusal(*w, p, item, st);
    if (!item.why.empty()) return false;
    double eA, eB;
    rod_end_errors(p, st, &eA, &eB);
    // The end pushes that remove both: x at L/10 from A, y at L/10 from B,
    // from the firmware's static points of each (with the trenches that hold
    // the rod): gA x + gB y = e per end.
    const EndGains gA = end_gains(*w, kEndAt * p.L), gB = end_gains(*w, (1 - kEndAt) * p.L);
    const double det = gA.a * gB.b - gB.a * gA.b;
    if (!gA.ok || !gB.ok || std::fabs(det) < 1e-9) {
        item.why = "the rod's static point is undefined";
        return false;
    }
    const double x = (eA * gB.b - gB.a * eB) / det, y = (gA.a * eB - gA.b * eA) / det;
    const bool at_b = std::fabs(y) > std::fabs(x);
    const double dn = std::clamp(at_b ? y : x, -ps.wire_step_nm, ps.wire_step_nm);
    if (std::getenv("AFM_PLAN_TRACE"))
        std::fprintf(stderr, "plan: t %.2f rod %d A (%.1f, %.1f) B (%.1f, %.1f) eA %.1f eB %.1f push %s by %.1f nm\n", instrument_->time_s(),
                     t.id, p.A.x, p.A.y, p.B.x, p.B.y, eA, eB, at_b ? "B" : "A", dn);
    ++item.pushes;
    ++rep_.pushes;
    push_wire_end(t.id, at_b, dn);
    return true;
}

void Planner::check_rod_by_scan(PlanItem &item, const WireTargetSpec &t)
{
    // The rod's model is on target: a scan of the target's square says
    // whether the rod is (its pose as the renderer's final check finds it).
    const PlanSpec &ps = s_.op.plan;
    double length = 0, d = 0;
    for (const auto &w : s_.wires)
        if (w.id == t.id) length = std::hypot(w.x1_nm - w.x0_nm, w.y1_nm - w.y0_nm), d = w.diameter_nm;
    const Vec2 T = item.target_nm + drift();
    const double size = rod_check_side_nm(ps, length);
    const int px = static_cast<int>(std::lround(ps.scan_px * size / ps.scan_size_nm));
    const Field f{T.x - size / 2, T.y - size / 2, size, px};
    if (engaged_) travel(tip_, false, ps.travel_speed_nm_per_s);
    const cv::Mat h = instrument_->scan(f);
    ++rep_.local_scans;
    ++item.scans;
    wait_s(ps.scan_s * size / ps.scan_size_nm);
    const TipShape tip = s_.has_effect("tip_convolution") ? TipShape{s_.probe.tip_radius_nm, s_.probe.tip_half_angle_deg} : TipShape{};
    const RodCheck c = check_rod(h, f, {T.x, T.y}, t.angle_deg, length, wire_footprint_nm(d / 2, tip) + ps.wire_tolerance_nm);
    if (!c.found) {
        item.why = "not found in the scan of its target";
        return;
    }
    item.error_nm = c.error_nm;
    item.placed = c.error_nm <= ps.wire_tolerance_nm;
    if (!item.placed) {
        std::ostringstream m;
        m.precision(3);
        m << "its model is on target but the scan shows it " << c.error_nm << " nm off";
        item.why = m.str();
    }
}


}  // namespace afm
