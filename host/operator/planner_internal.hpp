// What the planner's units share (planner.cpp, planner_particles.cpp,
// planner_rods.cpp, push_geometry.cpp): its tuning constants (planner.hpp's
// header says what each stage does with them) and plane vector helpers.
// Internal to the operator library: nothing outside it includes this.
#pragma once

#include <cmath>

#include "scene.hpp"

namespace afm {

namespace {   // one copy per unit

constexpr double kPi = 3.14159265358979323846;
constexpr double kStop_nm = 2.0;          // a stroke ends when the model is this close to its end (onto a site: kStopSite_nm)
constexpr double kStopSite_nm = 0.5;
constexpr double kSlowOver_nm = 40.0;     // the push onto a site slows over its last stretch ...
constexpr double kSlowest_nm_per_s = 200.0;   // ... to no slower than this
constexpr double kBackOff_nm = 30.0;      // after a push the tip backs off this far before lifting
constexpr double kLostAngle_deg = 60.0;   // the line of centres this far off the push: contact lost
constexpr double kDriftDeadband_nm = 4.0; // a pre-push scan closer than this to the model is not drift (the scan's own scatter)
constexpr double kPlaceAfterDrift_nm = 0.01;   // a drift fix that leaves the particle's model further than this from its scan is followed by a place fix
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
constexpr std::size_t kEndScans = 12;     // placed particles scanned at the end to register the drift anew (Kalman filter)
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

inline Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
inline Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
inline Vec2 operator*(double k, Vec2 a) { return {k * a.x, k * a.y}; }
inline double dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
inline double norm(Vec2 a) { return std::hypot(a.x, a.y); }
inline Vec2 unit(Vec2 a, Vec2 fallback = {1, 0})
{
    const double n = norm(a);
    return n > 1e-9 ? (1.0 / n) * a : fallback;
}
inline Vec2 perp(Vec2 a) { return {-a.y, a.x}; }

// A rod's target (centre T, axis at angle_deg) as its two ends, labelled
// to need the smaller turn from the rod's own A -> B: {end for A, end for B}.
struct RodEnds { Vec2 a, b; };
inline RodEnds rod_target_ends(Vec2 A, Vec2 B, Vec2 T, double angle_deg)
{
    const double th = angle_deg * kPi / 180, L = norm(B - A);
    Vec2 ta{std::cos(th), std::sin(th)};
    if (dot(ta, B - A) < 0) ta = -1.0 * ta;
    return {T - (L / 2) * ta, T + (L / 2) * ta};
}

// The side (nm) of the square scan that checks a rod of length_nm on its
// target (check_rod_by_scan): the rod and a local scan's margin each side.
inline double rod_check_side_nm(const PlanSpec &ps, double length_nm) { return length_nm + 2 * ps.scan_size_nm; }

// Distance from q to the segment a-b (common/scene's, the one copy).
inline double seg_dist(Vec2 q, Vec2 a, Vec2 b) { return point_segment_distance(q, a, b); }

}  // namespace

}  // namespace afm
