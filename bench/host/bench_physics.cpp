// ./afm bench physics: the contact solver's convergence table (physics.md
// 5.1, issue 47 item 3). A particle, a rigid rod and a flexible wire, each
// pushed at constant speed (sim_afm/push_probe.hpp, the measure the unit
// test takes too) over contact stiffness 20..2000 N/m (100x), sample rates
// 10..100 kHz and sweep caps; per row the steady force, the final position,
// the solver's sweeps and worst residual; per object the spread against the
// goals (2 % of the force, 0.5 nm of the position) and a verdict line. A
// benchmark: it prints, it does not fail.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "push_probe.hpp"
#include "scene.hpp"
#include "world.hpp"

namespace {

constexpr double kForceGoal = 0.02;         // relative spread of the force
constexpr double kPositionGoal_nm = 0.5;    // spread of the final position
constexpr double kPushSpeed_nm_per_s = 1000;

// The objects: a 0.9 nN latex particle of radius 50 nm; a 1.3 um x 100 nm
// rod and a 5 um flexible wire (N = 32), friction 5 nN/um, pushed square at
// their middle. The tip: mu 0.1, 1 nN adhesion, 5 nN load.
struct Object { const char *name; bool particle; bool flexible; double half_length_nm; };

afm::Scene object_scene(const Object &o, double kc, double rate)
{
    afm::Scene s;
    s.name = "bench-physics";
    s.file = "(bench_physics)";
    s.seed = 1;
    s.duration_s = 1;
    s.field_nm = 6000;
    s.sample_rate_hz = rate;
    s.effects = {"bending_offset", "adhesion"};
    if (o.flexible) s.effects.push_back("wire_flexibility");
    s.particle_contact_stiffness_N_per_m = kc;
    s.tip_substrate.mu = 0.1;
    s.tip_substrate.adhesion_nN = 1.0;
    s.particle_substrate.mu = 0.3;
    s.particle_substrate.adhesion_nN = 3.0;
    s.op.load_nN = 5;
    s.op.path_nm = {afm::Vec2{0, -120}};
    if (o.particle) s.particles.push_back(afm::ParticleSpec{1, 0, 0, 50});
    else {
        s.wire_model.friction_nN_per_um = 5;
        s.wires.push_back(afm::WireSpec{1, -o.half_length_nm, 0, o.half_length_nm, 0, 100});
    }
    return s;
}

struct Spread { double fmin = 1e300, fmax = -1e300, pmin = 1e300, pmax = -1e300; long unconverged = 0; };

void table(const Object &o)
{
    std::printf("\n%s, pushed at %.0f nm/s\n\n", o.name, kPushSpeed_nm_per_s);
    std::printf("| stiffness, N/m | rate, kHz | cap | force, nN | final position, nm | sweeps per sample | most in a sample |"
                " worst residual, nN | worst gap, nm | unconverged |\n|---|---|---|---|---|---|---|---|---|---|\n");
    Spread sp;
    for (double kc : {20.0, 200.0, 2000.0})
        for (double rate : {10000.0, 20000.0, 100000.0})
            for (int cap : {afm::sim::kSolverMaxSweeps, 20}) {
                const auto r = afm::sim::push_at_speed(object_scene(o, kc, rate), 0, -120, 100, kPushSpeed_nm_per_s, cap);
                std::printf("| %.0f | %.0f | %d | %.4f | %.3f | %.2f | %d | %.1e | %.1e | %ld |\n", kc, rate / 1000, cap, r.force_nN,
                            r.final_nm, r.samples ? static_cast<double>(r.sweeps) / static_cast<double>(r.samples) : 0.0,
                            r.max_sweeps, r.worst_force_nN, r.worst_gap_nm, r.unconverged);
                sp.fmin = std::min(sp.fmin, r.force_nN), sp.fmax = std::max(sp.fmax, r.force_nN);
                sp.pmin = std::min(sp.pmin, r.final_nm), sp.pmax = std::max(sp.pmax, r.final_nm);
                sp.unconverged += r.unconverged;
            }
    const double df = (sp.fmax - sp.fmin) / std::max(std::fabs(sp.fmax), 1e-12), dp = sp.pmax - sp.pmin;   // of the largest force
    std::printf("\nspread: force %.3f %% (goal %.0f %%), final position %.3f nm (goal %.1f nm); %ld samples unconverged\n",
                100 * df, 100 * kForceGoal, dp, kPositionGoal_nm, sp.unconverged);
    std::printf("verdict: %s: %s\n", o.name, df <= kForceGoal && dp <= kPositionGoal_nm ? "meets the goals" : "MISSES the goals");
}

}  // namespace

int main(int argc, char **argv)
{
    const std::string only = argc > 1 ? argv[1] : "";
    if (only == "-h" || only == "--help") {
        std::printf("usage: ./afm bench physics [particle|rod|wire]\n"
                    "  The contact solver's convergence table (docs/physics.md 5.1): each object pushed at %.0f nm/s\n"
                    "  over contact stiffness 20..2000 N/m, sample rates 10..100 kHz and sweep caps %d and 20;\n"
                    "  force, final position, sweeps and worst residual; the spread against 2 %% and 0.5 nm.\n",
                    kPushSpeed_nm_per_s, afm::sim::kSolverMaxSweeps);
        return 0;
    }
    const std::vector<Object> objects = {{"particle", true, false, 0}, {"rod", false, false, 650}, {"wire", false, true, 2500}};
    bool any = false;
    for (const auto &o : objects)
        if (only.empty() || only == o.name) table(o), any = true;
    if (!any) {
        std::fprintf(stderr, "bench_physics: unknown object '%s' (particle, rod or wire)\n", only.c_str());
        return 2;
    }
    std::printf("\ntolerances per sample: force %.3f nN, gap %.3f nm; cap %d sweeps\n", afm::sim::kSolverForceTol_nN,
                afm::sim::kSolverGapTol_nm, afm::sim::kSolverMaxSweeps);
    return 0;
}
