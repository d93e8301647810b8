// Unity tests of the simulated substrates: friction loops on a tilted plane
// (physics.md section 2), the scan lines' signals (the same contact physics),
// lithography on polycarbonate (section 9) and substrate roughness. The
// closed forms live here only; the simulator resolves the normal and friction
// forces of the inclined contact in the lever frame.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "../scene_text.hpp"
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

// Flat glass, one particle, for scan lines (SCAN: scan angle, EFFECTS).
const char *kScan = R"(name: scan-unit
seed: 5
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [EFFECTS]
sample:
  substrate: glass
  field_nm: 2000
  tip_substrate: {mu: 0.1, adhesion_nN: 1.0}
probe:
  scan_angle_deg: SCAN
objects:
  particles:
    - {id: 1, x_nm: 0, y_nm: 0, radius_nm: 50}
operator:
  load_nN: 5
  path_nm: [[0, -500]]
)";

// Rough glass (RMS, CORR), no objects.
const char *kRough = R"(name: rough-unit
seed: SEED
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [roughness]
sample:
  substrate: glass
  field_nm: 2000
  roughness_rms_nm: RMS
  roughness_corr_nm: CORR
operator:
  load_nN: 5
  path_nm: [[0, 0]]
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
        const double a = s.probe.spring_N_per_m * s.probe.deflection_nm_per_V / s.probe.lateral_nN_per_V;
        std::vector<double> sn_u, sl_u, sn_d, sl_d;
        for (double load : {5.0, 10.0, 15.0, 20.0, 30.0}) {
            World w(s);
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

void test_wire_pushed_into_a_trench_sinks_into_it_and_is_held()
{
    // Cut a trench along y = 0 (load 120 nN: 200 nm deep, 146 nm wide, wider
    // than the 100 nm wire), then push a 1 um wire lying parallel at y = -300
    // by its middle (pure translation at f L) into it. Once its axis is over
    // the V's opening (within 73 nm of the trench's line) it slides down the
    // walls onto the line and rests on both walls (World::settle_rods), its
    // axis at -D + R / sin gamma, its top below the surface; it is held
    // there: crossing needs tan(70 + 16.7 deg) / 0.3 = 58 times its
    // friction, more than the lever can push here, so it stays put while
    // the tip keeps pushing.
    const afm::Scene s = scene_from_text(with(with(kPoly, "effects: [lithography]",
        "effects: [bending_offset, lithography]"), "operator:",
        "  wire: {friction_nN_per_um: 20, mu: 0.3}\nobjects:\n  wires:\n"
        "    - {id: 1, x0_nm: -500, y0_nm: -300, x1_nm: 500, y1_nm: -300, diameter_nm: 100}\noperator:"));
    World w(s);
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
        if (y > -200 && w.wires()[0]->nodes().front().y() < -90) f_free += -w.tip_force().y() - friction, ++n_free;   // before the groove
    }
    f_free /= n_free;
    const auto &n = w.wires()[0]->nodes();
    const double held_force = -w.tip_force().y() - friction;
    std::printf("wire ends at y = %.3f, %.3f nm; free push %.3f f L, held against %.3f f L\n", n.front().y(), n.back().y(),
                f_free / fL, held_force / fL);
    TEST_ASSERT_DOUBLE_WITHIN(0.02, 1.0, f_free / fL);        // translation before the trench (2%, as test_rods)
    for (const auto &p : n) TEST_ASSERT_DOUBLE_WITHIN(0.5, 0.0, p.y());   // on the trench's line
    TEST_ASSERT_TRUE(held_force > 3 * fL);
    double D = 0;
    for (double d : w.trenches()[0].depth_nm) D += d / w.trenches()[0].depth_nm.size();
    const double g = s.probe.tip_half_angle_deg * M_PI / 180, seat = -D + 50.0 / std::sin(g);
    std::printf("seated: axis %.3f nm (-D + R / sin gamma = %.3f), top in the image %.3f nm\n", w.wire_axis_height_nm(0), seat,
                w.image_height(0, 0));
    TEST_ASSERT_DOUBLE_WITHIN(2.0, seat, w.wire_axis_height_nm(0));   // the depth varies a little along the cut
    TEST_ASSERT_TRUE(w.wire_axis_height_nm(0) + 50 < -3);              // its top below the surface (by 3.8 nm here)
    TEST_ASSERT_DOUBLE_WITHIN(2.0, w.wire_axis_height_nm(0) + 50, w.image_height(0, 0));
}

void test_lithography_is_refused_off_polycarbonate()
{
    TEST_ASSERT_TRUE(scene_error(with(kPoly, "polycarbonate", "glass")).find("sample.substrate") != std::string::npos);
}

void test_scan_line_on_tilted_glass_reads_what_the_tip_sliding_there_reads()
{
    // A scan line in +x reads, at every point, what World::step() reads while
    // the tip slides there in +x at the scene's load (the friction loop's
    // physics: normal and friction force of the inclined contact, resolved in
    // the lever frame, F_x bending the lever as eq. 1c says). At scan angle
    // 270 the line runs along the lever (S_l from the tilt of the normal
    // force), at 180 across it (S_l from friction), 225 between. Where the
    // lever's stiffness is diagonal in frame A (270, 180) the sliding trace is
    // exact: 1e-5 relative, as the loop test. At 225 the per-sample
    // projection onto the friction cone, with a lever stiffer across than
    // along, biases the slip direction by O(step): measured S_l error
    // 2.5e-4, 2.6e-5, 2.6e-6 V at 0.1, 0.01, 0.001 nm per sample, so at
    // 0.001 nm the tolerance is 2e-3 relative (the scan line is the limit).
    const struct { int line; const char *angle; double step_nm, rel; } rows[] = {
        {__LINE__, "270", 0.1, 1e-5},
        {__LINE__, "180", 0.1, 1e-5},
        {__LINE__, "225", 0.001, 2e-3},
    };
    for (const auto &r : rows) {
        const std::string text = with(with(kTilted, "SLOPE", "9"), "MU", "0.0865") + "probe:\n  scan_angle_deg: " + r.angle + "\n";
        const afm::Scene s = scene_from_text(text);
        World w(s);
        const double y = 100, load = s.op.load_nN;
        double x = -150;
        w.command(Eigen::Vector2d(x, y), load, true);
        for (int i = 0; i < 500; ++i) w.step();
        double sn = 0, sl = 0, ax = 0, ay = 0;
        int n = 0;
        const int samples = static_cast<int>(std::lround(200.0 / r.step_nm));   // 200 nm of sliding: past the transient
        for (int i = 0; i < samples; ++i) {
            x += r.step_nm;
            w.command(Eigen::Vector2d(x, y), load, true);
            const afm::sim::Sample smp = w.step();
            if (i >= samples - 1000) sn += smp.sn_v, sl += smp.sl_v, ax += w.apex().x(), ay += w.apex().y(), ++n;
        }
        sn /= n, sl /= n, ax /= n, ay /= n;
        const afm::sim::ScanPoint p = w.scan_point(ax, ay);
        char where[160];
        std::snprintf(where, sizeof where, "row at line %d: sliding S_n %.9f S_l %.9f V; scan line S_n %.9f S_l %.9f V", r.line, sn,
                      sl, p.sn_v, p.sl_v);
        std::printf("scan angle %s: %s\n", r.angle, where);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(r.rel * std::fabs(sn) + 1e-12, sn, p.sn_v, where);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(r.rel * std::fabs(sl) + 1e-12, sl, p.sl_v, where);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(1e-9, w.image_height(ax, ay), p.height_nm, where);
    }
    // Closed form at scan angle 180 (frame C's y is frame A's x), sliding
    // across the lever and across the slope: N = (F_z + F_adh cos phi) / cos phi,
    // S_l = -mu N / (k_theta K_l / h); the normal force's horizontal part
    // F_z tan phi points to +y of A = -x of C and bends the lever (eq. 1c).
    // Rounding only (1e-9 V).
    const afm::Scene s = scene_from_text(with(with(kTilted, "SLOPE", "9"), "MU", "0.0865") + "probe:\n  scan_angle_deg: 180\n");
    const World w(s);
    const double phi = 9 * M_PI / 180, fz = s.op.load_nN, adh = s.tip_substrate.adhesion_nN, mu = s.tip_substrate.mu;
    const double N = (fz + adh * std::cos(phi)) / std::cos(phi);
    const afm::sim::ScanPoint p = w.scan_point(0, 0);
    const double h = s.probe.tip_height_um * 1e3, l = s.probe.lever_length_um * 1e3, knKn = s.probe.spring_N_per_m * s.probe.deflection_nm_per_V;
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, -mu * N / s.probe.lateral_nN_per_V, p.sl_v);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, (fz - 2 * h / l * fz * std::tan(phi)) / knKn, p.sn_v);
}

void test_scan_line_on_flat_glass_reads_friction_and_the_set_point()
{
    // Across the lever (scan angle 180): S_l = -mu (F_z + F_adh) / (k_theta
    // K_l / h), S_n = F_z / (k_n K_n); along it (270): S_l = 0 and F_x =
    // -mu (F_z + F_adh) bends the lever (eq. 1c). Rounding only (1e-12 V).
    for (const char *angle : {"180", "270"}) {
        const afm::Scene s = scene_from_text(with(with(kScan, "SCAN", angle), "EFFECTS", "adhesion"));
        const World w(s);
        const double f = s.tip_substrate.mu * (s.op.load_nN + s.tip_substrate.adhesion_nN);
        const double knKn = s.probe.spring_N_per_m * s.probe.deflection_nm_per_V;
        const double h = s.probe.tip_height_um * 1e3, l = s.probe.lever_length_um * 1e3;
        const bool across = std::string(angle) == "180";
        for (double x : {-900.0, 500.0, 800.0}) {
            const afm::sim::ScanPoint p = w.scan_point(x, 300);
            TEST_ASSERT_DOUBLE_WITHIN(1e-12, across ? -f / s.probe.lateral_nN_per_V : 0.0, p.sl_v);
            TEST_ASSERT_DOUBLE_WITHIN(1e-12, (s.op.load_nN - (across ? 0.0 : 2 * h / l * f)) / knKn, p.sn_v);
            TEST_ASSERT_EQUAL_DOUBLE(0.0, p.height_nm);
        }
    }
}

void test_scan_line_lateral_signal_changes_sign_across_a_particle()
{
    // Across the lever, over a 50 nm particle dilated by the tip: climbing its
    // near side the substrate's force opposes the motion more (S_l below the
    // flat friction value); going down the far side, steeper (up to 70 deg)
    // than the friction angle (5.7 deg), it pushes the tip on: S_l > 0. The
    // line is deterministic (same scene, same values) and antisymmetric about
    // the flat friction offset only where friction is symmetric, so only signs
    // are asserted.
    const afm::Scene s = scene_from_text(with(with(kScan, "SCAN", "180"), "EFFECTS", "adhesion, tip_convolution"));
    const World a(s), b(s);
    const double flat = a.scan_point(-500, 0).sl_v;
    TEST_ASSERT_TRUE(flat < 0);
    double lo = 0, hi = 0, x_lo = 0, x_hi = 0;
    for (int i = 0; i <= 400; ++i) {
        const double x = -100 + 0.5 * i;
        const afm::sim::ScanPoint p = a.scan_point(x, 0), q = b.scan_point(x, 0);
        TEST_ASSERT_EQUAL_DOUBLE(p.sl_v, q.sl_v);
        TEST_ASSERT_EQUAL_DOUBLE(p.sn_v, q.sn_v);
        TEST_ASSERT_EQUAL_DOUBLE(a.image_height(x, 0), p.height_nm);
        if (p.sl_v < lo) lo = p.sl_v, x_lo = x;
        if (p.sl_v > hi) hi = p.sl_v, x_hi = x;
    }
    std::printf("flat S_l %.6f V; uphill min %.6f V at x = %.1f nm, downhill max %.6f V at x = %.1f nm\n", flat, lo, x_lo, hi, x_hi);
    TEST_ASSERT_TRUE(lo < flat && x_lo < 0);   // uphill: more against the motion
    TEST_ASSERT_TRUE(hi > 0 && x_hi > 0);      // downhill: the sign flips
    // On top the imaged surface is level again (its height is exact to about
    // 1e-12 nm, the slope from differences over 0.01 nm to about 1e-10).
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, flat, a.scan_point(0, 0).sl_v);
}

void test_rough_surface_has_its_rms_and_correlation_length()
{
    // One realization of K = 256 cosines, sampled on a 400 x 400 grid at
    // corr / 4 (100 corr on a side). Its rms is within 10% of
    // roughness_rms_nm, and its autocorrelation at lag corr (along x and y,
    // averaged) within 0.05 of 1/e = 0.368 (measured over seeds 1..8: within
    // 0.02; stratified radii keep one realization near the ensemble).
    for (const char *seed : {"1", "7", "12345"}) {
        const double rms = 2.0, corr = 40.0;
        const afm::Scene s = scene_from_text(with(with(with(kRough, "SEED", seed), "RMS", "2.0"), "CORR", "40.0"));
        const World w(s);
        const int n = 400, lag = 4;
        const double d = corr / lag;
        std::vector<double> z((n + lag) * (n + lag));
        for (int j = 0; j < n + lag; ++j)
            for (int i = 0; i < n + lag; ++i) z[j * (n + lag) + i] = w.image_height(-2000 + i * d, -2000 + j * d);
        double mean = 0, var = 0, cx = 0, cy = 0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) mean += z[j * (n + lag) + i];
        mean /= n * n;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double v = z[j * (n + lag) + i] - mean;
                var += v * v;
                cx += v * (z[j * (n + lag) + i + lag] - mean);
                cy += v * (z[(j + lag) * (n + lag) + i] - mean);
            }
        const double rho = 0.5 * (cx + cy) / var;
        std::printf("seed %s: rms %.4f nm (%.1f), autocorrelation at %.0f nm %.4f (1/e %.4f)\n", seed, std::sqrt(var / (n * n)), rms,
                    corr, rho, std::exp(-1.0));
        TEST_ASSERT_DOUBLE_WITHIN(0.1 * rms, rms, std::sqrt(var / (n * n)));
        TEST_ASSERT_DOUBLE_WITHIN(0.05, std::exp(-1.0), rho);
    }
}

void test_roughness_is_seeded_and_felt_by_the_mechanics()
{
    // Same seed, same surface; another seed, another. The piezo's z follows
    // it (the surface under the apex less the set point's deflection, 1e-9 nm).
    const std::string t = with(with(kRough, "RMS", "2.0"), "CORR", "40.0");
    const World a(scene_from_text(with(t, "SEED", "3"))), b(scene_from_text(with(t, "SEED", "3")));
    const World c(scene_from_text(with(t, "SEED", "4")));
    TEST_ASSERT_EQUAL_DOUBLE(a.image_height(123.4, -56.7), b.image_height(123.4, -56.7));
    TEST_ASSERT_TRUE(a.image_height(123.4, -56.7) != c.image_height(123.4, -56.7));
    World w(scene_from_text(with(t, "SEED", "3")));
    w.command(Eigen::Vector2d(200, 100), 5, true);
    afm::sim::Sample smp{};
    for (int i = 0; i < 1000; ++i) smp = w.step();
    const double defl = 5 / w.lever().spring;
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, w.image_height(w.apex().x(), w.apex().y()) - defl, smp.piezo_nm.z());
    TEST_ASSERT_TRUE(std::fabs(w.image_height(200, 100)) > 1e-6);   // rough, not flat
}

void test_roughness_keys_refused_negative_or_nan_with_the_key_named()
{
    const struct { int line; const char *rms, *corr, *key, *value; } rows[] = {
        {__LINE__, "-1", "40", "sample.roughness_rms_nm", "'-1'"},
        {__LINE__, ".nan", "40", "sample.roughness_rms_nm", "'.nan'"},
        {__LINE__, "1", "0", "sample.roughness_corr_nm", "'0'"},
        {__LINE__, "1", "-5", "sample.roughness_corr_nm", "'-5'"},
        {__LINE__, "1", ".nan", "sample.roughness_corr_nm", "'.nan'"},
    };
    for (const auto &r : rows) {
        const std::string msg = scene_error(with(with(with(kRough, "SEED", "1"), "RMS", r.rms), "CORR", r.corr));
        char where[64];
        std::snprintf(where, sizeof where, "row at line %d: %s", r.line, msg.c_str());
        TEST_ASSERT_TRUE_MESSAGE(msg.find(r.key) != std::string::npos, where);
        TEST_ASSERT_TRUE_MESSAGE(msg.find(r.value) != std::string::npos, where);
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_friction_loop_slopes_on_a_tilted_plane_match_eq_16_17);
    RUN_TEST(test_lithography_cuts_a_v_trench_seen_by_later_scans);
    RUN_TEST(test_wire_pushed_into_a_trench_sinks_into_it_and_is_held);
    RUN_TEST(test_lithography_is_refused_off_polycarbonate);
    RUN_TEST(test_scan_line_on_tilted_glass_reads_what_the_tip_sliding_there_reads);
    RUN_TEST(test_scan_line_on_flat_glass_reads_friction_and_the_set_point);
    RUN_TEST(test_scan_line_lateral_signal_changes_sign_across_a_particle);
    RUN_TEST(test_rough_surface_has_its_rms_and_correlation_length);
    RUN_TEST(test_roughness_is_seeded_and_felt_by_the_mechanics);
    RUN_TEST(test_roughness_keys_refused_negative_or_nan_with_the_key_named);
    return UNITY_END();
}
