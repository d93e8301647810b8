// The planner's geometry (planner.hpp: assign_sites, plan_push, lifted_route,
// stroke_length, assembly_order): functions of the plane, no instrument.

#include "planner.hpp"

#include <dlib/optimization/max_cost_assignment.h>

#include <algorithm>
#include <cmath>

#include "planner_internal.hpp"

namespace afm {

namespace {

// A leg a -> b is free when the particle's sweep and the tip's (from its
// landing point behind a to its place behind b) keep clear of every disc,
// and it does not run along the lever's axis.
// A particle that starts closer than that to another (a push that went
// astray left it there) may still leave: its leg must not bring it closer.
bool leg_free(Vec2 a, Vec2 b, const PushGeometry &g, const std::vector<Disc> &obs)
{
    const Vec2 d = b - a;
    if (norm(d) < 1e-9) return true;
    const Vec2 u = unit(d);
    if (std::fabs(dot(u, unit(g.lever_axis))) > std::cos(g.min_lever_angle_deg * kPi / 180)) return false;
    const double R = g.r + g.tip_r;
    const Vec2 land = a - (R + g.approach_nm) * u, tip_end = b - R * u;
    for (const Disc &c : obs) {
        const double need = g.r + c.r + g.clearance_nm;
        if (seg_dist(c.c, a, b) < std::min(need, norm(c.c - a) - 1e-6)) return false;
        if (seg_dist(c.c, land, tip_end) < g.tip_r + c.r + g.clearance_nm) return false;
    }
    return true;
}

// Within the cone of min_lever_angle_deg about the lever's axis (either way).
bool along_lever(Vec2 d, const PushGeometry &g)
{
    return std::fabs(dot(unit(d), unit(g.lever_axis))) > std::cos(g.min_lever_angle_deg * kPi / 180);
}

Vec2 rotate(Vec2 v, double deg)
{
    const double a = deg * kPi / 180;
    return {v.x * std::cos(a) - v.y * std::sin(a), v.x * std::sin(a) + v.y * std::cos(a)};
}

// The 16 directions a site may be approached from (unit vectors pointing
// from the site outwards), those the lever's axis allows.
std::vector<Vec2> approach_directions(const PushGeometry &g)
{
    std::vector<Vec2> out;
    for (int k = 0; k < 16; ++k) {
        const Vec2 d{std::cos(2 * kPi * k / 16), std::sin(2 * kPi * k / 16)};
        if (std::fabs(dot(d, unit(g.lever_axis))) <= std::cos(g.min_lever_angle_deg * kPi / 180)) out.push_back(d);
    }
    return out;
}

}  // namespace

std::vector<int> assign_sites(const std::vector<Vec2> &particles, const std::vector<Vec2> &sites)
{
    if (sites.empty()) throw PlanError("no target sites to fill");
    if (particles.size() < sites.size())
        throw PlanError(std::to_string(sites.size()) + " target sites but only " + std::to_string(particles.size()) +
                        " particles: give at most as many sites as particles");
    const long n = static_cast<long>(particles.size());
    // dlib maximises: cost M - d (0.1 nm) for a site, 0 for the padding
    // columns of the particles left over, so every site is served at the
    // least total distance.
    double dmax = 0;
    for (const Vec2 &p : particles)
        for (const Vec2 &s : sites) dmax = std::max(dmax, norm(p - s));
    const long M = static_cast<long>(std::ceil(dmax * 10)) + 1;
    dlib::matrix<long> cost(n, n);
    for (long i = 0; i < n; ++i)
        for (long j = 0; j < n; ++j)
            cost(i, j) = j < static_cast<long>(sites.size()) ? M - std::lround(norm(particles[i] - sites[j]) * 10) : 0;
    const std::vector<long> a = dlib::max_cost_assignment(cost);
    std::vector<int> out(sites.size(), -1);
    for (long i = 0; i < n; ++i)
        if (a[i] < static_cast<long>(sites.size())) out[a[i]] = static_cast<int>(i);
    return out;
}

std::vector<int> assign_sites(const std::vector<Vec2> &particles, const std::vector<Vec2> &sites, const std::vector<int> &pinned)
{
    if (pinned.empty()) return assign_sites(particles, sites);
    if (pinned.size() != sites.size()) throw PlanError("pinned sites: one entry per site, got " + std::to_string(pinned.size()));
    if (particles.size() < sites.size())
        return assign_sites(particles, sites);   // refused there, with both counts
    std::vector<int> out(sites.size(), -1), free_p, free_s;
    std::vector<bool> taken(particles.size(), false);
    for (std::size_t j = 0; j < sites.size(); ++j) {
        const int i = pinned[j];
        if (i < 0) continue;
        if (i >= static_cast<int>(particles.size())) throw PlanError("site " + std::to_string(j) + " is pinned to no particle");
        if (taken[static_cast<std::size_t>(i)]) throw PlanError("a particle is pinned to two sites (site " + std::to_string(j) + ")");
        taken[static_cast<std::size_t>(i)] = true;
        out[j] = i;
    }
    std::vector<Vec2> ps, ss;
    for (std::size_t i = 0; i < particles.size(); ++i)
        if (!taken[i]) free_p.push_back(static_cast<int>(i)), ps.push_back(particles[i]);
    for (std::size_t j = 0; j < sites.size(); ++j)
        if (out[j] < 0) free_s.push_back(static_cast<int>(j)), ss.push_back(sites[j]);
    if (ss.empty()) return out;
    const std::vector<int> rest = assign_sites(ps, ss);
    for (std::size_t k = 0; k < rest.size(); ++k) out[static_cast<std::size_t>(free_s[k])] = free_p[static_cast<std::size_t>(rest[k])];
    return out;
}

PushPath plan_push(Vec2 from, Vec2 to, const PushGeometry &g, const std::vector<Disc> &obstacles)
{
    PushPath best;
    if (norm(to - from) < 1e-6) {
        best.legs = {from, to};
        return best;
    }
    if (leg_free(from, to, g, obstacles)) {
        best.legs = {from, to};
        best.length_nm = norm(to - from);
        return best;
    }
    const double R = g.r + g.tip_r;
    std::vector<Vec2> vias;
    for (const Vec2 &d : approach_directions(g))
        for (double D : {3.0, 6.0, 10.0}) vias.push_back(to + (D * R) * d);
    const Vec2 mid = 0.5 * (from + to), n = perp(unit(to - from));
    for (double k : {3.0, 6.0, 10.0, 15.0})
        for (double sgn : {-1.0, 1.0}) vias.push_back(mid + (sgn * k * R) * n);
    // The zigzag: to - from as s1 a1 + s2 a2 with a1, a2 the lever's axis
    // turned by +-(min angle + 5 deg), either sign: the via after s1 a1 (or
    // after s2 a2).
    const double turn = g.min_lever_angle_deg + 5;
    for (double sgn : {-1.0, 1.0}) {
        const Vec2 a1 = rotate(sgn * unit(g.lever_axis), turn), a2 = rotate(sgn * unit(g.lever_axis), -turn);
        const Vec2 d = to - from;
        const double det = a1.x * a2.y - a1.y * a2.x;
        if (std::fabs(det) < 1e-12) continue;
        const double s1 = (d.x * a2.y - d.y * a2.x) / det, s2 = (a1.x * d.y - a1.y * d.x) / det;
        if (s1 < 0 || s2 < 0) continue;
        vias.push_back(from + s1 * a1);
        vias.push_back(from + s2 * a2);
    }
    for (const Vec2 &v : vias) {
        const double len = norm(v - from) + norm(to - v);
        if (best.ok() && len >= best.length_nm) continue;
        if (leg_free(from, v, g, obstacles) && leg_free(v, to, g, obstacles)) {
            best.legs = {from, v, to};
            best.length_nm = len;
        }
    }
    return best;
}

std::vector<Vec2> lifted_route(Vec2 from, Vec2 to, const PushGeometry &g, Vec2 centre)
{
    const Vec2 d = to - from;
    if (norm(d) < kLiftedStraight_nm || !along_lever(d, g)) return {to};
    // d = x a + y n along the axis a (the way d goes) and its normal n; the
    // corner sits x / 2 along a and h off the line's middle, h making both
    // legs at least kCornerAngle_deg off the axis; on the side nearer the
    // field's centre (the joystick's reach).
    const Vec2 a = dot(d, g.lever_axis) >= 0 ? unit(g.lever_axis) : -1.0 * unit(g.lever_axis), n = perp(a);
    const double x = dot(d, a), y = dot(d, n);
    const double h = 0.5 * x * std::tan(kCornerAngle_deg * kPi / 180) + 0.5 * std::fabs(y);
    const Vec2 mid = from + (0.5 * x) * a + (0.5 * y) * n;
    const Vec2 c1 = mid + h * n, c2 = mid - h * n;
    return {norm(c1 - centre) <= norm(c2 - centre) ? c1 : c2, to};
}

double stroke_length(Vec2 from, Vec2 leg_end, double stroke_nm, double near_nm, const PushGeometry &g,
                     const std::vector<Disc> &obstacles)
{
    const double len = norm(leg_end - from);
    double limit = stroke_nm;
    if (limit > near_nm) {
        // Long only where a particle that turns off the tip's line (at most
        // r + tip_r aside before it slips off) still keeps the clearance.
        const Vec2 end = from + std::min(len, 1.5 * limit) * unit(leg_end - from);
        const double aside = g.r + g.tip_r;
        for (const Disc &c : obstacles)
            if (seg_dist(c.c, from, end) < g.r + c.r + g.clearance_nm + aside) limit = near_nm;
    }
    return len > 1.5 * limit ? limit : len;
}

std::vector<int> assembly_order(const std::vector<Vec2> &sites, const PushGeometry &g)
{
    Vec2 centre{0, 0};
    for (const Vec2 &s : sites) centre = centre + s;
    if (!sites.empty()) centre = (1.0 / sites.size()) * centre;
    std::vector<int> left(sites.size());
    for (std::size_t i = 0; i < left.size(); ++i) left[i] = static_cast<int>(i);
    // Try the outermost first: the last to place.
    std::sort(left.begin(), left.end(), [&](int a, int b) { return norm(sites[a] - centre) > norm(sites[b] - centre); });
    const std::vector<Vec2> dirs = approach_directions(g);
    const double reach = 4 * (g.r + g.tip_r) + g.approach_nm;
    std::vector<int> last_first;
    while (!left.empty()) {
        std::size_t take = left.size();
        for (std::size_t k = 0; k < left.size() && take == left.size(); ++k) {
            std::vector<Disc> obs;
            for (std::size_t m = 0; m < left.size(); ++m)
                if (m != k) obs.push_back({sites[left[m]], g.r, left[m]});
            for (const Vec2 &d : dirs)
                if (leg_free(sites[left[k]] + reach * d, sites[left[k]], g, obs)) {
                    take = k;
                    break;
                }
        }
        if (take == left.size()) break;   // the rest are walled in, whatever the order
        last_first.push_back(left[take]);
        left.erase(left.begin() + static_cast<long>(take));
    }
    // Walled in even alone: first, innermost first (they may still find a way past what is not yet placed).
    std::vector<int> out(left.rbegin(), left.rend());
    out.insert(out.end(), last_first.rbegin(), last_first.rend());
    return out;
}

}  // namespace afm
