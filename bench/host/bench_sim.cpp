// bench_sim: what the simulator's accuracy knobs and effects cost.
//
// Prints tables (asserts nothing):
//   1. cost per simulated second and per sample against the number of
//      particles (1, 100, 10000 on a fixed-pitch lattice: the grid keeps the
//      per-sample cost flat);
//   2. cost with each effect turned on, over a base of bending_offset and
//      100 particles; 2b. a scan as sim_afm serves it (World::scan_line),
//      plain and with the effects that act on scans; 2c. a 512 px scan
//      without and with tip_convolution (rough glass, a measured map)
//      against the goal, with it at most 3x;
//   3. pushed wires against issue 15's goals: the cost per sample (as table
//      2 measures it) and per sample in contact of a rigid rod (uniform
//      friction; a trench under part of it) and of a flexible chain of
//      N = 32 segments, with the goal beside it;
//   4. flexible wires: error of the final shape against an N = 256 reference,
//      and the cost (per sample in contact, per segment, Newton steps), for
//      N = 4 .. 1024, against the goal: linear in N (kLinearGoal).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "command_line.hpp"
#include "wire.hpp"
#include "world.hpp"

using afm::Scene;
using afm::sim::World;

namespace {

constexpr double kPitch_nm = 400;        // particle lattice pitch
constexpr double kPushSpeed_nm_per_sample = 0.1;   // 2 um/s at 20 kHz: an operator's pace

Scene base_scene(int n_particles)
{
    Scene s;
    s.name = "bench";
    s.file = "(bench_sim)";
    s.seed = 1;
    s.sample_rate_hz = 20000;
    s.duration_s = 1;
    s.effects = {"bending_offset"};
    s.tip_substrate = afm::ContactSpec{0.0865, 1.0, 0, 0};
    s.particle_substrate = afm::ContactSpec{0.3, 3.0, 0, 0};
    const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n_particles))));
    s.field_nm = std::max(5000.0, (side + 1) * kPitch_nm);
    // A lattice with a particle at the origin, which the tip pushes.
    int id = 0;
    for (int i = 0; i < side && id < n_particles; ++i)
        for (int j = 0; j < side && id < n_particles; ++j) {
            const double x = (i - side / 2) * kPitch_nm, y = (j - side / 2) * kPitch_nm;
            s.particles.push_back(afm::ParticleSpec{id++, x, y, 50});
        }
    s.op.path_nm = {afm::Vec2{0, -200}};
    return s;
}

// Runs `samples` samples pushing along +y from y0 at the operator's pace;
// wall seconds. `in_contact`: the fraction of samples with a wire in contact.
double run_push(World &w, double x, double y0, int samples, double load = 5, double *in_contact = nullptr)
{
    double y = y0;
    w.command(Eigen::Vector2d(x, y), load, true);
    for (int i = 0; i < 200; ++i) w.step();
    int touching = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < samples; ++i) {
        y += kPushSpeed_nm_per_sample;
        w.command(Eigen::Vector2d(x, y), load, true);
        w.step();
        if (in_contact)
            for (const auto &wire : w.wires()) touching += wire->in_contact;
    }
    if (in_contact) *in_contact = static_cast<double>(touching) / samples;
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void table_particles()
{
    std::printf("\n1. Cost against the number of particles (bending_offset; pushing one; lattice pitch %.0f nm)\n", kPitch_nm);
    std::printf("| particles | us per sample | wall s per simulated s | vs 1 particle |\n|---|---|---|---|\n");
    const int samples = 40000;
    double ref = 0;
    for (int n : {1, 100, 10000}) {
        const Scene s = base_scene(n);
        World w(s);
        const double wall = run_push(w, 0, -200, samples);
        const double per = wall / samples;
        if (n == 1) ref = per;
        std::printf("| %d | %.3f | %.4f | %.2fx |\n", n, per * 1e6, per * s.sample_rate_hz, per / ref);
    }
}

constexpr int kEffectRuns = 3;   // table 2's and 2b's runs a row, the fastest shown

void table_effects()
{
    std::printf("\n2. Cost of each effect (base: bending_offset, 100 particles, pushing one; imaging: a 128 x 128 scan;"
                " fastest of %d runs a row)\n", kEffectRuns);
    std::printf("| scene | us per sample | wall s per simulated s | vs base | ms per 128^2 scan | samples with a wire in contact |\n|---|---|---|---|---|---|\n");
    const int samples = 40000;
    {   // warm-up (caches, allocator), not shown
        World w(base_scene(100));
        run_push(w, 0, -200, samples);
    }
    struct Case { const char *name; std::vector<std::string> add; bool wire; std::string substrate; double load; };
    const std::vector<Case> cases = {
        {"base", {}, false, "glass", 5},
        {"+ adhesion", {"adhesion"}, false, "glass", 5},
        {"+ photodiode_noise", {"photodiode_noise"}, false, "glass", 5},
        {"+ tip_convolution", {"tip_convolution"}, false, "glass", 5},
        {"+ particle_contacts", {"particle_contacts"}, false, "glass", 5},
        {"+ thermal_drift", {"thermal_drift"}, false, "glass", 5},
        {"+ piezo_hysteresis", {"piezo_hysteresis"}, false, "glass", 5},
        {"+ piezo_creep", {"piezo_creep"}, false, "glass", 5},
        {"+ z_drift", {"z_drift"}, false, "glass", 5},
        {"+ scan_artefacts (scans only: table 2b)", {"scan_artefacts"}, false, "glass", 5},
        {"+ lithography (cutting)", {"lithography"}, false, "polycarbonate", 30},
        {"+ a rigid wire (pushed)", {}, true, "glass", 5},
        {"+ a flexible wire, N = 32 (pushed)", {"wire_flexibility"}, true, "glass", 5},
        {"tilted_glass substrate", {}, false, "tilted_glass", 5},
    };
    double ref = 0;
    for (const auto &c : cases) {
        Scene s = base_scene(100);
        for (const auto &e : c.add) s.effects.push_back(e);
        s.substrate = c.substrate;
        if (c.substrate == "tilted_glass") s.slope_deg = 9;
        s.drift_nm_per_min = afm::Vec2{10, 0};
        double x = 0;
        if (c.wire) {   // a 1.3 um wire between two lattice rows, pushed at its end
            s.wires.push_back(afm::WireSpec{1, -650, 200, 650, 200, 100});
            x = -650;
        }
        double touching = 0, per = 0, scan = 0;
        for (int r = 0; r < kEffectRuns; ++r) {   // the machine is shared: others' load only ever adds time
            World w(s);
            // Wires: 4000 samples (400 nm of push), all in contact.
            const int n = c.wire ? 4000 : samples;
            const double run = run_push(w, x, c.wire ? 80 : -200, n, c.load, &touching) / n;
            const auto t0 = std::chrono::steady_clock::now();
            for (int j = 0; j < 128; ++j)
                for (int i = 0; i < 128; ++i) w.image_height(-2500 + i * 5000.0 / 128, -2500 + j * 5000.0 / 128);
            const double sc = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            per = r == 0 ? run : std::min(per, run);
            scan = r == 0 ? sc : std::min(scan, sc);
        }
        if (ref == 0) ref = per;
        std::printf("| %s | %.3f | %.4f | %.2fx | %.2f | %.0f%% |\n", c.name, per * 1e6, per * s.sample_rate_hz, per / ref, scan * 1e3,
                    100 * touching);
    }
}

// Table 2b: a scan as sim_afm serves it (World::scan_line, line by line),
// plain and with the effects that act on scans: us per point.
void table_scans()
{
    std::printf("\n2b. Cost of a scan as served (World::scan_line; 128 x 128 over the 5 um field of table 2's scene, fastest of %d)\n",
                kEffectRuns);
    std::printf("| scene | us per scan point | vs plain |\n|---|---|---|\n");
    const std::vector<std::pair<const char *, std::vector<std::string>>> cases = {
        {"plain", {}},
        {"+ piezo_hysteresis", {"piezo_hysteresis"}},
        {"+ piezo_creep (its raster's timeline)", {"piezo_creep"}},
        {"+ scan_artefacts", {"scan_artefacts"}},
        {"+ both", {"piezo_hysteresis", "scan_artefacts"}},
    };
    const int n = 128;
    std::vector<afm::sim::ScanPoint> line(n);
    std::vector<double> best(cases.size(), 0.0);
    for (int r = 0; r < kEffectRuns; ++r)   // the rows in turn, each round: a slow spell of the machine hits them alike
        for (std::size_t k = 0; k < cases.size(); ++k) {
            Scene s = base_scene(100);
            for (const auto &e : cases[k].second) s.effects.push_back(e);
            const World w(s);
            const auto t0 = std::chrono::steady_clock::now();
            for (int j = 0; j < n; ++j) w.scan_line(-2500, 5000.0 / n, n, -2500 + j * 5000.0 / n, -2500, line.data(), 5000.0 / n);
            const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / (n * n);
            best[k] = r == 0 ? t : std::min(best[k], t);
        }
    for (std::size_t k = 0; k < cases.size(); ++k)
        std::printf("| %s | %.3f | %.2fx |\n", cases[k].first, best[k] * 1e6, best[k] / best[0]);
}

// Table 2c: imaging at the cost of its pixels (issue 49, item 3): a 512 x 512
// scan served as sim_afm serves it (World::scan_line), the scene of
// scenes/imaging.yaml (a 3 um field, two 50 nm particles, roughness 1 nm rms
// over 50 nm), on rough glass and on a measured substrate (a 256 x 256 map
// under the roughness), without and with tip_convolution. Goal: with it, at
// most 3x the scan without it.
constexpr double kImagingGoal = 3.0;

Scene imaging_scene(bool measured, bool convolution)
{
    Scene s = base_scene(0);
    s.field_nm = 3000;
    s.out.image_px = 512;
    s.effects = {"bending_offset", "roughness"};
    if (convolution) s.effects.push_back("tip_convolution");
    s.particles = {afm::ParticleSpec{1, -500, -300, 50}, afm::ParticleSpec{2, 600, 400, 50}};
    if (measured) {   // a map: two sines and a 3 nm terrace step, 11.7 nm pixels
        auto g = std::make_shared<afm::GsfGrid>();
        g->xres = g->yres = 256;
        g->xreal_m = g->yreal_m = 3000e-9;
        g->xoff_m = g->yoff_m = -1500e-9;
        for (int r = 0; r < g->yres; ++r)
            for (int c = 0; c < g->xres; ++c) {
                const double x = -1500 + (c + 0.5) * 3000.0 / 256, y = 1500 - (r + 0.5) * 3000.0 / 256;
                const double z = 4 * std::sin(x / 230) * std::cos(y / 170) + (x + 0.3 * y > 200 ? 3.0 : 0.0);
                g->values.push_back(static_cast<float>(z * 1e-9));
            }
        s.substrate_map = g;
        s.substrate_gsf = "(bench_sim: two sines and a step)";
    }
    return s;
}

// Wall seconds of one whole scan of s's field at its image_px, line by line.
double time_scan(const Scene &s)
{
    const World w(s);
    const int n = s.out.image_px;
    const double d = s.field_nm / n, x0 = -0.5 * s.field_nm + 0.5 * d;
    std::vector<afm::sim::ScanPoint> line(n);
    const auto t0 = std::chrono::steady_clock::now();
    for (int j = 0; j < n; ++j) w.scan_line(x0, d, n, x0 + j * d, x0, line.data());
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void table_imaging()
{
    std::printf("\n2c. Imaging at 512 px (World::scan_line over scenes/imaging.yaml's 3 um field: two particles, roughness;"
                " fastest of %d)\n", kEffectRuns);
    std::printf("| substrate | s per scan without tip_convolution | with | ratio | goal | met |\n|---|---|---|---|---|---|\n");
    for (const bool measured : {false, true}) {
        double plain = 0, dilated = 0;
        for (int r = 0; r < kEffectRuns; ++r) {
            const double a = time_scan(imaging_scene(measured, false)), b = time_scan(imaging_scene(measured, true));
            plain = r == 0 ? a : std::min(plain, a);
            dilated = r == 0 ? b : std::min(dilated, b);
        }
        const double ratio = dilated / plain;
        std::printf("| %s | %.3f | %.3f | %.2fx | <= %.0fx | %s |\n", measured ? "measured map + roughness" : "rough glass", plain, dilated,
                    ratio, kImagingGoal, ratio <= kImagingGoal ? "met" : "NOT met");
    }
}

// What a run of pushes cost and did.
struct PushStats {
    double us_per_sample = 0;    // wall us per sample of the run (table 2's measure, and the issue's)
    double us_per_contact = 0;   // wall us per sample with a wire in contact
    double contact = 0;          // fraction of samples with a wire in contact
    double iterations = 0;       // the last push's solver iterations, mean over those samples
    double non_uniform = 0;      // fraction of them whose rod had friction not uniform (a trench held part of it)
};

// The solver iterations of a wire's last push (rigid: IRLS or Newton on the
// static point; flexible: Newton steps), and whether its friction was not
// uniform (rigid rods only).
int wire_iterations(const afm::sim::Wire &w, bool &non_uniform)
{
    non_uniform = false;
    if (const auto *r = dynamic_cast<const afm::sim::RigidWire *>(&w)) {
        non_uniform = r->held_points > 0;
        return r->last.iterations;
    }
    if (const auto *f = dynamic_cast<const afm::sim::FlexibleWire *>(&w)) return f->last_iterations;
    return 0;
}

// Pushes along +y from (x, y0) at the operator's pace for `samples` samples
// (200 samples to settle first, not timed); the world's one wire.
PushStats measure_push(World &w, double x, double y0, int samples, double load)
{
    double y = y0;
    w.command(Eigen::Vector2d(x, y), load, true);
    for (int i = 0; i < 200; ++i) w.step();
    PushStats st;
    int touching = 0, held = 0;
    long iters = 0;
    double wall = 0;
    for (int i = 0; i < samples; ++i) {
        y += kPushSpeed_nm_per_sample;
        const auto t0 = std::chrono::steady_clock::now();
        w.command(Eigen::Vector2d(x, y), load, true);
        w.step();
        wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const afm::sim::Wire &wire = *w.wires()[0];
        if (!wire.in_contact) continue;
        bool non_uniform;
        ++touching;
        iters += wire_iterations(wire, non_uniform);
        held += non_uniform;
    }
    st.contact = static_cast<double>(touching) / samples;
    st.us_per_sample = 1e6 * wall / samples;
    st.us_per_contact = 1e6 * wall / std::max(touching, 1);
    st.iterations = static_cast<double>(iters) / std::max(touching, 1);
    st.non_uniform = static_cast<double>(held) / std::max(touching, 1);
    return st;
}

// Moves the tip to `to` at load_nN (engaged) or lifted, and waits until the
// scanner (1 nm per sample) is there.
void go(World &w, const Eigen::Vector2d &to, double load_nN, bool engaged, int samples)
{
    w.command(to, load_nN, engaged);
    for (int i = 0; i < samples; ++i) w.step();
}

// The effects table's wire scene: 100 particles, bending_offset, drift, a
// 1.3 um wire at y = 200 between two lattice rows.
Scene goal_wire_scene(bool flexible)
{
    Scene s = base_scene(100);
    if (flexible) s.effects.push_back("wire_flexibility");
    s.drift_nm_per_min = afm::Vec2{10, 0};
    s.wires.push_back(afm::WireSpec{1, -650, 200, 650, 200, 100});
    return s;
}

// A goal row's run: a fresh world from the scene, set up by `prepare` (not
// timed), then pushed from (x, y0). The fastest of kGoalRuns runs is shown:
// the machine is shared, and the others' load only ever adds time.
constexpr int kGoalRuns = 3;

template <class Prepare>
PushStats best_of_runs(const Scene &s, double x, double y0, int samples, Prepare prepare)
{
    PushStats best;
    for (int r = 0; r < kGoalRuns; ++r) {
        World w(s);
        prepare(w);
        const PushStats st = measure_push(w, x, y0, samples, 5);
        if (r == 0 || st.us_per_sample < best.us_per_sample) best = st;
    }
    return best;
}

void table_wire_goals()
{
    const int samples = 4000;   // 400 nm of push
    std::printf("\n3. Pushed wires against issue 15's goals (scene of table 2: 100 particles, bending_offset, drift;"
                " a 1.3 um x 100 nm wire at y = 200; %d samples pushing %.0f nm along +y at %.1f nm per sample, the tip"
                " reaching the wire after a few hundred; fastest of %d runs). Goal and 'met': us per sample over the run,"
                " as table 2 and issue 15 measure it; per sample in contact beside it\n",
                samples, samples * kPushSpeed_nm_per_sample, kPushSpeed_nm_per_sample, kGoalRuns);
    std::printf("| wire | us per sample | goal, us per sample | met | us per sample in contact | samples in contact |"
                " solver iterations per push | pushes with friction not uniform |\n|---|---|---|---|---|---|---|---|\n");
    auto row = [](const char *name, const PushStats &st, double goal_us) {
        char goal[32] = "-", met[8] = "-";
        if (goal_us > 0) {
            std::snprintf(goal, sizeof goal, "%.0f", goal_us);
            std::snprintf(met, sizeof met, "%s", st.us_per_sample <= goal_us ? "yes" : "no");
        }
        std::printf("| %s | %.2f | %s | %s | %.2f | %.0f%% | %.1f | %.0f%% |\n", name, st.us_per_sample, goal, met,
                    st.us_per_contact, 100 * st.contact, st.iterations, 100 * st.non_uniform);
    };
    auto nothing = [](World &) {};
    {   // warm-up (caches, allocator), not shown
        World w(goal_wire_scene(false));
        measure_push(w, -650, 80, samples / 4, 5);
    }
    row("rigid rod, uniform friction, pushed at its end (l = 0)", best_of_runs(goal_wire_scene(false), -650, 80, samples, nothing), 2);
    row("rigid rod, uniform friction, pushed at l = L/4", best_of_runs(goal_wire_scene(false), -325, 80, samples, nothing), 2);
    {   // A trench (120 nN on polycarbonate: 200 nm deep, 146 nm wide) along
        // y = 300 under the rod's left half, x in [-1000, 0], cut with the
        // tip; the rod is then pushed at l = 3L/4 into it, and the trench
        // holds that half.
        Scene s = goal_wire_scene(false);
        s.substrate = "polycarbonate";
        s.effects.push_back("lithography");
        auto cut = [](World &w) {
            go(w, Eigen::Vector2d(-1000, 300), 0, false, 1500);
            go(w, Eigen::Vector2d(-1000, 300), 120, true, 200);
            go(w, Eigen::Vector2d(0, 300), 120, true, 1200);
            go(w, Eigen::Vector2d(0, 300), 0, false, 100);
            go(w, Eigen::Vector2d(325, 80), 0, false, 400);
        };
        row("rigid rod, a trench under its left half, pushed at l = 3L/4", best_of_runs(s, 325, 80, samples, cut), 0);
    }
    row("flexible chain, N = 32, pushed at its end (l = 0)", best_of_runs(goal_wire_scene(true), -650, 80, samples, nothing), 10);
    {   // Table 4's wire: 5 um (lambda 50), no particles.
        Scene s = base_scene(0);
        s.particles.clear();
        s.effects.push_back("wire_flexibility");
        s.wires.push_back(afm::WireSpec{1, -2500, 0, 2500, 0, 100});
        row("flexible chain, N = 32, 5 um (lambda 50), pushed at l = L/4", best_of_runs(s, -1250, -120, samples, nothing), 10);
    }
}

// Shape of a wire resampled at m equal arc positions.
std::vector<Eigen::Vector2d> resample(const std::vector<Eigen::Vector2d> &x, int m)
{
    std::vector<double> arc(x.size(), 0.0);
    for (std::size_t i = 1; i < x.size(); ++i) arc[i] = arc[i - 1] + (x[i] - x[i - 1]).norm();
    std::vector<Eigen::Vector2d> out;
    std::size_t k = 0;
    for (int j = 0; j < m; ++j) {
        const double a = arc.back() * j / (m - 1);
        while (k + 2 < x.size() && arc[k + 1] < a) ++k;
        const double t = std::clamp((a - arc[k]) / (arc[k + 1] - arc[k]), 0.0, 1.0);
        out.push_back(x[k] + t * (x[k + 1] - x[k]));
    }
    return out;
}

// Table 4's goal: the flexible wire's cost linear in its segments, the
// cost per sample per segment at every N from 32 to 1024 within this factor
// of N = 32's (issue 49 item 4).
constexpr double kLinearGoal = 2.0;

void table_flexible()
{
    const double L = 5000, d = 100;
    const int samples = 4000;   // 400 nm of push at 2 um/s
    std::printf("\n4. Flexible wire (silver, %.0f nm x %.0f nm, lambda %.0f; friction 20 nN/um; pushed %.0f nm at l = L/4):"
                " shape error against N = 256, and the cost per sample in contact (per segment: linear in N keeps it flat)\n",
                L, d, L / d, samples * kPushSpeed_nm_per_sample);
    std::printf("| N | max shape error, nm | rms shape error, nm | us per sample in contact | us per sample per segment |"
                " Newton steps per sample in contact | steps unconverged | wall s per simulated s |\n|---|---|---|---|---|---|---|---|\n");
    struct Run {
        std::vector<Eigen::Vector2d> shape;
        double per = 0, newton = 0;   // wall s and Newton steps per sample in contact
        long unconverged = 0;
    };
    auto run = [&](int N) {
        Scene s = base_scene(0);
        s.particles.clear();
        s.effects.push_back("wire_flexibility");
        s.wire_model.segments = N;
        s.wires.push_back(afm::WireSpec{1, -L / 2, 0, L / 2, 0, d});
        World w(s);
        double touching = 0;
        Run r;
        r.per = run_push(w, -L / 4, -120, samples, 5, &touching) / (samples * std::max(touching, 1e-9));
        const auto &fw = dynamic_cast<const afm::sim::FlexibleWire &>(*w.wires()[0]);
        r.newton = static_cast<double>(fw.newton_steps) / std::max(1L, fw.solved);
        r.unconverged = fw.unconverged;
        r.shape = resample(fw.nodes(), 257);
        return r;
    };
    const Run ref = run(256);
    double per_seg_32 = 0, worst_ratio = 0;
    for (int N : {4, 8, 16, 32, 64, 128, 256, 512, 1024}) {
        const Run r = N == 256 ? ref : run(N);
        double worst = 0, sum2 = 0;
        for (std::size_t i = 0; i < ref.shape.size(); ++i) {
            const double e = (r.shape[i] - ref.shape[i]).norm();
            worst = std::max(worst, e);
            sum2 += e * e;
        }
        const double per_seg = r.per * 1e6 / N;
        if (N == 32) per_seg_32 = per_seg;
        if (N >= 32) worst_ratio = std::max(worst_ratio, per_seg / per_seg_32);
        std::printf("| %d%s | %.3f | %.3f | %.1f | %.3f | %.1f | %ld | %.3f |\n", N, N == 256 ? " (reference)" : "", worst,
                    std::sqrt(sum2 / ref.shape.size()), r.per * 1e6, per_seg, r.newton, r.unconverged, r.per * 20000);
    }
    std::printf("Goal, linear in N: us per sample per segment from N = 32 to 1024 within %.0fx of N = 32's: worst %.2fx, %s\n",
                kLinearGoal, worst_ratio, worst_ratio <= kLinearGoal ? "met" : "NOT met");
}

struct Options {
    std::string only;   // "": every table
};

const afm::cli::CommandLine<Options> kCommandLine = {
    "bench_sim",
    "usage: bench_sim [particles|effects|imaging|wires]\n  Prints the simulator's cost and accuracy tables (all by default);\n"
    "  wires: the pushed wires against issue 15's goals, then the flexible wire's accuracy against N.\n",
    {{{"TABLE", nullptr, nullptr, nullptr}, afm::cli::choice(&Options::only, {"particles", "effects", "imaging", "wires"})}}};

}  // namespace

int main(int argc, char **argv)
{
    Options o;
    if (const int code = afm::cli::read_command_line(kCommandLine, argc, argv, &o); code >= 0) return code;
    const std::string &only = o.only;
    std::printf("bench_sim: 20 kHz samples; wall s per simulated s = the simulator's cost alone (no bus)\n");
    if (only.empty() || only == "particles") table_particles();
    if (only.empty() || only == "effects") {
        table_effects();
        table_scans();
    }
    if (only.empty() || only == "imaging") table_imaging();
    if (only.empty() || only == "wires") {
        table_wire_goals();
        table_flexible();
    }
    return 0;
}
