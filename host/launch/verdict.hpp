// A run's verdict (issue 37: a run that tells the truth about itself).
//
// A run that completes can still have failed one of its own checks. Each is
// judged from run.json as the launcher puts it together (the processes' own
// reports), never from the simulator's truth:
//   fidelity           the display against a fresh scan, outside its target
//                      (the renderer's fidelity.json "pass");
//   assembly           the planner's sites without a particle within their
//                      tolerance, or a rod off its target (fidelity.json
//                      "assembly", from the fresh scan);
//   interlock          the card's force interlock tripped (fw_report.json
//                      interlock_trips);
//   saturation         samples with an ADC saturated (the card's count);
//   unobservable_push  blocks in which the card pushed an object while F_x
//                      was unobservable (motion along the lever's axis: the
//                      card's friction fallback);
//   solver             samples the simulator's contact solver left
//                      unconverged at its cap (sim_report.json solver
//                      unconverged_samples > 0; the tolerances are the
//                      solver's own, physics.md 5.1).
// The names are scene/scene.hpp's verdict_checks(); a scene's expect:
// lists those it fails on purpose. An expected failure that happens passes;
// an expected one that does not is itself a failure ("expect").
//
// judge() returns {"pass": bool, "failed": [{"check", "detail"}],
// "expected": [...], "met": [...]}: run.json's "verdict". line() is the
// run's last line. The launcher exits kExitVerdict (4) when it does not
// pass, unless --no-verdict.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace afm {

nlohmann::json judge(const nlohmann::json &run, const std::vector<std::string> &expect);
std::string verdict_line(const nlohmann::json &verdict);

}  // namespace afm
