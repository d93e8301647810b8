// Unity tests of the display's wires and lithography trenches
// (host/display, fidelity, profile): the closed forms against brute
// force dilations, a known wire's footprint and height, a trench's depth
// where the tip fits and where it does not, local update == full redraw with
// moving wires and growing trenches, the colour scale below 0, the
// fidelity check catching a misplaced wire, and a rod seated in a groove
// found along its length.
#include <unity.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "display.hpp"
#include "fidelity.hpp"
#include "profile.hpp"

namespace {
const afm::Field kField{-500, -500, 1000, 200};     // 5 nm pixels
const afm::TipShape kTip{10, 20};
constexpr double kDeg = M_PI / 180;

// Tip surface above its apex at horizontal distance u: spherical apex of
// radius r_t tangent to a cone of half angle gamma (r_t 0: a sharp cone).
double tip_surface_nm(double u, const afm::TipShape &t)
{
    const double g = t.half_angle_deg * kDeg, u0 = t.radius_nm * std::cos(g);
    if (u <= u0) return t.radius_nm - std::sqrt(t.radius_nm * t.radius_nm - u * u);
    return t.radius_nm - t.radius_nm * std::sin(g) + (u - u0) / std::tan(g);
}

// Brute-force dilation: the apex height at which the tip at q first touches a
// capsule of radius R whose axis runs from (0, 0) to (L, 0) at height R, by
// sampling the capsule's upper surface.
double capsule_image_brute_nm(double R, double L, double qx, double qy, const afm::TipShape &t)
{
    double best = 0;
    const int n = 400;
    for (int i = 0; i <= n; ++i) {
        const double x = -R + (L + 2 * R) * i / n;
        for (int j = 0; j <= n; ++j) {
            const double y = -R + 2 * R * j / n;
            const double dx = x < 0 ? x : (x > L ? x - L : 0.0);
            const double r2 = R * R - dx * dx - y * y;
            if (r2 < 0) continue;
            best = std::max(best, R + std::sqrt(r2) - tip_surface_nm(std::hypot(qx - x, qy - y), t));
        }
    }
    return best;
}

double pixel_at(const afm::Display &d, double x, double y)
{
    const cv::Point2d c = kField.to_px(x, y);
    return d.height().at<float>(cvRound(c.y), cvRound(c.x));
}

double max_abs_diff(const cv::Mat &a, const cv::Mat &b)
{
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    double worst;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    return worst;
}

afm::DisplayWire rod(int id, double cx, double cy, double L, double psi_deg, double d)
{
    const double c = std::cos(psi_deg * kDeg) * L / 2, s = std::sin(psi_deg * kDeg) * L / 2;
    return {id, d, {{cx - c, cy - s}, {cx + c, cy + s}}};
}
}  // namespace

void setUp() {}
void tearDown() {}

void test_wire_profile_top_is_d_under_any_tip()
{
    for (const afm::TipShape &t : {afm::TipShape{}, afm::TipShape{10, 20}, afm::TipShape{80, 10}, afm::TipShape{2, 35}})
        for (double R : {10.0, 50.0, 150.0}) TEST_ASSERT_DOUBLE_WITHIN(1e-12, 2 * R, afm::wire_profile_nm(R, 0, t));
}

void test_wire_profile_matches_a_brute_force_dilation_across_and_beyond_the_end()
{
    // Rows: tip, R, L, query point (axis along x from 0 to L).
    struct Row { int line; afm::TipShape tip; double R, L, qx, qy; } rows[] = {
        {__LINE__, {10, 20}, 50, 300, 150, 0},   {__LINE__, {10, 20}, 50, 300, 150, 40},
        {__LINE__, {10, 20}, 50, 300, 150, 70},  {__LINE__, {10, 20}, 50, 300, -30, 20},
        {__LINE__, {10, 20}, 50, 300, 340, -35}, {__LINE__, {80, 10}, 10, 100, 50, 30},
        {__LINE__, {2, 35}, 30, 200, 230, 0},
    };
    for (const Row &r : rows) {
        const double dx = r.qx < 0 ? r.qx : (r.qx > r.L ? r.qx - r.L : 0.0);
        const double closed = afm::wire_profile_nm(r.R, std::hypot(dx, r.qy), r.tip);
        const double brute = capsule_image_brute_nm(r.R, r.L, r.qx, r.qy, r.tip);
        char msg[64];
        std::snprintf(msg, sizeof msg, "row at line %d", r.line);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(0.3, brute, closed, msg);   // the brute force samples the surface every 0.25-1 nm
    }
}

void test_groove_profile_matches_a_sharp_cone_descending_into_the_v()
{
    // A sharp cone (r_t = 0): the apex height at u is the highest of
    // surface(v) - |u - v| cot gamma over the groove's surface.
    const afm::TipShape cone{0, 20};
    for (double half_width : {5.0, 14.56, 40.0}) {   // narrower than, as wide as, wider than the cone at 40 nm
        const double depth = 40;
        for (double u = 0; u < half_width + 5; u += 1.7) {
            double brute = -1e300;
            for (int i = -4000; i <= 4000; ++i) {
                const double v = i * 0.025;
                const double s = std::fabs(v) < half_width ? -depth * (1 - std::fabs(v) / half_width) : 0.0;
                brute = std::max(brute, s - std::fabs(u - v) / std::tan(20 * kDeg));
            }
            TEST_ASSERT_DOUBLE_WITHIN(0.1, -brute, afm::groove_profile_nm(depth, half_width, u, cone));
        }
    }
}

void test_known_wire_renders_to_its_footprint_and_height()
{
    afm::Display d(kField, kTip);
    const afm::DisplayWire w{1, 60, {{-197.5, 2.5}, {202.5, 2.5}}};   // axis on pixel centres
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{{}, {w}, {}});
    const double foot = afm::wire_footprint_nm(30, kTip);
    int inside = 0, outside_nonzero = 0;
    for (int r = 0; r < kField.px; ++r)
        for (int c = 0; c < kField.px; ++c) {
            const double x = kField.x_of(c), y = kField.y_of(r);
            const double dx = x < -197.5 ? x + 197.5 : (x > 202.5 ? x - 202.5 : 0.0);
            const double rho = std::hypot(dx, y - 2.5);
            const float h = d.height().at<float>(r, c);
            if (rho < foot - 1e-6) {
                ++inside;
                TEST_ASSERT_TRUE(h > 0);
                TEST_ASSERT_FLOAT_WITHIN(1e-4f, static_cast<float>(afm::wire_profile_nm(30, rho, kTip)), h);
            } else if (h != 0.0f) {
                ++outside_nonzero;
            }
        }
    TEST_ASSERT_EQUAL_INT(0, outside_nonzero);
    // A band 2 foot wide and 400 nm long with two half-disc caps, in 25 nm^2
    // pixels, to within the pixels along its edge.
    const double area_px = (2 * foot * 400 + M_PI * foot * foot) / 25.0, edge_px = (2 * 400 + 2 * M_PI * foot) / 5.0;
    TEST_ASSERT_INT_WITHIN(static_cast<int>(edge_px / 2), static_cast<int>(area_px), inside);
    for (double x : {-197.5, 2.5, 202.5}) TEST_ASSERT_FLOAT_WITHIN(1e-4, 60.0, pixel_at(d, x, 2.5));   // d at the axis
    TEST_ASSERT_TRUE(pixel_at(d, 2.5, 2.5 + foot + 5) == 0.0);
}

void test_trench_renders_to_its_depth_where_the_tip_fits_and_shallower_where_not()
{
    const double depth = 40, fits = 2 * depth * std::tan(20 * kDeg);
    const afm::DisplayTrench wide{1, {{-300, -97.5, depth, fits}, {300, -97.5, depth, fits}}};
    const afm::DisplayTrench narrow{2, {{-300, 102.5, depth, 10}, {300, 102.5, depth, 10}}};
    afm::Display d(kField, kTip), ideal(kField, afm::TipShape{});
    const afm::DisplayModel m{{}, {}, {wide, narrow}};
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), m);
    ideal.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), m);
    TEST_ASSERT_FLOAT_WITHIN(1e-4, -depth, pixel_at(d, 2.5, -97.5));
    // The cone stops on the rims of the 10 nm groove: 5 cot(20 deg) = 13.7 nm.
    TEST_ASSERT_FLOAT_WITHIN(1e-4, -5 / std::tan(20 * kDeg), pixel_at(d, 2.5, 102.5));
    TEST_ASSERT_FLOAT_WITHIN(1e-4, -depth, pixel_at(ideal, 2.5, 102.5));
    // V walls: half the depth half way out; the substrate beyond the rim.
    TEST_ASSERT_FLOAT_WITHIN(1e-3, -depth * (1 - 5 / (fits / 2)), pixel_at(d, 2.5, -92.5));
    TEST_ASSERT_EQUAL_FLOAT(0.0f, pixel_at(d, 2.5, -97.5 + fits / 2 + 5));
    TEST_ASSERT_EQUAL_FLOAT(0.0f, pixel_at(d, 320, -97.5));
    // The colour scale reaches below the trench, and its bottom is dark.
    TEST_ASSERT_TRUE(d.z_bottom() <= -depth);
    const cv::Point2d c = kField.to_px(2.5, -97.5), s = kField.to_px(2.5, 0);
    const cv::Mat colour = d.frame(afm::Overlay{});
    const cv::Vec3b bottom = colour.at<cv::Vec3b>(cvRound(c.y), cvRound(c.x)), flat = colour.at<cv::Vec3b>(cvRound(s.y), cvRound(s.x));
    TEST_ASSERT_TRUE(bottom[2] < flat[2]);
}

void test_colour_scale_widens_when_a_trench_appears()
{
    afm::Display d(kField, kTip);
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{{{1, 0, 0, 50}}, {}, {}});
    TEST_ASSERT_EQUAL_DOUBLE(0.0, d.z_bottom());
    TEST_ASSERT_TRUE(d.z_top() >= 100);
    d.update(afm::DisplayModel{{{1, 0, 0, 50}}, {}, {{1, {{-100, -200, 30, 21.8}, {100, -200, 30, 21.8}}}}});
    TEST_ASSERT_TRUE(d.z_bottom() <= -30);
}

void test_local_update_equals_full_redraw_with_moving_wires_and_growing_trenches()
{
    afm::DisplayModel m;
    m.particles = {{1, -300, 300, 40}, {2, 250, 250, 30}};
    m.wires = {rod(1, -100, 0, 400, 10, 60), {2, 40, {{-350, -300}, {-250, -280}, {-150, -300}, {-50, -320}, {50, -300}}}};
    m.trenches = {{1, {{100, -420, 30, 21.8}}}};
    cv::Mat scan(kField.px, kField.px, CV_32F);
    cv::randu(scan, -2.0, 2.0);   // a rough background: erasing and restoring show
    afm::Display a(kField, kTip), b(kField, kTip);
    a.start(scan, m);
    b.start(scan, m);
    for (int k = 0; k < 60; ++k) {
        // The rod pushed and turned, the chain bent, the trench cut further
        // (deeper each step), a second trench started half way, a particle moved.
        m.wires[0] = rod(1, -100 + 1.3 * k, 3.1 * k, 400, 10 + 0.7 * k, 60);
        m.wires[1].nodes_nm[2].y += 2.3;
        m.wires[1].nodes_nm[3].y += 1.1;
        m.trenches[0].points.push_back({100 + 6.0 * (k + 1), -420 + 1.0 * k, 30 + 0.3 * k, 2 * (30 + 0.3 * k) * std::tan(20 * kDeg)});
        if (k == 30) m.trenches.push_back({2, {{-400, 420, 20, 14.6}}});
        if (k > 30) m.trenches[1].points.push_back({-400 + 5.0 * (k - 30), 420, 20, 14.6});
        m.particles[k % 2].x_nm += 2.9;
        if (k == 45) m.wires.pop_back();   // a wire leaves the model
        const long touched = a.update(m);
        TEST_ASSERT_TRUE(touched < kField.px * kField.px / 2);   // local
        b.redraw(m);
    }
    TEST_ASSERT_EQUAL_DOUBLE(0.0, max_abs_diff(a.height(), b.height()));
    TEST_ASSERT_EQUAL_DOUBLE(a.z_bottom(), b.z_bottom());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, max_abs_diff(a.frame(afm::Overlay{}), b.frame(afm::Overlay{})));
    // The removed wire is gone: the background is back where it lay (away from the others).
    TEST_ASSERT_FLOAT_WITHIN(2.0f, 0.0f, static_cast<float>(pixel_at(a, -250, -280)));
}

void test_growing_trench_touches_only_its_new_end()
{
    afm::DisplayTrench t{1, {}};
    for (int i = 0; i < 100; ++i) t.points.push_back({-450 + 9.0 * i, -450 + 9.0 * i, 30, 21.8});
    afm::Display d(kField, kTip);
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{{}, {}, {t}});
    t.points.push_back({-450 + 900.0, -450 + 900.0, 30, 21.8});
    const long touched = d.update(afm::DisplayModel{{}, {}, {t}});
    TEST_ASSERT_TRUE(touched < 200);   // the last step's box, not the trench's 900 x 900 nm (180 x 180 px) box
}

void test_fidelity_passes_honest_and_catches_a_wire_misplaced_by_20nm()
{
    const afm::DisplayModel truth{{{1, 300, 300, 50}}, {rod(1, -50, -50, 600, 30, 100)}, {}};
    afm::Display scanner(kField, kTip);
    scanner.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{});
    scanner.redraw(truth);
    const cv::Mat scan = scanner.height().clone();

    afm::Display honest(kField, kTip);
    honest.start(scan, truth);
    afm::Fidelity f = afm::compare_with_scan(honest.height(), scan, kField, truth, kTip, 40);
    TEST_ASSERT_EQUAL_INT(2, static_cast<int>(f.objects.size()));
    TEST_ASSERT_EQUAL_STRING("wire", f.objects[1].kind.c_str());
    TEST_ASSERT_TRUE(f.objects[1].found);
    TEST_ASSERT_TRUE(f.max_position_error_nm < 0.01);
    TEST_ASSERT_DOUBLE_WITHIN(0.5, 30.0, f.objects[1].display_angle_deg);
    TEST_ASSERT_TRUE(f.rms_height_error_nm < 1e-6);

    // Misplaced across its axis by 20 nm.
    afm::DisplayModel wrong = truth;
    wrong.wires[0] = rod(1, -50 - 20 * std::sin(30 * kDeg), -50 + 20 * std::cos(30 * kDeg), 600, 30, 100);
    afm::Display misled(kField, kTip);
    misled.start(scan, truth);
    misled.update(wrong);
    f = afm::compare_with_scan(misled.height(), scan, kField, wrong, kTip, 40);
    std::printf("wire misplaced by 20 nm: centroid %.3f nm, angle %.3f deg, error %.3f nm, rms %.3f nm\n",
                f.objects[1].centroid_error_nm, f.objects[1].angle_error_deg, f.objects[1].error_nm, f.rms_height_error_nm);
    TEST_ASSERT_TRUE(f.objects[1].found);
    TEST_ASSERT_DOUBLE_WITHIN(1.0, 20.0, f.objects[1].centroid_error_nm);
    TEST_ASSERT_DOUBLE_WITHIN(0.2, 0.0, f.objects[1].angle_error_deg);
    TEST_ASSERT_TRUE(f.objects[0].error_nm < 0.01);
    TEST_ASSERT_TRUE(f.max_position_error_nm > 5.0);

    // Turned by 2 deg about its centre: the ends move by 300 sin(2 deg) = 10.5 nm.
    wrong.wires[0] = rod(1, -50, -50, 600, 32, 100);
    afm::Display turned(kField, kTip);
    turned.start(scan, truth);
    turned.update(wrong);
    f = afm::compare_with_scan(turned.height(), scan, kField, wrong, kTip, 40);
    std::printf("wire turned by 2 deg: centroid %.3f nm, angle %.3f deg, error %.3f nm\n", f.objects[1].centroid_error_nm,
                f.objects[1].angle_error_deg, f.objects[1].error_nm);
    TEST_ASSERT_DOUBLE_WITHIN(0.2, -2.0, f.objects[1].angle_error_deg);
    TEST_ASSERT_DOUBLE_WITHIN(1.5, 300 * std::sin(2 * kDeg), f.objects[1].error_nm);
    TEST_ASSERT_DOUBLE_WITHIN(0.2, 2.0, f.max_angle_error_deg);
}

void test_fidelity_rms_counts_a_trench_the_display_lacks()
{
    const afm::DisplayTrench t{1, {{-300, 0, 40, 29.1}, {300, 0, 40, 29.1}}};
    afm::Display scanner(kField, kTip);
    scanner.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{{}, {}, {t}});
    const cv::Mat scan = scanner.height().clone();
    afm::Display honest(kField, kTip), blind(kField, kTip);
    honest.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{{}, {}, {t}});
    blind.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{});
    TEST_ASSERT_TRUE(afm::compare_with_scan(honest.height(), scan, kField, afm::DisplayModel{}, kTip, 40).rms_height_error_nm < 1e-6);
    TEST_ASSERT_TRUE(afm::compare_with_scan(blind.height(), scan, kField, afm::DisplayModel{}, kTip, 40).rms_height_error_nm > 1.0);
}

// A rod seated in a V-groove, its ends over the groove's floor, imaged by a
// brute-force dilation at the trench run's pixel (15.6 nm). The tip falls
// far past each end into the V, so an end is a narrow spike that rises more
// above the ground beside it than the rod's body does above the walls; at
// some pixel phases only one end shows it. The ridge is still found along
// the rod, its centre within a quarter pixel of the rod's, at every phase.
void test_ridge_of_a_rod_seated_in_a_groove_is_found_along_it_at_every_pixel_phase()
{
    const afm::Field field{-1000, -1000, 2000, 128};
    const afm::TipShape tip{10, 20};
    const double g = 20 * kDeg, depth = 337, R = 50, yc = 100, L = 1300 - 2 * R;
    const double zc = -depth + R / std::sin(g);   // the axis where the rod rests on both walls
    const int reach = static_cast<int>(std::ceil(depth * std::tan(g) / field.pitch())) + 2;
    for (double shift = 0; shift < field.pitch(); shift += field.pitch() / 5) {
        const double x0 = -L / 2 + shift, x1 = L / 2 + shift;
        cv::Mat surface(field.px, field.px, CV_32F), image(field.px, field.px, CV_32F);
        for (int r = 0; r < field.px; ++r)
            for (int c = 0; c < field.px; ++c) {
                const double x = field.x_of(c), y = field.y_of(r), u = std::fabs(y - yc);
                double h = std::min(0.0, -depth + u / std::tan(g));
                const double dx = x < x0 ? x - x0 : (x > x1 ? x - x1 : 0.0), d2 = dx * dx + (y - yc) * (y - yc);
                if (d2 < R * R) h = std::max(h, zc + std::sqrt(R * R - d2));
                surface.at<float>(r, c) = static_cast<float>(h);
            }
        for (int r = 0; r < field.px; ++r)
            for (int c = 0; c < field.px; ++c) {
                double best = -1e9;
                for (int i = std::max(0, r - reach); i <= std::min(field.px - 1, r + reach); ++i)
                    for (int j = std::max(0, c - reach); j <= std::min(field.px - 1, c + reach); ++j)
                        best = std::max(best, surface.at<float>(i, j) -
                                                  tip_surface_nm(field.pitch() * std::hypot(i - r, j - c), tip));
                image.at<float>(r, c) = static_cast<float>(best);
            }
        double cx = 0, cy = 0, a = 0;
        const double band = afm::wire_footprint_nm(R, tip) + 40;
        TEST_ASSERT_TRUE(afm::locate_ridge(image, field, {{x0, yc}, {x1, yc}}, band, &cx, &cy, &a));
        const double along = std::min(a, M_PI - a) * 180 / M_PI;
        std::printf("seated rod shifted %.2f nm: centre off by (%.2f, %.2f) nm, axis %.3f deg off\n", shift, cx - 0.5 * (x0 + x1),
                    cy - yc, along);
        TEST_ASSERT_DOUBLE_WITHIN(0.25 * field.pitch(), 0.5 * (x0 + x1), cx);
        TEST_ASSERT_DOUBLE_WITHIN(1.0, yc, cy);
        TEST_ASSERT_TRUE(along < 0.5);
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_wire_profile_top_is_d_under_any_tip);
    RUN_TEST(test_wire_profile_matches_a_brute_force_dilation_across_and_beyond_the_end);
    RUN_TEST(test_groove_profile_matches_a_sharp_cone_descending_into_the_v);
    RUN_TEST(test_known_wire_renders_to_its_footprint_and_height);
    RUN_TEST(test_trench_renders_to_its_depth_where_the_tip_fits_and_shallower_where_not);
    RUN_TEST(test_colour_scale_widens_when_a_trench_appears);
    RUN_TEST(test_local_update_equals_full_redraw_with_moving_wires_and_growing_trenches);
    RUN_TEST(test_growing_trench_touches_only_its_new_end);
    RUN_TEST(test_fidelity_passes_honest_and_catches_a_wire_misplaced_by_20nm);
    RUN_TEST(test_fidelity_rms_counts_a_trench_the_display_lacks);
    RUN_TEST(test_ridge_of_a_rod_seated_in_a_groove_is_found_along_it_at_every_pixel_phase);
    return UNITY_END();
}
