// The planner's simulated time from the scene (plan_estimate.hpp says what
// it counts and why it is a floor).
#include "plan_estimate.hpp"

#include <algorithm>
#include <cmath>

#include "planner.hpp"
#include "planner_internal.hpp"

namespace afm {

namespace {

// One job's strokes from `from` to `to` (nm) with the stroke limit *limit
// (grown after each, as when the model never strays): the strokes made.
int strokes_to(Vec2 from, Vec2 to, double *limit)
{
    double left = norm(to - from);
    int n = 0;
    do {   // one stroke at least: the planner pushes every particle onto its site
        left -= left <= 1.5 * *limit ? left : *limit;   // stroke_length's rule
        *limit = std::min(kStrokeMax_nm, *limit * 1.5);
        ++n;
    } while (left > 0);
    return n;
}

// The rods (objects.wire_targets), after the particles as run_wires does:
// each rod not yet within wire_tolerance_nm of its target takes at least
// one end push (the lifted travel to its end's approach, the push of its
// largest end error up to wire_step_nm, the tip's landing and lift), then
// the scan of its target's square that checks it (check_rod_by_scan's
// field and time).
void estimate_rods(const Scene &s, Vec2 *tip, PlanEstimate *e)
{
    const PlanSpec &ps = s.op.plan;
    for (const WireTargetSpec &t : s.wire_targets) {
        const auto w = std::find_if(s.wires.begin(), s.wires.end(), [&](const WireSpec &x) { return x.id == t.id; });
        if (w == s.wires.end()) continue;
        const Vec2 A{w->x0_nm, w->y0_nm}, B{w->x1_nm, w->y1_nm};
        const double L = norm(B - A);
        const RodEnds ends = rod_target_ends(A, B, {t.x_nm, t.y_nm}, t.angle_deg);
        const double err = std::max(norm(ends.a - A), norm(ends.b - B));   // push_rod_once's error
        ++e->rods;
        if (err > ps.wire_tolerance_nm) {
            const Vec2 end = A + (kEndAt * L) * unit(B - A);
            e->travel_nm += norm(end - *tip);
            e->push_nm += std::min(err, ps.wire_step_nm);
            ++e->strokes;
            *tip = end;
        }
        e->scan_s += ps.scan_s * rod_check_side_nm(ps, L) / ps.scan_size_nm;   // check_rod_by_scan's wait
    }
}

}  // namespace

PlanEstimate estimate_plan(const Scene &s)
{
    const PlanSpec &ps = s.op.plan;
    PlanEstimate e;
    Vec2 tip = s.start_nm();
    for (const CutSpec &c : ps.cuts) {
        e.travel_nm += norm(c.from_nm - tip);
        e.cut_nm += norm(c.to_nm - c.from_nm);
        tip = c.to_nm;
        ++e.cuts;
    }
    objects_t m{};
    for (const auto &p : s.particles) m.particles.push_back({p.id, p.x_nm, p.y_nm, p.radius_nm, false});
    m.n_particles = static_cast<int32_t>(m.particles.size());
    const Planner planner(s);
    double limit = kStrokeStart_nm;
    for (const PlanJob &j : planner.sites().empty() ? std::vector<PlanJob>{} : planner.jobs(m)) {
        const auto p = std::find_if(s.particles.begin(), s.particles.end(), [&](const ParticleSpec &q) { return q.id == j.particle; });
        if (p == s.particles.end()) continue;
        const Vec2 at{p->x_nm, p->y_nm}, site = planner.sites()[static_cast<std::size_t>(j.site)];
        e.travel_nm += norm(at - tip);
        const int n = strokes_to(at, site, &limit);
        e.push_nm += norm(site - at);
        e.strokes += n;
        e.scans += 1 + n;
        ++e.jobs;
        tip = site;
    }
    estimate_rods(s, &tip, &e);
    e.scan_s += e.scans * ps.scan_s;
    const double land_s = 2.0 * kLandBlocks / s.block_hz;   // landing and lifting, each stroke and cut
    e.seconds = (e.cut_nm + e.push_nm) / ps.speed_nm_per_s + e.travel_nm / ps.travel_speed_nm_per_s + e.scan_s +
                (e.strokes + e.cuts) * land_s;
    return e;
}

}  // namespace afm
