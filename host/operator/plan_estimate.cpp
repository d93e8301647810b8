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
    const double land_s = 2.0 * kLandBlocks / s.block_hz;   // landing and lifting, each stroke and cut
    e.seconds = (e.cut_nm + e.push_nm) / ps.speed_nm_per_s + e.travel_nm / ps.travel_speed_nm_per_s + e.scans * ps.scan_s +
                (e.strokes + e.cuts) * land_s;
    return e;
}

}  // namespace afm
