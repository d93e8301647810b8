#include "planner.hpp"

extern "C" {
#include "fw_board.h"
#include "fw_units.h"
#include "fw_wire.h"
}

#include <dlib/optimization/max_cost_assignment.h>

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
#include "profile.hpp"

namespace afm {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kStop_nm = 2.0;          // a stroke ends when the model is this close to its end (onto a site: kStopSite_nm)
constexpr double kStopSite_nm = 0.5;
constexpr double kSlowOver_nm = 40.0;     // the push onto a site slows over its last stretch ...
constexpr double kSlowest_nm_per_s = 200.0;   // ... to no slower than this
constexpr double kBackOff_nm = 30.0;      // after a push the tip backs off this far before lifting
constexpr double kLostAngle_deg = 60.0;   // the line of centres this far off the push: contact lost
constexpr double kDriftDeadband_nm = 4.0; // a pre-push scan closer than this to the model is not drift (the scan's own scatter)
constexpr int kLandBlocks = 3;            // blocks the tip takes to land or lift
constexpr double kSearchMargin_nm = 40.0; // how far from where it should be a scan looks for a particle
constexpr double kWideScan = 3.0;         // a particle not in its local scan: one this many times wider
constexpr double kEndAt = 0.1;            // a rod's end push is at L/10 from the end
constexpr double kTurnTol_deg = 20.0;     // a rod is carried while its normal is within this of the way
constexpr double kStuck_nm = 1.0;         // a rod's end push that moved its model's ends less than this did nothing
constexpr double kCarryUntil = 3.0;       // a rod is carried until its centre is this many tolerances from the target
constexpr double kMinLeverAngle_deg = 25.0;   // pushes and lifted moves keep this far off the lever's axis (F_x: fw_force.h's S_HI is 14.5 deg)
constexpr double kCornerAngle_deg = 35.0;     // a lifted move along the axis turns aside this far (lifted_route)
constexpr double kLiftedStraight_nm = 2.0;    // a lifted move shorter than this goes straight (the card's direction needs 1 nm)
constexpr double kStrokeNear_nm = 180.0;      // the longest stroke near another particle (stroke_length)
// Strokes: a pushed sphere drifts off the line of centres exponentially
// with the distance pushed (length r_tip + r_p), the real one and the
// model alike, from different starts: the model is trusted for a stroke,
// then a scan puts it right. The stroke lengthens while the model stays
// within kStrayLow_nm of the scan, and halves when it strays past
// kStrayHigh_nm.
constexpr double kStrokeStart_nm = 180.0, kStrokeMin_nm = 60.0, kStrokeMax_nm = 600.0;
constexpr double kStrayLow_nm = 5.0, kStrayHigh_nm = 15.0;
constexpr int kMaxStrokes = 60;           // per particle
constexpr double kModelMoved_nm = 0.5;    // a model that moved this much during another's push is checked by a scan
constexpr int kStallBlocks = 40;          // the tip at its aim and the model still this long: the particle has gone
// The model still in more than half of the blocks of this long (s) after
// contact was made ends a stroke: the particle has slipped off the tip
// (pushed, the model moves every block). The card's model would otherwise creep on after it,
// a few nm at each contact the card feels now and then with the tip
// pressed into the model, and end further from the particle than a place
// fix may move it (the card's drift limit, 200 nm).
constexpr double kApart_s = 0.02;

Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
Vec2 operator*(double k, Vec2 a) { return {k * a.x, k * a.y}; }
double dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
double norm(Vec2 a) { return std::hypot(a.x, a.y); }
Vec2 unit(Vec2 a, Vec2 fallback = {1, 0})
{
    const double n = norm(a);
    return n > 1e-9 ? (1.0 / n) * a : fallback;
}
Vec2 perp(Vec2 a) { return {-a.y, a.x}; }

// Distance from q to the segment a-b (common/scene's, the one copy).
double seg_dist(Vec2 q, Vec2 a, Vec2 b) { return point_segment_distance(q, a, b); }

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

struct Planner::Job {
    int site = 0;       // index in sites_
    int particle = 0;   // particle id
};

Planner::Planner(const Scene &s) : s_(s), sites_(target_sites(s)), stroke_nm_(kStrokeStart_nm)
{
    if (const std::string why = targets_refusal(s); !why.empty()) throw PlanError(why);
    if (!s.wires.empty()) {
        const CardSetup card(s);
        const fw_card_config_t &c = card.config();
        if (fw_wire_tip_init(&wire_tip_, c.tip_radius_pm, c.tip_half_angle_mdeg, c.wire_friction_pn_per_um,
                             c.wire_mu_ppm, 0) != FW_OK)
            throw PlanError("the card refuses the rods' tip: " + card_refusal(s));
    }
}

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

Vec2 Planner::drift() const { return {model_->drift_nm[0], model_->drift_nm[1]}; }

const particle_t *Planner::particle(int id) const
{
    for (const auto &p : model_->particles)
        if (p.id == id) return &p;
    return nullptr;
}

PushGeometry Planner::geometry(double r) const
{
    PushGeometry g;
    g.r = r;
    g.tip_r = s_.probe.tip_radius_nm;
    g.approach_nm = s_.op.plan.approach_nm;
    g.clearance_nm = s_.op.plan.clearance_nm;
    // The lever's axis x_C in frame A, as the firmware turns it.
    q30_t axis[2];
    fw_board_lever_axis_q30(fwu_mdeg_from_deg(s_.probe.scan_angle_deg), axis);
    g.lever_axis = {fwu_from_q30(axis[0]), fwu_from_q30(axis[1])};
    g.min_lever_angle_deg = kMinLeverAngle_deg;
    return g;
}

std::vector<Disc> Planner::obstacles(int except_id) const
{
    std::vector<Disc> out;
    const Vec2 d = drift();
    for (const auto &p : model_->particles)
        if (p.id != except_id) out.push_back({Vec2{p.x_nm, p.y_nm} - d, p.radius_nm, p.id});
    // A rod: discs of its radius along its axis, half a diameter apart.
    for (const auto &w : model_->wires)
        for (int i = 0; i + 1 < w.n; ++i) {
            const Vec2 a = Vec2{w.x_nm[i], w.y_nm[i]} - d, b = Vec2{w.x_nm[i + 1], w.y_nm[i + 1]} - d;
            const int k = std::max(1, static_cast<int>(std::ceil(norm(b - a) / (w.diameter_nm / 2))));
            for (int j = 0; j <= k; ++j) out.push_back({a + (static_cast<double>(j) / k) * (b - a), w.diameter_nm / 2, -w.id});
        }
    return out;
}

void Planner::hold(int blocks)
{
    for (int i = 0; i < blocks; ++i) model_ = &bench_->block({tip_, engaged_, load_nN_});
}

void Planner::wait_s(double s) { hold(static_cast<int>(std::lround(s * s_.block_hz))); }

void Planner::cut(const CutSpec &c)
{
    const PlanSpec &ps = s_.op.plan;
    if (engaged_) travel(tip_, false, ps.travel_speed_nm_per_s);
    travel(c.from_nm, false, ps.travel_speed_nm_per_s);
    travel(tip_, true, ps.speed_nm_per_s);   // land at the operator's load
    load_nN_ = c.load_nN;
    hold(kLandBlocks);                       // pressed in before it moves
    travel(c.to_nm, true, ps.speed_nm_per_s);
    load_nN_ = 0;
    hold(kLandBlocks);                       // back to the light load before lifting
    travel(tip_, false, ps.travel_speed_nm_per_s);
    ++rep_.cuts;
    rep_.cuts_done_s = bench_->time_s();
}

void Planner::travel(Vec2 to, bool engaged, double speed)
{
    if (engaged != engaged_) {
        engaged_ = engaged;
        hold(kLandBlocks);
    }
    // Lifted, never along the lever's axis: the card flags a blind push
    // (FW_FLAG_BLIND_PUSH) whenever its direction of motion lies in that
    // cone and the apex is over an object it models, lifted or not, and a
    // local scan holds the tip over its particle with the direction of
    // the move that brought it there. At a corner the tip stops a block,
    // so that the card's direction turns from one leg to the next without
    // passing through the axis.
    const std::vector<Vec2> route = engaged_ ? std::vector<Vec2>{to} : lifted_route(tip_, to, geometry(0), s_.field_center_nm);
    const double step = speed / s_.block_hz;
    for (std::size_t k = 0; k < route.size(); ++k) {
        if (k > 0) hold(1);
        while (norm(route[k] - tip_) > 1e-9) {
            const Vec2 d = route[k] - tip_;
            tip_ = norm(d) <= step ? route[k] : tip_ + step * unit(d);
            model_ = &bench_->block({tip_, engaged_, load_nN_});
        }
    }
}

bool Planner::scan_at(int id, Vec2 around, Vec2 *found)
{
    const PlanSpec &ps = s_.op.plan;
    if (engaged_) travel(tip_, false, ps.travel_speed_nm_per_s);
    const particle_t *p = particle(id);
    if (!p) return false;
    const double r = p->radius_nm;
    const TipShape tip = s_.has_effect("tip_convolution") ? TipShape{s_.probe.tip_radius_nm, s_.probe.tip_half_angle_deg} : TipShape{};
    const double window = sphere_footprint_nm(r, tip) * 0.5 + kSearchMargin_nm;
    std::vector<cv::Point2d> others;
    for (const auto &q : model_->particles)
        if (q.id != id) others.emplace_back(q.x_nm, q.y_nm);
    // The bump nearest where it should be that is not another particle; not
    // in the scan (it went further than the model knows), a wider scan.
    for (double size : {ps.scan_size_nm, kWideScan * ps.scan_size_nm}) {
        const int px = static_cast<int>(std::lround(ps.scan_px * size / ps.scan_size_nm));
        const Field f{around.x - size / 2, around.y - size / 2, size, px};
        const cv::Mat h = bench_->scan(f);
        ++rep_.local_scans;
        wait_s(ps.scan_s * size / ps.scan_size_nm);
        double x = 0, y = 0;
        if (nearest_bump(h, f, around.x, around.y, r, window, others, r, &x, &y)) {
            if (std::getenv("AFM_PLAN_TRACE"))
                std::fprintf(stderr, "plan: scan t %.3f particle %d around (%.1f, %.1f) found (%.1f, %.1f)\n", bench_->time_s(), id, around.x,
                             around.y, x, y);
            *found = {x, y};
            return true;
        }
    }
    return false;
}

bool Planner::send_fix(int id, Vec2 at, bool place)
{
    std::string note;
    model_ = &bench_->fix(id, at, place, &note);
    if (note.empty()) ++rep_.fixes;
    else ++rep_.fixes_refused;
    return note.empty();
}

bool Planner::scan_particle(int id, Vec2 around, bool place, Vec2 *found)
{
    if (!scan_at(id, around, found)) return false;
    const particle_t *p = particle(id);
    const Vec2 off = *found - Vec2{p->x_nm, p->y_nm};
    if (place) return send_fix(id, *found, true);
    // Drift, or was it disturbed? Within the scan's own scatter: neither.
    // Otherwise the nearest other particle is scanned too: found off by the
    // same it is drift (every model moves); if not, the particles were
    // disturbed, and each model alone is put right.
    if (norm(off) < kDriftDeadband_nm) return true;
    const particle_t *ref = nullptr;
    double best = 1e300;
    for (const auto &q : model_->particles)
        if (q.id != id && std::hypot(q.x_nm - p->x_nm, q.y_nm - p->y_nm) < best) best = std::hypot(q.x_nm - p->x_nm, q.y_nm - p->y_nm), ref = &q;
    Vec2 ref_at;
    const int ref_id = ref ? ref->id : 0;
    const Vec2 ref_model = ref ? Vec2{ref->x_nm, ref->y_nm} : Vec2{};
    const Vec2 here = *found;
    if (ref) travel(ref_model, false, s_.op.plan.travel_speed_nm_per_s);
    const bool ref_found = ref && scan_at(ref_id, ref_model, &ref_at);
    if (ref_found && norm((ref_at - ref_model) - off) < kDriftDeadband_nm) return send_fix(id, here, false);
    ++rep_.disturbed;
    if (ref_found && norm(ref_at - ref_model) >= kDriftDeadband_nm) send_fix(ref_id, ref_at, true);
    return send_fix(id, here, true);
}

bool Planner::push_leg(int id, Vec2 end_A, bool slow_end)
{
    const PlanSpec &ps = s_.op.plan;
    const particle_t *p = particle(id);
    if (!p) return false;
    const double R = p->radius_nm + s_.probe.tip_radius_nm;
    Vec2 P{p->x_nm, p->y_nm};
    Vec2 u = unit(end_A - P);
    travel(P - (R + ps.approach_nm) * u, false, ps.travel_speed_nm_per_s);
    travel(tip_, true, ps.speed_nm_per_s);   // land
    const double T = 1.0 / s_.block_hz;
    const double far = norm(end_A - P) + ps.approach_nm;
    const long max_blocks = static_cast<long>(3 * far / ps.speed_nm_per_s * s_.block_hz) + static_cast<long>(s_.block_hz);
    bool touched = false, ok = false;
    Vec2 last_P = P;
    int still = 0;
    std::deque<bool> moved;   // since contact: whether the model moved, a block each, the last apart_max
    const int apart_max = std::max(3, static_cast<int>(std::lround(kApart_s * s_.block_hz)));
    for (long k = 0; k < max_blocks; ++k) {
        p = particle(id);
        if (!p) break;
        P = {p->x_nm, p->y_nm};
        still = norm(P - last_P) < 0.05 ? still + 1 : 0;
        last_P = P;
        const Vec2 rem = end_A - P;
        const double d = norm(rem);
        if (d <= (slow_end ? kStopSite_nm : kStop_nm)) {
            ok = true;
            break;
        }
        if (d > 20) u = unit(rem, u);
        const Vec2 c = P - tip_;
        touched = touched || p->in_contact;
        // Slipped off: the model moved in fewer than half of the last
        // apart_max blocks (pushed, it moves every block; what the card
        // still feels now and then, with the tip pressed into the model,
        // is not the particle).
        if (touched) {
            moved.push_back(still == 0);
            if (static_cast<int>(moved.size()) > apart_max) moved.pop_front();
            if (static_cast<int>(moved.size()) == apart_max && 2 * std::count(moved.begin(), moved.end(), true) < apart_max) break;
        }
        if (touched) {
            const double cosang = dot(unit(c, u), u);
            if (cosang < std::cos(kLostAngle_deg * kPi / 180) || norm(c) > R + ps.approach_nm + 30) break;   // lost
        }
        const Vec2 aim = P - (R - ps.push_depth_nm) * u;
        if (still > kStallBlocks && norm(aim - tip_) < 0.5) break;   // at its aim, nothing moves: it has slipped away
        const double v = slow_end ? std::clamp(d / kSlowOver_nm * ps.speed_nm_per_s, kSlowest_nm_per_s, ps.speed_nm_per_s) : ps.speed_nm_per_s;
        const Vec2 to = aim - tip_;
        tip_ = norm(to) <= v * T ? aim : tip_ + (v * T) * unit(to);
        model_ = &bench_->block({tip_, true});
    }
    // Back off from the particle's model (the way it came, if the tip is on its centre).
    if (const particle_t *q = particle(id)) u = unit(Vec2{q->x_nm, q->y_nm} - tip_, u);
    travel(tip_ - kBackOff_nm * u, true, ps.speed_nm_per_s);
    travel(tip_, false, ps.travel_speed_nm_per_s);   // lift
    return ok;
}

bool Planner::locate(PlanItem &item, bool place, Vec2 *at)
{
    const particle_t *p = particle(item.id);
    if (!p) return false;
    const Vec2 P{p->x_nm, p->y_nm};
    travel(P, false, s_.op.plan.travel_speed_nm_per_s);
    ++item.scans;
    return scan_particle(item.id, P, place, at);
}

void Planner::check_disturbed(const std::vector<particle_t> &before, int pushed_id)
{
    // Another particle's model moved during a push (the firmware saw the
    // tip or the pushed particle touch it): a scan shows where it is.
    for (const particle_t &b : before) {
        if (b.id == pushed_id) continue;
        const particle_t *p = particle(b.id);
        if (!p || std::hypot(p->x_nm - b.x_nm, p->y_nm - b.y_nm) < kModelMoved_nm) continue;
        ++rep_.disturbed;
        PlanItem probe;
        probe.id = b.id;
        Vec2 at;
        locate(probe, true, &at);
    }
}

void Planner::place_particle(PlanItem &item, Vec2 site)
{
    const PlanSpec &ps = s_.op.plan;
    Vec2 at;
    // Where is it? Untouched since the model last saw it: the difference is drift.
    if (!locate(item, false, &at)) {
        item.why = "not found in the local scan around its model";
        return;
    }
    int attempts = 0;   // strokes that ended at the site
    for (int strokes = 0; strokes < kMaxStrokes; ++strokes) {
        const particle_t *p = particle(item.id);
        if (!p) {
            item.why = "not in the firmware's model";
            return;
        }
        const Vec2 from = Vec2{p->x_nm, p->y_nm} - drift();
        const PushPath path = plan_push(from, site, geometry(p->radius_nm), obstacles(item.id));
        if (!path.ok()) {
            item.why = "no free path to its site";
            return;
        }
        // One stroke: along the first leg, no longer than the model is
        // trusted to follow the particle.
        Vec2 end = path.legs[1];
        bool at_site = path.legs.size() == 2;
        const double len = stroke_length(from, end, stroke_nm_, kStrokeNear_nm, geometry(p->radius_nm), obstacles(item.id));
        if (len < norm(end - from)) {
            end = from + len * unit(end - from);
            at_site = false;
        }
        ++item.pushes;
        ++rep_.pushes;
        if (at_site && ++attempts > 1) ++rep_.repushes;
        const std::vector<particle_t> before = model_->particles;
        push_leg(item.id, end + drift(), at_site);
        check_disturbed(before, item.id);
        // The check: a scan where the model has it; the model goes where it shows.
        const particle_t *q = particle(item.id);
        if (!q) {
            item.why = "not in the firmware's model";
            return;
        }
        const Vec2 model{q->x_nm, q->y_nm};
        if (!locate(item, true, &at)) {
            // not found, or found further from its model than the card accepts
            item.why = "lost: not found near its model after a push (or further off than the firmware accepts)";
            return;
        }
        // How far the model strayed over this stroke sets the next one's length.
        const double strayed = norm(at - model);
        if (std::getenv("AFM_PLAN_TRACE"))
            std::fprintf(stderr, "plan: t %.2f particle %d stroke %.0f nm (limit %.0f) at_site %d model (%.1f, %.1f) at (%.1f, %.1f) strayed %.1f nm\n", bench_->time_s(), item.id, norm(end - from), stroke_nm_, at_site, model.x, model.y, at.x, at.y, strayed);
        if (strayed < kStrayLow_nm) stroke_nm_ = std::min(kStrokeMax_nm, stroke_nm_ * 1.5);
        else if (strayed > kStrayHigh_nm) stroke_nm_ = std::max(kStrokeMin_nm, stroke_nm_ * 0.5);
        if (!at_site) continue;
        // Aim for half the tolerance; take the tolerance on the last attempt.
        item.error_nm = norm(at - (site + drift()));
        if (item.error_nm <= ps.tolerance_nm * (attempts >= ps.max_pushes ? 1.0 : 0.5)) {
            item.placed = true;
            item.why.clear();
            return;
        }
        if (attempts >= ps.max_pushes) break;
    }
    std::ostringstream m;
    m.precision(3);
    if (attempts == 0) m << "not at its site after " << kMaxStrokes << " strokes";
    else m << "off its site by " << item.error_nm << " nm after " << attempts << " pushes onto it";
    item.why = m.str();
}

void Planner::clear_blockers(const std::vector<int> &assigned)
{
    // A spare particle on a site another particle is coming to: push it
    // outwards, away from the pattern's centre, until it is clear.
    const PlanSpec &ps = s_.op.plan;
    Vec2 centre{0, 0};
    for (const Vec2 &s : sites_) centre = centre + s;
    centre = (1.0 / sites_.size()) * centre;
    const double half = s_.field_nm / 2;
    for (const auto &p : std::vector<particle_t>(model_->particles)) {
        if (std::find(assigned.begin(), assigned.end(), p.id) != assigned.end()) continue;
        const Vec2 P = Vec2{p.x_nm, p.y_nm} - drift();
        double nearest = 1e300;
        Vec2 near_site;
        for (const Vec2 &s : sites_)
            if (norm(s - P) < nearest) nearest = norm(s - P), near_site = s;
        const double need = 2 * p.radius_nm + ps.clearance_nm;
        if (nearest >= need) continue;
        Vec2 out = unit(P - centre, unit(P - near_site));
        // To the nearest place outside every site's reach along that line.
        Vec2 to = P;
        for (int k = 1; k < 200; ++k) {
            to = P + (k * 0.5 * need) * out;
            bool clear = true;
            for (const Vec2 &s : sites_) clear = clear && norm(s - to) >= need + p.radius_nm;
            if (clear) break;
        }
        to.x = std::clamp(to.x, s_.field_center_nm.x - half + need, s_.field_center_nm.x + half - need);
        to.y = std::clamp(to.y, s_.field_center_nm.y - half + need, s_.field_center_nm.y + half - need);
        // Pushed there as any particle to its site (free paths, strokes, scans).
        PlanItem item;
        item.kind = "spare";
        item.id = p.id;
        item.target_nm = to;
        ++rep_.cleared;
        place_particle(item, to);
        if (item.placed) item.why = "a spare particle on a site: pushed aside";
        rep_.items.push_back(item);
    }
}

void Planner::run_particles()
{
    std::vector<Vec2> pos;
    std::vector<int> ids;
    for (const auto &p : model_->particles) {
        pos.push_back(Vec2{p.x_nm, p.y_nm} - drift());
        ids.push_back(p.id);
    }
    // A pinned site (objects.targets[j].particle) by the particle's index here.
    std::vector<int> pinned;
    for (int id : s_.targets.pinned) {
        const auto at = std::find(ids.begin(), ids.end(), id);
        if (id >= 0 && at == ids.end()) throw PlanError("objects.targets: particle " + std::to_string(id) + " is pinned to a site but not in the firmware's model");
        pinned.push_back(id < 0 ? -1 : static_cast<int>(at - ids.begin()));
    }
    const std::vector<int> who = assign_sites(pos, sites_, pinned);
    std::vector<int> assigned;
    for (int i : who) assigned.push_back(ids[static_cast<std::size_t>(i)]);
    clear_blockers(assigned);

    double r = 0;
    for (const auto &p : model_->particles) r = std::max(r, p.radius_nm);
    std::vector<Job> left;
    for (int j : assembly_order(sites_, geometry(r))) left.push_back({j, assigned[static_cast<std::size_t>(j)]});
    const PlanSpec &ps = s_.op.plan;
    while (!left.empty()) {
        // The innermost job with a free push.
        std::size_t pick = left.size();
        for (std::size_t k = 0; k < left.size() && pick == left.size(); ++k) {
            const particle_t *p = particle(left[k].particle);
            if (!p) continue;
            if (plan_push(Vec2{p->x_nm, p->y_nm} - drift(), sites_[left[k].site], geometry(p->radius_nm), obstacles(p->id)).ok())
                pick = k;
        }
        if (pick == left.size()) {
            for (const Job &j : left) {
                PlanItem item;
                item.kind = "particle";
                item.id = j.particle;
                item.target_nm = sites_[j.site];
                item.why = "no free path to its site";
                rep_.items.push_back(item);
            }
            break;
        }
        const Job j = left[pick];
        left.erase(left.begin() + static_cast<long>(pick));
        PlanItem item;
        item.kind = "particle";
        item.id = j.particle;
        item.target_nm = sites_[j.site];
        place_particle(item, sites_[static_cast<std::size_t>(j.site)]);
        rep_.items.push_back(item);
    }
    // A placed particle knocked off its site by a later push (its model was
    // put right by a scan when it moved) is pushed back.
    for (int pass = 0; pass < 2; ++pass)
        for (PlanItem &item : rep_.items) {
            if (item.kind != "particle" || !item.placed) continue;
            const particle_t *p = particle(item.id);
            if (!p || norm(Vec2{p->x_nm, p->y_nm} - (item.target_nm + drift())) <= ps.tolerance_nm) continue;
            item.placed = false;
            ++rep_.replaced;
            place_particle(item, item.target_nm);
        }
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
    const double th = t.angle_deg * kPi / 180;
    Vec2 ta{std::cos(th), std::sin(th)};
    if (dot(ta, p.a) < 0) ta = -1.0 * ta;
    p.T = item.target_nm + drift();
    p.As = p.T - (p.L / 2) * ta;
    p.Bs = p.T + (p.L / 2) * ta;
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
        std::fprintf(stderr, "plan: t %.2f rod %d A (%.1f, %.1f) B (%.1f, %.1f) eA %.1f eB %.1f push %s by %.1f nm\n", bench_->time_s(),
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
    const double size = length + 2 * ps.scan_size_nm;
    const int px = static_cast<int>(std::lround(ps.scan_px * size / ps.scan_size_nm));
    const Field f{T.x - size / 2, T.y - size / 2, size, px};
    if (engaged_) travel(tip_, false, ps.travel_speed_nm_per_s);
    const cv::Mat h = bench_->scan(f);
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

PlanItem Planner::push_particle(PlanBench &bench, int id, Vec2 target_nm, Vec2 tip_nm)
{
    const auto wall0 = std::chrono::steady_clock::now();
    bench_ = &bench;
    tip_ = tip_nm;
    engaged_ = false;
    load_nN_ = 0;
    model_ = &bench.block({tip_, false});
    PlanItem item;
    item.kind = "particle";
    item.id = id;
    item.target_nm = target_nm - drift();
    if (particle(id)) place_particle(item, item.target_nm);
    else item.why = "not in the firmware's model";
    rep_.items.push_back(item);
    rep_.finished_s = bench.time_s();
    rep_.wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    return item;
}

void Planner::run(PlanBench &bench)
{
    const auto wall0 = std::chrono::steady_clock::now();
    bench_ = &bench;
    tip_ = s_.start_nm();
    engaged_ = false;
    model_ = &bench.block({tip_, false});
    for (const CutSpec &c : s_.op.plan.cuts) cut(c);
    if (!sites_.empty()) run_particles();
    if (!s_.wire_targets.empty()) run_wires();
    rep_.finished_s = bench.time_s();
    rep_.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

}  // namespace afm
