#include "warnings.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

extern "C" {
#include "fw_board.h"
#include "fw_force.h"
#include "fw_guard.h"
#include "fw_particles.h"
}
#include "fw_units.h"

namespace afm {

namespace {

bool expects(const Scene &s, const char *check) { return std::find(s.expect.begin(), s.expect.end(), check) != s.expect.end(); }

// A value as the warnings say it: 4 significant digits, a whole number from
// 10000 up (never an exponent: "12874 nm", not "1.287e+04").
std::string num(double v)
{
    char b[48];
    std::snprintf(b, sizeof b, std::fabs(v) < 1e4 ? "%.4g" : "%.0f", v);
    return b;
}

// |sin| of the angle to the lever's axis below which F_x is unobservable:
// the firmware's S_HI (fw_force.h: S_LO plus the blend's span, 2.30).
double unobservable_sin()
{
    return static_cast<double>(FW_FORCE_SIN_HI_Q30) / static_cast<double>(1 << 30);
}

void unobservable_pushes(const Scene &s, std::vector<std::string> *out)
{
    if (s.op.plan.enabled || expects(s, "unobservable_push")) return;   // the planner keeps its pushes off the axis itself
    q30_t axis[2];
    fw_board_lever_axis_q30(fwu_mdeg_from_deg(s.probe.scan_angle_deg), axis);
    const double ax = fwu_from_q30(axis[0]), ay = fwu_from_q30(axis[1]);
    const auto &p = s.op.path_nm;
    for (std::size_t i = 1; i < p.size(); ++i) {
        const double dx = p[i].x - p[i - 1].x, dy = p[i].y - p[i - 1].y, len = std::hypot(dx, dy);
        if (len <= 0 || std::fabs(ax * dy - ay * dx) / len >= unobservable_sin()) continue;
        for (const auto &q : s.particles)
            if (point_segment_distance({q.x_nm, q.y_nm}, p[i - 1], p[i]) < q.radius_nm + s.probe.tip_radius_nm) {
                out->push_back("operator.path_nm[" + std::to_string(i) + "]: pushes particle " + std::to_string(q.id) +
                               " within " + num(std::asin(unobservable_sin()) * 180 / M_PI) +
                               " deg of the lever's axis, where the card cannot see F_x (its model stays behind)");
                break;
            }
    }
}

void loads(const Scene &s, const fw_card_config_t &card, std::vector<std::string> *out)
{
    const double full = fwu_nn_from_pn(fw_guard_full_scale_pn(card.board.normal_gain_pn_per_v));
    const double limit = fwu_nn_from_pn(card.interlock_normal_pn);
    std::vector<std::pair<std::string, double>> asked = {{"operator.load_nN", s.op.load_nN}};
    if (s.op.load_ramp_to_nN) asked.push_back({"operator.load_ramp_to_nN", *s.op.load_ramp_to_nN});
    for (std::size_t i = 0; i < s.op.plan.cuts.size(); ++i)
        asked.push_back({"operator.plan.cuts[" + std::to_string(i) + "].load_nN", s.op.plan.cuts[i].load_nN});
    // With the interlock on it trips before S_n saturates (its limit lies
    // below the full scale, the card's rule): that is the warning then.
    for (const auto &[key, load] : asked) {
        if (s.fw_cal.interlock && load > limit) {
            if (!expects(s, "interlock"))
                out->push_back(key + ": " + num(load) + " nN is beyond the card's interlock limit (" + num(limit) + " nN): it will trip");
        } else if (load > full && !expects(s, "saturation")) {
            out->push_back(key + ": " + num(load) + " nN is beyond the lever's range (k_n K_n 10 V = " + num(full) + " nN): S_n saturates");
        }
    }
}

// A script whose path the run ends before the aim has walked it
// (path_times_s: the walk's one summary).
void path_outlasts(const Scene &s, std::vector<std::string> *out)
{
    if (s.op.plan.enabled || s.op.mode != "script" || s.op.path_nm.size() < 2) return;
    const std::vector<double> t = path_times_s(s);
    if (t.back() <= s.duration_s * (1 + 1e-9)) return;
    std::size_t i = 1;
    while (t[i] <= s.duration_s) ++i;   // the segment the run ends in
    out->push_back("operator.path_nm: the script's path ends at " + num(t.back()) + " s (" + num(t.back() * s.op.speed_nm_per_s) +
                   " nm at operator.speed_nm_per_s " + num(s.op.speed_nm_per_s) + "), after duration_s " + num(s.duration_s) +
                   " s: the run ends mid-path, on the way to operator.path_nm[" + std::to_string(i) + "]; make duration_s at least " +
                   num(t.back()) + " or shorten the path");
}

// A sphere pushed by the spherical apex turns off the stroke's line (the
// line of centres, ahead of the apex, is unstable), faster the further off
// it starts, and slides off the tip; the card's particle model
// (fw_particles_update: the particle projected along the line of centres
// to r_tip + r_p) is that rule, and the truth follows it: a stroke 5 nm off
// a particle's centre at r_tip + r_p = 60 nm loses it 190.5 nm after the
// touch in the model, and in the simulator 9 nm before a stroke that
// ran 200 nm past the touch (the particle moved 130 nm; 20 nm off: 105.6
// nm in the model, the simulator's particle moved 49 nm, as the model's).
// A stroke that starts on the line exactly is seeded by kSeed_nm, the
// truth's noise: on the default scene a head-on stroke lost its particle
// 610 nm after the touch with photodiode noise (680 without); a 5 pm
// seed loses it after 604 nm in the model.
constexpr double kSeed_nm = 0.005;

struct Slide {
    double pushed_nm = 0;   // the apex's travel with the particle on it, in this stroke
    double off_nm = 0;      // the particle's centre off the stroke's line at the first touch
    bool slid = false;      // it left the tip before the stroke's end ...
    double left_nm = 0;     // ... this far before it
};

// One particle (centre *c, moved by the push) under a stroke from a to b,
// in the model at a scale where r_tip + r_p is 2^28 units, the apex held at
// the model's origin (the particle shifted back by each step instead).
Slide follow_stroke(Vec2 a, Vec2 b, double reach_nm, double radius_nm, Vec2 *c)
{
    Slide r;
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (len <= 0 || point_segment_distance(*c, a, b) >= reach_nm) return r;
    const Vec2 d{(b.x - a.x) / len, (b.y - a.y) / len};
    double off = (c->x - a.x) * -d.y + (c->y - a.y) * d.x;   // left of the line: +
    if (std::fabs(off) < kSeed_nm) {
        const double k = (off < 0 ? -kSeed_nm : kSeed_nm) - off;
        *c = {c->x - d.y * k, c->y + d.x * k};
        off += k;
    }
    const double unit = reach_nm / static_cast<double>(1 << 28), step = reach_nm / 200;
    const double along = (c->x - a.x) * d.x + (c->y - a.y) * d.y;
    double t = std::clamp(along - reach_nm - step, 0.0, len);   // just before the first touch
    fw_particle_t store[1];
    fw_particles_t m;
    fw_particles_init(&m, store, 1, static_cast<int32_t>(std::lround((reach_nm - radius_nm) / unit)));
    fw_particles_add(&m, 0, static_cast<int32_t>(std::lround((c->x - a.x - t * d.x) / unit)),
                     static_cast<int32_t>(std::lround((c->y - a.y - t * d.y) / unit)), static_cast<int32_t>(std::lround(radius_nm / unit)), 0);
    const int32_t tip[2] = {0, 0}, force[2] = {static_cast<int32_t>(std::lround(-d.x * 1e6)), static_cast<int32_t>(std::lround(-d.y * 1e6))};
    const int32_t dx = static_cast<int32_t>(std::lround(d.x * step / unit)), dy = static_cast<int32_t>(std::lround(d.y * step / unit));
    bool touched = false;
    while (t < len) {
        const double h = std::min(step, len - t);
        fw_particles_shift(&m, h < step ? static_cast<int32_t>(std::lround(-d.x * h / unit)) : -dx,
                           h < step ? static_cast<int32_t>(std::lround(-d.y * h / unit)) : -dy);
        t += h;
        fw_particles_update(&m, tip, force, 1);
        const bool on = (fw_particles_get(&m, 0)->flags & FW_PARTICLE_PUSHED) != 0u;
        if (on && !touched) r.off_nm = std::fabs(off);
        if (on) r.pushed_nm += h;
        if (touched && !on) {
            r.slid = len - t > step;
            r.left_nm = len - t;
            break;
        }
        touched = touched || on;
    }
    const fw_particle_t *q = fw_particles_get(&m, 0);
    *c = {a.x + t * d.x + q->x_pm * unit, a.y + t * d.y + q->y_pm * unit};
    return r;
}

// Strokes of the script (mode script: its strokes do not stop at contact)
// that a particle cannot follow to their end: each particle alone, moved by
// every stroke in turn.
void strokes_slide_off(const Scene &s, std::vector<std::string> *out)
{
    if (s.op.plan.enabled || s.op.mode != "script") return;
    const auto &path = s.op.path_nm;
    for (const ParticleSpec &p : s.particles) {
        Vec2 c{p.x_nm, p.y_nm};
        const double reach = s.probe.tip_radius_nm + p.radius_nm;
        for (std::size_t i = 1; i < path.size(); ++i) {
            const Slide r = follow_stroke(path[i - 1], path[i], reach, p.radius_nm, &c);
            if (!r.slid) continue;
            out->push_back("operator.path_nm[" + std::to_string(i) + "]: the stroke pushes particle " + std::to_string(p.id) +
                           (r.off_nm <= kSeed_nm ? std::string(" through its centre") : ", " + num(r.off_nm) + " nm off its centre") +
                           "; a sphere pushed by the tip turns off the stroke's line (e-fold length r_tip + r_p = " + num(reach) +
                           " nm, the card's particle model) and slides off the tip " + num(r.pushed_nm) + " nm after the tip meets it, " +
                           num(r.left_nm) + " nm before the stroke's end: push it in shorter strokes, each aimed through its centre");
            break;   // one warning a particle: the rest of its path is off the script's plan
        }
    }
}

// Objects that start touching, or closer than the tip's diameter: the tip
// cannot pass between them, and a push of one reaches the other at once
// (object_pairs_within: the one owner of their geometry; an overlap is
// refused by the validator).
void objects_touch(const Scene &s, std::vector<std::string> *out)
{
    const double tip_d = 2 * s.probe.tip_radius_nm;
    for (const ObjectPair &p : object_pairs_within(s, tip_d)) {
        if (p.gap_nm < 0) continue;   // refused by the validator (or a scattered pair, kept apart by min_gap_nm)
        out->push_back(p.key_i + ": starts " + num(p.gap_nm) + " nm from " + p.key_j + " (id " + std::to_string(p.id_j) +
                       "), surface to surface: " +
                       (p.gap_nm < 0.5 ? std::string("they touch, so a push of one pushes the other")
                                       : "less than the tip's diameter (" + num(tip_d) + " nm): the tip cannot pass between them") +
                       "; move them at least " + num(tip_d) + " nm apart");
    }
}

// The fit's coefficients, s per unit of each feature of WallEstimate
// (tools/wall_fit.py; docs/scenes.md, "Checks"), and its constant: the
// processes' start, the video's encoding and the report of the run.
struct WallFit { double one, blocks, samples, scan_px, rough_scan_px, frame_px, wire_samples; };
constexpr WallFit kFit = {0.729, 0.000125, 0, 2.33e-07, 9.34e-06, 3.28e-08, 3.05e-07};

std::string whole(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%.0f", v);
    return b;
}

void long_run(const Scene &s, std::vector<std::string> *out)
{
    const WallEstimate e = estimate_wall(s);
    if (e.planned || e.realtime || e.seconds <= kLongRun_s) return;
    out->push_back("duration_s: a run of " + num(s.duration_s) + " simulated s takes about " + whole(e.seconds) +
                   " s of wall time, estimated from its size (" + whole(e.blocks) + " blocks, " + whole(e.samples) + " samples, scans of " +
                   std::to_string(s.out.image_px) + " px, " + std::to_string(s.total_frames()) + " frames" +
                   (e.wire_samples > 0 ? ", flexible wires" : "") + "): more than " + whole(kLongRun_s) +
                   " s; shorten duration_s, or lower sample_rate_hz or outputs.image_px");
}

// A plan that needs longer than the run: the planner's estimate
// (plan_estimate.hpp, a floor) past duration_s.
void plan_outlasts(const Scene &s, const PlanEstimate *plan, std::vector<std::string> *out)
{
    if (!plan || plan->seconds <= s.duration_s) return;
    const PlanSpec &ps = s.op.plan;
    std::string work = std::to_string(plan->jobs) + " particles to their sites: " + std::to_string(plan->strokes) + " strokes over " +
                       num(plan->push_nm) + " nm at operator.plan.speed_nm_per_s " + num(ps.speed_nm_per_s) + ", " +
                       std::to_string(plan->scans) + " local scans of operator.plan.scan_s " + num(ps.scan_s) + " s, " +
                       num(plan->travel_nm) + " nm lifted at operator.plan.travel_speed_nm_per_s " + num(ps.travel_speed_nm_per_s);
    if (plan->cuts > 0) work += ", " + std::to_string(plan->cuts) + " cuts over " + num(plan->cut_nm) + " nm";
    if (plan->rods > 0) work += ", " + std::to_string(plan->rods) + " rods to their targets (an end push and a check scan each at least)";
    out->push_back("duration_s: " + num(s.duration_s) + " s is shorter than the plan needs, at least " + num(plan->seconds) +
                   " s of simulated time by the planner's estimate (" + work + "): the run ends with the plan half done; "
                   "make duration_s at least " + num(std::ceil(plan->seconds)) + " (a planning run ends when the planner is done)");
}

}  // namespace

std::vector<std::string> scene_warnings(const Scene &s, const fw_card_config_t &card, const PlanEstimate *plan)
{
    std::vector<std::string> out;
    unobservable_pushes(s, &out);
    path_outlasts(s, &out);
    strokes_slide_off(s, &out);
    objects_touch(s, &out);
    if (!s.particles.empty() && !s.has_effect("adhesion"))
        out.push_back("effects: the scene has particles to push but no adhesion effect: nothing holds them (the first touch slides them away)");
    loads(s, card, &out);
    long_run(s, &out);
    plan_outlasts(s, plan, &out);
    return out;
}

WallEstimate estimate_wall(const Scene &s)
{
    WallEstimate e;
    e.blocks = static_cast<double>(s.total_blocks());
    e.samples = e.blocks * s.samples_per_block();
    const double px2 = static_cast<double>(s.out.image_px) * s.out.image_px;
    const bool rough = s.has_effect("tip_convolution") && (s.has_effect("roughness") || !s.substrate_gsf.empty());
    (rough ? e.rough_scan_px : e.scan_px) = 2 * px2;
    e.frame_px = s.total_frames() * px2;
    if (s.has_effect("wire_flexibility"))
        e.wire_samples = e.samples * static_cast<double>(s.wires.size()) * s.wire_model.segments * s.wire_model.relax_sweeps;
    e.seconds = kFit.one + kFit.blocks * e.blocks + kFit.samples * e.samples + kFit.scan_px * e.scan_px +
                kFit.rough_scan_px * e.rough_scan_px + kFit.frame_px * e.frame_px + kFit.wire_samples * e.wire_samples;
    e.planned = s.op.plan.enabled;
    e.realtime = s.time_mode == "realtime";
    return e;
}

}  // namespace afm
