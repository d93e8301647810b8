// What ./afm check warns about in a scene that is valid but likely not what
// its author meant (issues 37, 50): each warning names the key, the value
// and what to do.
//   - a scripted path segment that pushes a particle within the cone about
//     the lever's axis where the card cannot see F_x (|sin theta| below
//     fw_force.h's S_HI, 14.5 deg): the card's model then stays behind;
//   - a scripted path (operator.mode script) that outlasts duration_s: the
//     run ends mid-path (Scene's path_times_s, the walk's one summary);
//   - a scripted stroke a particle cannot follow to its end: a sphere
//     pushed by the spherical apex turns off the stroke's line and slides
//     off the tip, by the card's particle model (fw_particles_update),
//     which the truth follows;
//   - objects that start touching, or closer than the tip's diameter
//     (scene.hpp's object_pairs_within; an overlap is refused outright);
//   - particles to push without the adhesion effect (they hold by nothing:
//     the first touch slides them away);
//   - a load beyond the card's normal full scale (k_n K_n 10 V) or its
//     interlock limit;
//   - a scripted lockstep run whose wall time, estimated from its size
//     (estimate_wall), exceeds kLongRun_s;
//   - a planning run (operator.plan) whose plan needs more simulated time
//     than duration_s, by the planner's own estimate (plan_estimate.hpp,
//     which the launcher asks of the operator): the run ends with the
//     pattern half done.
// (A path off the scan field is an error already: the joystick cannot reach
// it, scene/scene.cpp.)
// A scene's expect: silences the warnings of a failure it expects
// (unobservable_push, saturation, interlock). --strict makes them errors.
#pragma once

#include <string>
#include <vector>

extern "C" {
#include "fw_card.h"
}
#include "plan_estimate.hpp"
#include "scene.hpp"

namespace afm {

// plan: the planner's estimate for a planning run (nullptr: none).
std::vector<std::string> scene_warnings(const Scene &s, const fw_card_config_t &card, const PlanEstimate *plan = nullptr);

// The run's wall time estimated from the scene's size: a linear model of
// its work (the features below), its coefficients fitted by least squares
// to runs measured on the bench's two-core machine (tools/wall_fit.py
// measures and fits; docs/scenes.md gives the fit and its error). A planned
// run ends when the planner is done (duration_s only caps it), and a
// realtime run takes duration_s by design: neither is warned of.
struct WallEstimate {
    double blocks = 0;         // analog blocks: the lockstep's round trips
    double samples = 0;        // analog samples: the simulator's steps
    double scan_px = 0;        // the two whole-field scans' points (the renderer's first, the fidelity check's), image_px^2 each
    double rough_scan_px = 0;  // the same, on a rough or measured substrate with tip_convolution (the dilation's costly case)
    double frame_px = 0;       // frames x image_px^2: drawn, written, encoded
    double wire_samples = 0;   // samples x a flexible wire's segments x relax_sweeps, summed over the wires
    double seconds = 0;        // the estimate
    bool planned = false, realtime = false;
};
WallEstimate estimate_wall(const Scene &s);
// The longest run ./afm check lets pass without a warning, wall seconds.
constexpr double kLongRun_s = 60.0;

}  // namespace afm
