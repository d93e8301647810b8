// Scan artefacts (sim_afm/scan_artefacts.hpp, effect scan_artefacts) against
// their laws: the bow's sag at the field's edge, the line offsets' rms, the
// servo's first-order lag behind an edge; scans only, never the truth.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "../scene_text.hpp"
#include "world.hpp"

using afm::sim::ScanPoint;
using afm::sim::World;

namespace {

const char *kScene = R"(name: artefacts
seed: 11
duration_s: 1
sample_rate_hz: 10000
block_hz: 1000
effects: [EFFECTS]
sample:
  substrate: glass
  field_nm: 4000
  field_center_nm: [1000, -500]
afm:
  scan_artefacts: {line_offset_rms_nm: OFFSET, servo_lag_nm: LAG, bow_sag_nm: SAG}
objects:
  landmarks:
    - {id: 1, x_nm: 1500, y_nm: -500, side_nm: 1000, height_nm: 40}
operator:
  load_nN: 5
  path_nm: [[1000, -1500]]
)";

afm::Scene scene(const std::string &effects, double offset, double lag, double sag)
{
    std::string t = with(kScene, "EFFECTS", effects);
    t = with(t, "OFFSET", std::to_string(offset));
    t = with(t, "LAG", std::to_string(lag));
    return scene_from_text(with(t, "SAG", std::to_string(sag)));
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_bow_sags_its_level_at_the_field_edge()
{
    // A line through the field's centre (y = cy) on the bare glass left of
    // the pillar: -sag ((x - cx) / (f / 2))^2, so -sag at the edge x = cx - f/2.
    World w(scene("scan_artefacts", 0, 0, 3));
    const int n = 21;
    std::vector<ScanPoint> p(n);
    w.scan_line(-1000, 50, n, -500, -2500, p.data());   // x -1000 .. 0 (cx - f/2 .. cx - f/4)
    for (int i = 0; i < n; ++i) {
        const double u = (-1000 + 50.0 * i - 1000) / 2000;
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, -3 * u * u, p[i].height_nm);
    }
    std::printf("scan_artefacts: bow at the field's edge %.4f nm (sag 3 nm), at x = cx - f/4 %.4f nm\n", p[0].height_nm,
                p[n - 1].height_nm);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, -3.0, p[0].height_nm);
}

void test_line_offsets_have_their_rms()
{
    // 4000 lines on bare glass: each line's heights are one draw. rms
    // within 5 % (the estimate's standard error, 1 / sqrt(2 * 4000) = 1.1 %,
    // times 4.4), mean within 4 standard errors (0.5 / sqrt(4000) each).
    World w(scene("scan_artefacts", 0.5, 0, 0));
    const int lines = 4000, n = 4;
    std::vector<ScanPoint> p(n);
    double sum = 0, sum2 = 0;
    for (int j = 0; j < lines; ++j) {
        w.scan_line(-900, 10, n, -2000, -2000, p.data());
        for (int i = 1; i < n; ++i) TEST_ASSERT_EQUAL_DOUBLE(p[0].height_nm, p[i].height_nm);   // one offset a line
        sum += p[0].height_nm;
        sum2 += p[0].height_nm * p[0].height_nm;
    }
    const double mean = sum / lines, rms = std::sqrt(sum2 / lines);
    std::printf("scan_artefacts: line offsets over %d lines: rms %.4f nm (level 0.5), mean %.4f nm\n", lines, rms, mean);
    TEST_ASSERT_DOUBLE_WITHIN(0.025, 0.5, rms);
    TEST_ASSERT_DOUBLE_WITHIN(4 * 0.5 / std::sqrt(lines), 0.0, mean);
}

void test_servo_lags_an_edge_by_its_length()
{
    // The pillar's left edge at x = 1000 (the points at 802 + 5 i: none on
    // the edge itself, where the tip jams and S_n saturates): the line's
    // height climbs as H (1 - exp(-(k + 1) dx / lag)) at the k-th point past
    // it (the recursion's exact points), and S_n shows what z has not
    // followed, (H - height) / K_n over the plain S_n.
    const double lag = 30, H = 40, dx = 5, x0 = 802, first_on = 1002;
    World w(scene("scan_artefacts", 0, lag, 0)), plain(scene("", 0, lag, 0));
    const int n = 80;
    std::vector<ScanPoint> p(n), q(n);
    w.scan_line(x0, dx, n, -500, -500, p.data());
    plain.scan_line(x0, dx, n, -500, -500, q.data());
    const double volts_per_nm = 1.0 / w.lever().deflection;
    for (int i = 0; i < n; ++i) {
        const double x = x0 + dx * i;
        const double want = x < first_on ? 0.0 : H * (1 - std::exp(-(x - first_on + dx) / lag));
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, want, p[i].height_nm);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, q[i].sn_v + (q[i].height_nm - p[i].height_nm) * volts_per_nm, p[i].sn_v);
    }
    const int at = static_cast<int>((first_on - x0) / dx) + static_cast<int>(lag / dx) - 1;   // one lag past the edge
    std::printf("scan_artefacts: servo lag %.0f nm: %.3f of the %.0f nm edge one lag past it (1 - 1/e = 0.632)\n", lag,
                p[at].height_nm / H, H);
}

void test_without_the_effect_a_scan_line_is_its_points()
{
    World w(scene("", 0.5, 30, 3));
    const int n = 50;
    std::vector<ScanPoint> p(n);
    w.scan_line(700, 13, n, -500, -1500, p.data());
    for (int i = 0; i < n; ++i) {
        const ScanPoint s = w.scan_point(700 + 13.0 * i, -500);
        TEST_ASSERT_EQUAL_DOUBLE(s.height_nm, p[i].height_nm);
        TEST_ASSERT_EQUAL_DOUBLE(s.sn_v, p[i].sn_v);
        TEST_ASSERT_EQUAL_DOUBLE(s.sl_v, p[i].sl_v);
    }
}

void test_the_truth_keeps_no_artefact()
{
    World a(scene("scan_artefacts", 0.5, 30, 3)), b(scene("", 0, 0, 0));
    for (double x : {-900.0, 1000.0, 1200.0, 2900.0})
        TEST_ASSERT_EQUAL_DOUBLE(b.image_height(x, -400), a.image_height(x, -400));
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_bow_sags_its_level_at_the_field_edge);
    RUN_TEST(test_line_offsets_have_their_rms);
    RUN_TEST(test_servo_lags_an_edge_by_its_length);
    RUN_TEST(test_without_the_effect_a_scan_line_is_its_points);
    RUN_TEST(test_the_truth_keeps_no_artefact);
    return UNITY_END();
}
