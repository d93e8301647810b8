// Unity tests of the simulated substrates: friction loops on a tilted plane
// (physics.md section 2) and lithography on polycarbonate (section 9). The
// closed forms live here only; the simulator resolves the normal and friction
// forces of the inclined contact in the lever frame.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "sim_scene.hpp"
#include "world.hpp"

using afm::sim::World;

namespace {

const char *kTilted = R"(name: tilted-unit
seed: 2
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [bending_offset, adhesion]
sample:
  substrate: tilted_glass
  slope_deg: SLOPE
  field_nm: 2000
  tip_substrate: {mu: MU, adhesion_nN: 2.0}
operator:
  load_nN: 5
  path_nm: [[0, 0]]
)";

const char *kPoly = R"(name: litho-unit
seed: 2
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [lithography]
sample:
  substrate: polycarbonate
  field_nm: 2000
  lithography: {threshold_nN: 20, depth_nm_per_nN: 2}
operator:
  load_nN: 5
  path_nm: [[0, -200]]
)";

// Least-squares slope of y against x.
double slope(const std::vector<double> &x, const std::vector<double> &y)
{
    double mx = 0, my = 0;
    for (std::size_t i = 0; i < x.size(); ++i) mx += x[i], my += y[i];
    mx /= x.size();
    my /= y.size();
    double sxy = 0, sxx = 0;
    for (std::size_t i = 0; i < x.size(); ++i) sxy += (x[i] - mx) * (y[i] - my), sxx += (x[i] - mx) * (x[i] - mx);
    return sxy / sxx;
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_friction_loop_slopes_on_a_tilted_plane_match_eq_16_17()
{
    // Scan across the lever (scan angle 270: frames C and A coincide, F_x = 0)
    // up and down the slope at five set points; the slopes dS_l/dS_n of the
    // traces must be r_u = a tan(phi + beta) (uphill, towards -y) and
    // r_d = a tan(phi - beta) (downhill), a = k_n K_n / (k_theta K_l / h),
    // beta = atan(mu). Tolerance 1e-5 relative (measured about 1e-8): the
    // relaxation converges within each sample at this pace (0.1 nm per
    // sample), so the traces' second halves are in steady sliding.
    const double cases[][2] = {{9.0, 0.0865}, {20.0, 0.3}, {5.0, 0.2}};   // slope_deg, mu (the last: phi < beta)
    for (const auto &c : cases) {
        const afm::Scene s = scene_from_text(with(with(kTilted, "SLOPE", std::to_string(c[0])), "MU", std::to_string(c[1])));
        const double phi = c[0] * M_PI / 180, beta = std::atan(c[1]);
        const double a = s.probe.kn_N_per_m * s.probe.Kn_nm_per_V / s.probe.lateral_nN_per_V;
        std::vector<double> sn_u, sl_u, sn_d, sl_d;
        for (double load : {5.0, 10.0, 15.0, 20.0, 30.0}) {
            World w(s);
            w.set_relax_iterations(8);
            double y = 0;
            w.command(Eigen::Vector2d(0, y), load, true);
            for (int i = 0; i < 500; ++i) w.step();
            for (int dir : {+1, -1}) {   // downhill (+y), then uphill (-y)
                double sn = 0, sl = 0;
                int n = 0;
                for (int i = 0; i < 2000; ++i) {
                    y += dir * 0.1;
                    w.command(Eigen::Vector2d(0, y), load, true);
                    const afm::sim::Sample smp = w.step();
                    if (i >= 1000) sn += smp.sn_v, sl += smp.sl_v, ++n;
                }
                (dir > 0 ? sn_d : sn_u).push_back(sn / n);
                (dir > 0 ? sl_d : sl_u).push_back(sl / n);
            }
        }
        const double ru = slope(sn_u, sl_u), rd = slope(sn_d, sl_d);
        const double ru0 = a * std::tan(phi + beta), rd0 = a * std::tan(phi - beta);
        std::printf("phi %.1f deg, mu %.4f: r_u %.9f (eq. 16: %.9f), r_d %.9f (eq. 17: %.9f)\n", c[0], c[1], ru, ru0, rd, rd0);
        TEST_ASSERT_DOUBLE_WITHIN(1e-5 * std::fabs(ru0), ru0, ru);
        TEST_ASSERT_DOUBLE_WITHIN(1e-5 * std::fabs(rd0), rd0, rd);
    }
}

void test_lithography_cuts_a_v_trench_seen_by_later_scans()
{
    // Load 30 nN over a 20 nN threshold at 2 nm/nN: 20 nm deep, and the cone
    // (gamma = 20 deg) leaves 2 depth tan(gamma) = 14.56 nm at the surface.
    // The imaged profile across the line: -20 nm on the path (1e-9), 0 at
    // +-7.28 nm (bisection to 1e-6 nm; tolerance 1e-4 nm).
    const afm::Scene s = scene_from_text(kPoly);
    World w(s);
    w.command(Eigen::Vector2d(0, -200), 30, true);
    for (int i = 0; i < 100; ++i) w.step();
    w.command(Eigen::Vector2d(0, 200), 30, true);
    for (int i = 0; i < 600; ++i) w.step();
    w.command(Eigen::Vector2d(300, 200), 5, true);   // below threshold: no cut
    for (int i = 0; i < 600; ++i) w.step();
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(w.trenches().size()));
    const double depth = 20, half = depth * std::tan(s.probe.tip_half_angle_deg * M_PI / 180);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, -depth, w.image_height(0, 33.3));
    double lo = 0, hi = 50;
    while (hi - lo > 1e-6) {
        const double mid = 0.5 * (lo + hi);
        (w.image_height(mid, 33.3) < -1e-12 ? lo : hi) = mid;
    }
    std::printf("trench half width %.6f nm, 2 depth tan(gamma) / 2 = %.6f nm\n", lo, half);
    TEST_ASSERT_DOUBLE_WITHIN(1e-4, half, lo);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.0, w.image_height(100, 33.3));   // untouched beside it
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.0, w.image_height(150, 200.0 + 50));
    for (double wdt : w.trenches()[0].width_nm) TEST_ASSERT_DOUBLE_WITHIN(1e-9, 2 * half, wdt);
}

void test_wire_pushed_into_a_trench_is_held_by_it()
{
    // Cut a trench along y = 0 (load 120 nN: 200 nm deep, 146 nm wide, wider
    // than the 100 nm wire), then push a 1 um wire lying parallel at y = -300
    // by its middle (pure translation at f L) into it. Once its axis is within
    // (146 - 100) / 2 = 22.8 nm of the trench's line it is held: crossing
    // needs tan(70 + 16.7 deg) / 0.3 = 58 times its friction, more than the
    // lever can push here, so it stays put while the tip keeps pushing.
    const afm::Scene s = scene_from_text(with(with(kPoly, "effects: [lithography]",
        "effects: [bending_offset, lithography]"), "operator:",
        "  wire: {friction_nN_per_um: 20, mu: 0.3}\nobjects:\n  wires:\n"
        "    - {id: 1, x0_nm: -500, y0_nm: -300, x1_nm: 500, y1_nm: -300, diameter_nm: 100}\noperator:"));
    World w(s);
    w.set_relax_iterations(16);   // converged within a sample, as in test_wires
    auto go = [&](double x, double y, double load, int samples) {
        w.command(Eigen::Vector2d(x - w.lever().normal_offset(load).x(), y), load, true);
        for (int i = 0; i < samples; ++i) w.step();
    };
    go(-700, 0, 5, 1500);
    go(-700, 0, 120, 200);
    go(700, 0, 120, 2000);     // cut
    go(700, 0, 5, 200);
    go(700, -500, 5, 1000);
    go(0, -500, 5, 1000);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(w.trenches().size()));
    const double friction = s.tip_substrate.mu * (5 + s.tip_substrate.adhesion_nN);
    const double fL = 20.0;
    double y = -500, f_free = 0;
    int n_free = 0;
    for (int i = 0; i < 6000; ++i) {   // 0.1 nm per sample up to y = +100
        y += 0.1;
        go(0, y, 5, 1);
        if (y > -200 && y < -100) f_free += -w.tip_force().y() - friction, ++n_free;
    }
    f_free /= n_free;
    const auto &n = w.wires()[0]->nodes();
    const double held_force = -w.tip_force().y() - friction;
    std::printf("wire ends at y = %.3f, %.3f nm; free push %.3f f L, held against %.3f f L\n", n.front().y(), n.back().y(),
                f_free / fL, held_force / fL);
    TEST_ASSERT_DOUBLE_WITHIN(0.02, 1.0, f_free / fL);        // translation before the trench (2%, as test_wires)
    for (const auto &p : n) TEST_ASSERT_TRUE(p.y() > -23.0 && p.y() < -20.0);   // in the trench's reach
    TEST_ASSERT_TRUE(held_force > 3 * fL);
}

void test_lithography_is_refused_off_polycarbonate()
{
    bool refused = false;
    try {
        scene_from_text(with(kPoly, "polycarbonate", "glass"));
    } catch (const afm::SceneError &e) {
        refused = std::string(e.what()).find("sample.substrate") != std::string::npos;
    }
    TEST_ASSERT_TRUE(refused);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_friction_loop_slopes_on_a_tilted_plane_match_eq_16_17);
    RUN_TEST(test_lithography_cuts_a_v_trench_seen_by_later_scans);
    RUN_TEST(test_wire_pushed_into_a_trench_is_held_by_it);
    RUN_TEST(test_lithography_is_refused_off_polycarbonate);
    return UNITY_END();
}
