// Unity tests of the tip's dilation over a lattice (sim_afm/dilation.hpp)
// against the closed forms where they are exact (a sphere, a cylinder, a
// pillar alone on a flat: TipShape), a groove the tip cut, the edge cases
// (a tip larger than the field, a sharp cone, a one-pixel field), and the
// world's scans through it.
//
// The stated error: a node's image lies within 0.3 of a lattice step's
// height on the cone's flank, cot(gamma) h, of the closed form, and never
// above it (the maximum is taken over the lattice's offsets; 1e-6 nm, the
// closed form's own tolerance), for a sphere or a cylinder at least 2 h in
// radius (measured: 0.26 at most, a 30 nm apex on a 10 deg cone over a
// 50 nm sphere at 5 nm; 0.17 with the paper's 10 nm and 20 deg). A scan's
// pixel is split into 1 to 4 lattice steps a side (at most 5 nm each with
// a 10 nm apex), so on the demo's 19.5 nm pixels that is 0.08 of a pixel's
// height step.
// Between nodes the image is bilinear: a scan's point there is bounded by a
// pixel's step, cot(gamma) dx (measured: 0.08 of it).
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "../scene_text.hpp"
#include "dilation.hpp"
#include "scene.hpp"
#include "world.hpp"

using afm::sim::DilatedField;
using afm::sim::TipShape;

namespace {

constexpr double kNone = -std::numeric_limits<double>::infinity();
constexpr double kDeg = M_PI / 180.0;
constexpr double kNodeBound = 0.3;    // of cot(gamma) h, at a node

// A map of one sphere (or, with cylinder, a cylinder along y) of radius r
// centred at (cx, cy) on a flat at 0, no groove.
afm::sim::MapFill ball(double cx, double cy, double r, bool cylinder = false)
{
    return [=](double x, double y, int n, double h, double *b, double *g, double *o) {
        for (int i = 0; i < n; ++i) {
            const double dx = x + i * h - cx, dy = cylinder ? 0.0 : y - cy, w2 = dx * dx + dy * dy;
            b[i] = 0;
            g[i] = 0;
            o[i] = w2 < r * r ? r + std::sqrt(r * r - w2) : kNone;
        }
    };
}

// The most a field's nodes within `span` of (cx, cy) fall below (positive)
// or rise above (negative) the closed form, in units of cot(gamma) h.
struct Err { double below = 0, above = 0; };
Err node_error(const DilatedField &f, const TipShape &tip, double cx, double cy, double r, double span, bool cylinder = false)
{
    Err e;
    const double step = f.pitch() / std::tan(tip.half_angle_rad);
    const int64_t n = static_cast<int64_t>(span / f.pitch());
    const int64_t i0 = static_cast<int64_t>(std::floor((cx - f.x0()) / f.pitch())), j0 = static_cast<int64_t>(std::floor((cy - f.y0()) / f.pitch()));
    for (int64_t j = j0 - n; j <= j0 + n; j += cylinder ? n : 1)
        for (int64_t i = i0 - n; i <= i0 + n; ++i) {
            const double x = f.x0() + i * f.pitch(), y = f.y0() + j * f.pitch();
            const double want = tip.bump(cylinder ? std::fabs(x - cx) : std::hypot(x - cx, y - cy), r);
            const double got = f.node(i, j);
            e.below = std::max(e.below, (want - got) / step);
            e.above = std::max(e.above, (got - want) / step);
        }
    return e;
}

void check_ball(double rt, double gamma_deg, double r, double h, bool cylinder)
{
    const TipShape tip{rt, gamma_deg * kDeg};
    const double cx = 0.37 * h, cy = -0.21 * h;   // off the nodes
    const DilatedField f(tip, 0, 0, h, 2 * r, 0, ball(cx, cy, r, cylinder));
    const Err e = node_error(f, tip, cx, cy, r, r + tip.reach(2 * r) + 3 * h, cylinder);
    std::printf("%s r %.0f nm, apex %.1f nm, %.0f deg, pitch %.2f nm: nodes below the closed form by %.4f, above by %.2e (of cot g h = %.2f nm)\n",
                cylinder ? "cylinder" : "sphere", r, rt, gamma_deg, h, e.below, e.above, h / std::tan(tip.half_angle_rad));
    TEST_ASSERT_TRUE(e.below <= kNodeBound);
    TEST_ASSERT_TRUE(e.above * h / std::tan(tip.half_angle_rad) <= 1e-6);   // a lattice's maximum never exceeds the continuous one
}

void test_a_sphere_alone_matches_the_closed_form_within_three_tenths_of_a_step()
{
    check_ball(10, 20, 50, 2.5, false);
    check_ball(10, 20, 50, 5.0, false);
    check_ball(10, 35, 25, 5.0, false);
    check_ball(30, 10, 50, 5.0, false);
}

void test_a_cylinder_alone_matches_the_closed_form_within_three_tenths_of_a_step()
{
    check_ball(10, 20, 50, 5.0, true);
    check_ball(10, 20, 100, 5.0, true);
}

void test_a_pillar_images_a_flat_top_and_the_tip_profile_beside_it()
{
    const TipShape tip{10, 20 * kDeg};
    const double side = 200, top = 150, h = 5;
    const DilatedField f(tip, 0, 0, h, top, 0, [&](double x, double y, int n, double hh, double *b, double *g, double *o) {
        for (int i = 0; i < n; ++i) {
            b[i] = g[i] = 0;
            o[i] = std::fabs(x + i * hh) <= side / 2 && std::fabs(y) <= side / 2 ? top : kNone;
        }
    });
    for (int i = 0; i <= 40; ++i) {   // along y = 0: the edge at x = 100, a node
        const double x = i * h, d = std::max(0.0, x - side / 2);
        const double want = std::max(0.0, tip.pillar(d, top));
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, want, std::max(0.0, f.node(i, 0)));   // on the nodes the lattice holds the edge exactly
    }
}

void test_a_groove_the_tip_cut_stays_unfilled()
{
    // A V of depth D and walls at the cone's angle (lithography's): imaged
    // at its depth everywhere, as a dilation of the tip's own trace. Put in
    // the substrate instead, the apex would lift its whole width by
    // R (1 / sin g - 1): the sharp V is not the tip's trace near its bottom.
    const TipShape tip{10, 20 * kDeg};
    const double D = 60, h = 2.5;
    auto v = [&](double x) { return std::max(0.0, D - std::fabs(x) / std::tan(tip.half_angle_rad)); };
    const DilatedField cut(tip, 0, 0, h, 0, 0, [&](double x, double, int n, double hh, double *b, double *g, double *o) {
        for (int i = 0; i < n; ++i) b[i] = 0, g[i] = v(x + i * hh), o[i] = kNone;
    });
    const DilatedField filled(tip, 0, 0, h, D, 0, [&](double x, double, int n, double hh, double *b, double *g, double *o) {
        for (int i = 0; i < n; ++i) b[i] = -v(x + i * hh), g[i] = 0, o[i] = kNone;
    });
    for (int i = -12; i <= 12; ++i) TEST_ASSERT_DOUBLE_WITHIN(1e-12, -v(i * h), cut.node(i, 3));
    const double lift = tip.radius_nm * (1 / std::sin(tip.half_angle_rad) - 1);
    std::printf("the V in the substrate: its bottom lifted by %.2f nm (R (1 / sin g - 1) = %.2f nm)\n", filled.node(0, 3) + D, lift);
    TEST_ASSERT_DOUBLE_WITHIN(0.1 * h / std::tan(tip.half_angle_rad), lift, filled.node(0, 3) + D);
}

void test_a_tip_larger_than_the_field_and_a_sharp_cone()
{
    // A 1 um apex over a 5 nm sphere: the apex alone touches it, out to
    // 141 nm from it (the footprint: 71 steps). A sharp cone (R = 0).
    check_ball(1000, 20, 5, 2.0, false);
    check_ball(0, 20, 50, 5.0, false);
    check_ball(0, 20, 50, 5.0, true);
}

// A World with one particle and tip_convolution, the field and pixels given.
afm::Scene one_particle(double field_nm, int image_px, const char *effects = "tip_convolution")
{
    std::string t = std::string(R"(name: unit
seed: 3
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [)") + effects + R"(]
sample:
  substrate: glass
  field_nm: FIELD
  tip_substrate: {mu: 0.1, adhesion_nN: 1.0}
  particle_substrate: {mu: 0.3, adhesion_nN: 3.0}
objects:
  particles:
    - {id: 1, x_nm: 0, y_nm: 0, radius_nm: 50}
operator:
  load_nN: 5
  path_nm: [[0, -300]]
outputs:
  image_px: PX
)";
    return scene_from_text(with(with(t, "FIELD", std::to_string(field_nm)), "PX", std::to_string(image_px)));
}

void test_a_world_scan_matches_the_closed_form_between_nodes_too()
{
    // scan_line through a 50 nm particle: at every point (on nodes and
    // between them: a scan's pixels are subdivided) within the stated bound.
    const afm::Scene s = one_particle(2000, 256);
    const afm::sim::World w(s);
    const TipShape tip{s.probe.tip_radius_nm, s.probe.tip_half_angle_deg * kDeg};
    const int n = 101;
    const double dx = 2.1, step = dx / std::tan(tip.half_angle_rad);
    std::vector<afm::sim::ScanPoint> line(n);
    double worst = 0;
    for (double y : {0.0, 13.3, -41.0}) {
        w.scan_line(-105, dx, n, y, y, line.data());
        for (int i = 0; i < n; ++i) {
            const double x = -105 + i * dx;
            worst = std::max(worst, std::fabs(line[i].height_nm - tip.bump(std::hypot(x, y), 50)) / step);
            TEST_ASSERT_DOUBLE_WITHIN(1.1 * step, tip.bump(std::hypot(x, y), 50), line[i].height_nm);
        }
    }
    std::printf("a scan at 2.1 nm pixels: within %.3f of cot g dx of the closed form\n", worst);
    TEST_ASSERT_TRUE(worst <= 1.1);
}

void test_a_one_pixel_field_images_its_point()
{
    // A scan of one pixel 100 nm wide over the particle's top: the lattice
    // (25 nm steps: a pixel is split 4 x 4 at most) has that pixel's centre
    // as a node; on the flank, within 0.1 of the pixel's height step.
    const afm::Scene s = one_particle(2000, 256);
    const afm::sim::World w(s);
    afm::sim::ScanPoint p;
    w.scan_line(0, 100, 1, 0, 0, &p);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 100.0, p.height_nm);
    w.scan_line(60, 100, 1, 0, 0, &p);
    const TipShape tip{s.probe.tip_radius_nm, s.probe.tip_half_angle_deg * kDeg};
    TEST_ASSERT_DOUBLE_WITHIN(0.1 * 100 / std::tan(tip.half_angle_rad), tip.bump(60, 50), p.height_nm);
}

void test_a_rough_substrate_is_dilated_too()
{
    // Roughness narrower than the apex (3 nm rms over 4 nm): the tip cannot
    // reach the valleys, so the image stands above the surface there and
    // never below it at the lattice's nodes (field 2000 nm at 400 px: 5 nm
    // pixels, the lattice's step). The whole map is dilated, not the
    // objects alone.
    const std::string rough = "tip_convolution, roughness";
    afm::Scene s = one_particle(2000, 400, rough.c_str()), bare = one_particle(2000, 400, "roughness");
    s.roughness_rms_nm = bare.roughness_rms_nm = 3;
    s.roughness_corr_nm = bare.roughness_corr_nm = 4;
    const afm::sim::World w(s), v(bare);
    double lift = 0, below = 0;
    for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) {
            const double x = 300 + 2.5 + 5 * i, y = -600 + 2.5 + 5 * j;   // nodes, clear of the particle
            lift = std::max(lift, w.image_height(x, y) - v.image_height(x, y));
            below = std::max(below, v.image_height(x, y) - w.image_height(x, y));
        }
    std::printf("rough substrate: the image at most %.3f nm above the surface, %.1e below\n", lift, below);
    TEST_ASSERT_TRUE(below <= 1e-9);
    TEST_ASSERT_TRUE(lift > 1.0);
}

void test_a_long_scan_keeps_its_tiles_bounded()
{
    // 80 rows of 64 tiles (5,120, past kKeepTiles): the tiles well below the
    // row asked for are dropped, and a node asked for again is the same.
    const TipShape tip{10, 20 * kDeg};
    const DilatedField f(tip, 0, 0, 5, 100, 0, ball(1000, 300, 50));
    const double first = f.node(200, 60);
    std::size_t most = 0;
    for (int64_t tj = 0; tj < 80; ++tj)
        for (int64_t ti = 0; ti < 64; ++ti) {
            f.node(ti * DilatedField::kTile, tj * DilatedField::kTile);
            most = std::max(most, f.tiles());
        }
    TEST_ASSERT_TRUE(most <= DilatedField::kKeepTiles + 64);
    TEST_ASSERT_EQUAL_DOUBLE(first, f.node(200, 60));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, tip.bump(std::hypot(200 * 5 - 1000, 60 * 5 - 300), 50), first);
}

void test_a_slope_steeper_than_the_cone_takes_the_largest_footprint()
{
    // tilted 45 deg under an 80 deg cone (the scene's limits): the footprint
    // has no bound from the slope, so it is the largest, not refused.
    const TipShape tip{10, 80 * kDeg};
    const DilatedField f(tip, 0, 0, 5, 0, 1.0, [](double x, double y, int n, double h, double *b, double *g, double *o) {
        for (int i = 0; i < n; ++i) b[i] = -y, g[i] = 0, o[i] = kNone;
        (void)x, (void)h;
    });
    TEST_ASSERT_EQUAL_INT(DilatedField::kMaxReach, f.footprint_nodes());
    TEST_ASSERT_TRUE(std::isfinite(f.node(3, 4)));
}

void test_rough_rows_match_the_rough_surface()
{
    // add_row steps each wave's phase: the same heights as height() to 1e-9 nm over 1000 nodes.
    const afm::sim::RoughSurface r(2.0, 40.0, 11);
    std::vector<double> row(1000, 0.0);
    r.add_row(-1234.5, 77.7, 1000, 2.5, row.data());
    for (int i = 0; i < 1000; i += 37) TEST_ASSERT_DOUBLE_WITHIN(1e-9, r.height(Eigen::Vector2d(-1234.5 + i * 2.5, 77.7)), row[i]);
}

}  // namespace

void setUp() {}
void tearDown() {}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_a_sphere_alone_matches_the_closed_form_within_three_tenths_of_a_step);
    RUN_TEST(test_a_cylinder_alone_matches_the_closed_form_within_three_tenths_of_a_step);
    RUN_TEST(test_a_pillar_images_a_flat_top_and_the_tip_profile_beside_it);
    RUN_TEST(test_a_groove_the_tip_cut_stays_unfilled);
    RUN_TEST(test_a_tip_larger_than_the_field_and_a_sharp_cone);
    RUN_TEST(test_a_world_scan_matches_the_closed_form_between_nodes_too);
    RUN_TEST(test_a_one_pixel_field_images_its_point);
    RUN_TEST(test_a_rough_substrate_is_dilated_too);
    RUN_TEST(test_a_long_scan_keeps_its_tiles_bounded);
    RUN_TEST(test_a_slope_steeper_than_the_cone_takes_the_largest_footprint);
    RUN_TEST(test_rough_rows_match_the_rough_surface);
    return UNITY_END();
}
