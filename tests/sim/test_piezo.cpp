// The scanner's piezo (sim_afm/piezo.hpp) against its laws: the
// Prandtl-Ishlinskii loop's width at full range, the creep per decade of the
// log law and the relaxers' fit, the World's piezo following the drive
// through them while the analog block reports the drive, and a scan's
// points carrying the creep of the steps before them.
#include <unity.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "../scene_text.hpp"
#include "piezo.hpp"
#include "scan_raster.hpp"
#include "world.hpp"

using afm::sim::LogCreep;
using afm::sim::PlayHysteresis;
using afm::sim::World;

namespace {

// A loop's figures over the second of two cycles between -A and +A from 0,
// in steps of A / 1000: its widest vertical opening (descending less
// ascending branch at the same input) and the output's peak-to-peak range.
struct Loop { double opening, range; };

Loop cycle(double width, double span, double A)
{
    PlayHysteresis h(width, span, 0.0);
    const int n = 1000;
    std::vector<double> up(2 * n + 1), down(2 * n + 1);
    auto leg = [&](double from, double to, std::vector<double> *out) {
        for (int i = 0; i <= 2 * n; ++i) {
            const double y = h.step(from + (to - from) * i / (2 * n));
            if (out) (*out)[to > from ? i : 2 * n - i] = y;
        }
    };
    for (int i = 0; i <= n; ++i) h.step(A * i / n);   // the initial curve to +A
    leg(A, -A, nullptr);
    leg(-A, A, nullptr);
    leg(A, -A, &down);
    leg(-A, A, &up);
    Loop l{0, 0};
    for (int i = 0; i <= 2 * n; ++i) l.opening = std::max(l.opening, down[i] - up[i]);
    l.range = *std::max_element(up.begin(), up.end()) - *std::min_element(down.begin(), down.end());
    return l;
}

const char *kScene = R"(name: piezo
seed: 5
duration_s: 2
sample_rate_hz: 10000
block_hz: 1000
effects: [EFFECTS]
sample:
  substrate: glass
  field_nm: 5000
afm:
  hysteresis: {width_pct: 10, span_nm: 5000}
  creep: {gamma_pct_per_decade: 1.5, t0_s: 0.1}
operator:
  load_nN: 5
  path_nm: [[0, 0]]
)";

}  // namespace

void setUp() {}
void tearDown() {}

void test_hysteresis_loop_at_full_range_is_its_width()
{
    // The closed form (piezo.hpp): opening / range = w exactly over a
    // cycle of the span, and the range is the input's (the gain g).
    for (double w : {0.02, 0.10, 0.15, 0.23}) {
        const Loop l = cycle(w, 90000, 45000);
        char what[64];
        std::snprintf(what, sizeof what, "width %.2f", w);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(1e-9, w, l.opening / l.range, what);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(1e-6, 90000.0, l.range, what);
    }
    const Loop l = cycle(0.10, 90000, 45000);
    std::printf("piezo_hysteresis: width 10 %% at full range: opening %.1f nm of %.1f nm = %.4f\n", l.opening, l.range,
                l.opening / l.range);
}

void test_hysteresis_smaller_cycles_open_narrower_loops()
{
    // Fewer plays turn in a smaller cycle: the relative opening falls with
    // the amplitude (2 % of the range at small signals, 10-15 % at large).
    double last = 1.0;
    for (double frac : {1.0, 0.5, 0.2, 0.1}) {
        const Loop l = cycle(0.10, 5000, 2500 * frac);
        std::printf("piezo_hysteresis: a cycle of %.0f %% of the span: opening %.4f of its range\n", 100 * frac, l.opening / l.range);
        TEST_ASSERT_TRUE(l.opening / l.range <= last + 1e-12);
        last = l.opening / l.range;
    }
    TEST_ASSERT_TRUE(last < 0.03);
}

void test_hysteresis_is_rate_independent()
{
    // The same path in 10 or in 1000 steps a leg: the same output at each
    // leg's end (a play's state after a monotone leg is its end's).
    PlayHysteresis a(0.1, 5000, 0), b(0.1, 5000, 0);
    double from = 0;
    for (double to : {2000.0, -1500.0, 700.0, 650.0, 2400.0}) {
        for (int i = 1; i <= 10; ++i) a.step(from + (to - from) * i / 10);
        for (int i = 1; i <= 1000; ++i) b.step(from + (to - from) * i / 1000);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, b.output(), a.output());
        from = to;
    }
}

void test_creep_per_decade_follows_the_log_law()
{
    // A step of 1000 nm at t = 0 held for 100 s (t0 0.1 s, gamma 1.5 %): the
    // output at t0 10^k against 1000 (1 + gamma k). Tolerance: the fit's
    // worst deviation over [t0, T] (fit_error, decades) times gamma D, and
    // 1e-3 of it for the sampling.
    const double dt = 1e-3, gamma = 0.015, D = 1000;
    LogCreep c(gamma, 0.1, 100, dt, 0.0);
    std::printf("piezo_creep: %zu relaxers, tau %.3g .. %.3g s, fit error %.4f decades (%.2f %% of gamma per decade)\n",
                c.taus_s().size(), c.taus_s().front(), c.taus_s().back(), c.fit_error(), 100 * c.fit_error());
    TEST_ASSERT_TRUE(c.fit_error() < 0.03);
    std::vector<double> at;
    double y = 0;
    const int steps = static_cast<int>(std::lround(100 / dt));
    int next = 100;   // 0.1 s
    for (int i = 1; i <= steps; ++i) {
        y = c.step(D);
        if (i == next) {
            at.push_back(y);
            next *= 10;
        }
    }
    TEST_ASSERT_EQUAL_INT(4, static_cast<int>(at.size()));   // 0.1, 1, 10, 100 s
    const double tol = (c.fit_error() + 1e-3) * gamma * D;
    for (std::size_t k = 0; k < at.size(); ++k) {
        TEST_ASSERT_DOUBLE_WITHIN(tol, D * (1 + gamma * static_cast<double>(k)), at[k]);
        if (k > 0)
            std::printf("piezo_creep: decade %zu: %.3f %% of the step (law 1.5 %%)\n", k, 100 * (at[k] - at[k - 1]) / D);
    }
}

void test_creep_superposes_steps()
{
    // Two steps: the response is the sum of each step's (linear in the input).
    const double dt = 1e-3;
    LogCreep both(0.015, 0.1, 10, dt, 0.0), first(0.015, 0.1, 10, dt, 0.0), second(0.015, 0.1, 10, dt, 0.0);
    double yb = 0, y1 = 0, y2 = 0;
    for (int i = 0; i < 5000; ++i) {
        const bool later = i >= 2000;
        yb = both.step(later ? 300.0 : 1000.0);
        y1 = first.step(1000.0);
        y2 = second.step(later ? -700.0 : 0.0);
    }
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, y1 + y2, yb);
}

void test_world_piezo_follows_the_drive_through_the_models()
{
    // Without the effects the piezo is at the drive; with hysteresis it
    // lags on a reversal, and the analog block reports the drive.
    World plain(scene_from_text(with(kScene, "EFFECTS", "")));
    World hyst(scene_from_text(with(kScene, "EFFECTS", "piezo_hysteresis")));
    const auto m = hyst.models_built();
    TEST_ASSERT_TRUE(std::find(m.begin(), m.end(), "piezo_hysteresis") != m.end());
    for (World *w : {&plain, &hyst}) {
        w->command(Eigen::Vector2d(2000, 0), 5, true);
        for (int i = 0; i < 2000; ++i) w->step();
        w->command(Eigen::Vector2d(0, 0), 5, true);
        for (int i = 0; i < 2000; ++i) w->step();
    }
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, (plain.piezo() - plain.drive()).norm());
    const afm::sim::Sample s = hyst.step();
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, s.piezo_nm.x());   // the drive
    std::printf("piezo_hysteresis: after 0 -> 2000 -> 0 nm the piezo is at x = %.1f nm\n", hyst.piezo().x());
    TEST_ASSERT_TRUE(hyst.piezo().x() > 20.0);   // the descending branch lies above
}

// A tilted substrate's height tells each scan point's true y: h = -y tan(slope).
const char *kTilted = R"(name: piezo-scan
seed: 5
duration_s: 2
sample_rate_hz: 10000
block_hz: 1000
effects: [EFFECTS]
sample:
  substrate: tilted_glass
  slope_deg: 10
  field_nm: 5000
afm:
  creep: {gamma_pct_per_decade: 1.5, t0_s: 0.1}
operator:
  load_nN: 5
  path_nm: [[0, 0]]
)";

// A scan's lines of n points across x0 .. x0 + W at y_first + j dy (dy
// tiny: the raster's own steps creep by nothing measurable), each point's
// true y from the substrate's height less its commanded y, against the
// law's creep of a step D made `before_s` before the scan (its ramp's
// middle) at the point's time on the raster (common/scan_raster.hpp);
// the worst deviation over the points at t0 or later after the step.
double worst_against_law(const World &w, double y_first, double D, double before_s, int lines, double *creep_end)
{
    constexpr int n = 64;
    constexpr double x0 = -2500, W = 5000, dy = 1e-3, gamma = 0.015, t0 = 0.1;
    const double tan_slope = std::tan(10 * M_PI / 180), dx = W / n;
    const afm::ScanRaster raster = afm::scan_raster(dx, n);
    std::vector<afm::sim::ScanPoint> p(n);
    double worst = 0;
    for (int j = 0; j < lines; ++j) {
        const double y = y_first + j * dy;
        w.scan_line(x0, dx, n, y, y_first, p.data(), dy);
        for (int i = 0; i < n; ++i) {
            const double t = before_s + raster.line_time_s(j), creep = -p[static_cast<std::size_t>(i)].height_nm / tan_slope - y;
            if (t < t0) continue;
            worst = std::max(worst, std::fabs(creep - gamma * D * std::log10(t / t0)));
            *creep_end = creep;
        }
    }
    return worst;
}

void test_a_scan_carries_the_creep_of_the_steps_before_it()
{
    // The creep's law in a scan: 2000 nm away from the tip's rest, the
    // raster's first point is a step; 0.5 s after a move of 2000 nm the
    // scan's start carries that move's creep. Each line, 0.5 s long, sees
    // the step's creep grown by its time: y less its command is
    // gamma D log10(t / t0) within the fit's error (and 0.005 gamma D for
    // the move's ramp, taken at its middle).
    constexpr double D = 2000, gamma = 0.015;
    World at_rest(scene_from_text(with(kTilted, "EFFECTS", "piezo_creep")));
    double end = 0;
    const double e_rest = worst_against_law(at_rest, D, D, 0.0, 64, &end);
    std::printf("piezo_creep in a scan: the step to the raster's start, 64 lines (32 s): y within %.2f nm of the law; "
                "%.1f nm of creep at the last line (law %.1f)\n", e_rest, end, gamma * D * std::log10(32 / 0.1));
    World moved(scene_from_text(with(kTilted, "EFFECTS", "piezo_creep")));
    moved.command(Eigen::Vector2d(0, D), 5, true);
    for (int i = 0; i < 5000; ++i) moved.step();   // 0.5 s; the drive gets there in 0.1 s
    const double ramp_mid_s = 0.5 - 0.5 * D / 20000.0;
    const double e_moved = worst_against_law(moved, D, D, ramp_mid_s, 16, &end);
    std::printf("piezo_creep in a scan 0.5 s after a 2000 nm move: y within %.2f nm of the law; %.1f nm at its last line\n",
                e_moved, end);
    const double tol = (0.03 + 0.005) * gamma * D;   // the relaxers' fit error (below 0.03 decades) and the ramp
    TEST_ASSERT_TRUE(e_rest < tol);
    TEST_ASSERT_TRUE(e_moved < tol);
    TEST_ASSERT_TRUE(end > 0.02 * D);   // the creep is there: 2.4 % of the move at the last line
    // without the effect the scan's y is its command
    World plain(scene_from_text(with(kTilted, "EFFECTS", "")));
    const double e_plain = worst_against_law(plain, D, 0.0, 0.0, 4, &end);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, e_plain);
}

void test_world_without_the_effects_builds_no_piezo_model()
{
    World w(scene_from_text(with(kScene, "EFFECTS", "bending_offset")));
    for (const auto &name : w.models_built()) {
        TEST_ASSERT_TRUE_MESSAGE(name.find("piezo_") == std::string::npos, name.c_str());
        TEST_ASSERT_TRUE_MESSAGE(name != "scan_artefacts", name.c_str());
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_hysteresis_loop_at_full_range_is_its_width);
    RUN_TEST(test_hysteresis_smaller_cycles_open_narrower_loops);
    RUN_TEST(test_hysteresis_is_rate_independent);
    RUN_TEST(test_creep_per_decade_follows_the_log_law);
    RUN_TEST(test_creep_superposes_steps);
    RUN_TEST(test_world_piezo_follows_the_drive_through_the_models);
    RUN_TEST(test_a_scan_carries_the_creep_of_the_steps_before_it);
    RUN_TEST(test_world_without_the_effects_builds_no_piezo_model);
    return UNITY_END();
}
