// A push at constant speed through the world's step, measured (physics.md
// 5.1): the convergence test (tests/sim/test_solver.cpp) and the bench
// (./afm bench physics) both push through it, so the figures they compare
// are measured one way.
//
// The tip starts at (x, y0) (the apex, not the piezo: the lever's normal
// offset is taken off the command) on the scene's load, settles, then the
// piezo's set point advances along +y at v_nm_per_s to y1 and rests there.
// The steady force is the mean lateral force along the push over the second
// half of the samples in which the object touches the tip, less the tip's
// own sliding friction on the flat substrate, mu_ts (load + F_adh,ts); the
// final position is the object's along the push when the tip has rested
// (the first particle's centre, else the first wire's mean node).
#pragma once

#include "scene.hpp"

namespace afm::sim {

struct PushRun {
    double force_nN = 0;           // steady push on the object, nN
    double final_nm = 0;           // the object's final position along the push (y, frame A), nm
    long contact_samples = 0;      // samples in which the object touched the tip
    long samples = 0, sweeps = 0;  // the solver's samples solved and sweeps in all
    int max_sweeps = 0;            // the most sweeps one sample took
    double worst_force_nN = 0, worst_gap_nm = 0;   // the worst residual a sample ended with
    long unconverged = 0;          // samples left at the cap
};

// cap: the solver's sweeps per sample at most (World::set_solver_cap).
PushRun push_at_speed(const Scene &s, double x_nm, double y0_nm, double y1_nm, double v_nm_per_s, int cap);

}  // namespace afm::sim
