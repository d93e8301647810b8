// The planner's simulated time, estimated before the run from what it will
// do (operator.plan): ./afm check warns when it outlasts duration_s (the run
// would end with the pattern half done), and afm_launch --estimate prints
// it. The one owner is estimate_plan (the operator library: it needs the
// planner's sites, assignment and order); `operator --check-targets` prints
// it as one JSON line, which the launcher reads (plan_estimate_json and
// plan_estimate_from_json here: the line's one format).
//
// A floor, not a forecast: the cuts at speed_nm_per_s with the lifted
// travel to each; then each particle's job in the planner's order (its
// site, assign_sites and assembly_order: Planner::jobs): the lifted travel
// from where the tip is to the particle at travel_speed_nm_per_s, its scan
// before the first stroke, the strokes along the straight line to the site
// at speed_nm_per_s as stroke_length would cut it with the stroke limit
// growing each time (kStrokeStart_nm x 1.5 per stroke up to kStrokeMax_nm,
// as when the model never strays), a scan after each (scan_s), and the
// tip's landing and lift (kLandBlocks each) at each stroke. Then each rod
// (objects.wire_targets): one end push if it is off its target (the lifted
// travel to its end, the push of its end error up to wire_step_nm) and the
// scan of its target's square that checks it. Detours round other
// particles, repushes, strays, shorter strokes near a neighbour, disturbed
// particles and a rod's further end pushes only add to it.
#pragma once

#include <nlohmann/json.hpp>

#include "scene.hpp"

namespace afm {

struct PlanEstimate {
    double seconds = 0;       // simulated s the plan takes at least
    int cuts = 0;             // operator.plan.cuts
    int jobs = 0;             // particles pushed onto sites
    int strokes = 0;          // pushing strokes
    int scans = 0;            // local scans of particles (scan_s each)
    int rods = 0;             // rods (objects.wire_targets), each with its check scan
    double scan_s = 0;        // simulated s in local scans, particles' and rods'
    double cut_nm = 0;        // cut, at speed_nm_per_s
    double push_nm = 0;       // pushed, at speed_nm_per_s
    double travel_nm = 0;     // lifted, at travel_speed_nm_per_s
};

// Defined in the operator library (plan_estimate.cpp). Throws PlanError or
// PatternError where Planner's constructor does.
PlanEstimate estimate_plan(const Scene &s);

inline nlohmann::json plan_estimate_json(const PlanEstimate &e)
{
    return {{"seconds", e.seconds}, {"cuts", e.cuts},           {"jobs", e.jobs},         {"strokes", e.strokes},
            {"scans", e.scans},     {"rods", e.rods},           {"scan_s", e.scan_s},     {"cut_nm", e.cut_nm},       {"push_nm", e.push_nm},   {"travel_nm", e.travel_nm}};
}

inline PlanEstimate plan_estimate_from_json(const nlohmann::json &j)
{
    PlanEstimate e;
    e.seconds = j.at("seconds").get<double>();
    e.cuts = j.at("cuts").get<int>();
    e.jobs = j.at("jobs").get<int>();
    e.strokes = j.at("strokes").get<int>();
    e.scans = j.at("scans").get<int>();
    e.rods = j.at("rods").get<int>();
    e.scan_s = j.at("scan_s").get<double>();
    e.cut_nm = j.at("cut_nm").get<double>();
    e.push_nm = j.at("push_nm").get<double>();
    e.travel_nm = j.at("travel_nm").get<double>();
    return e;
}

}  // namespace afm
