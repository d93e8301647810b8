// Unity tests of the frame a person reads (renderer/frame_overlay.hpp) and
// of fidelity_diff.png (renderer/fidelity_figure.hpp): the overlay never
// reaches the physical height image the fidelity check compares (the
// check's figures are the same with and without frames composed, the
// heights bit for bit); a small particle's marker is at least kMinMarkerPx
// across; labels are a capital 9 px or more at 256 px; the lever's cone
// is the firmware's S_HI; the diverging map is white at 0 and its range
// rounds the differences' 95th percentile up.
#include <unity.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

#include "afm/fw_state_t.hpp"
#include "display.hpp"
#include "fidelity.hpp"
#include "fidelity_figure.hpp"
#include "frame_overlay.hpp"

namespace {

// 5 um at 256 px (19.5 nm a pixel): a 100 nm particle's image is about 6 px across, as in scenes/default.yaml.
const afm::Field kField{-2500, -2500, 5000, 256};
const afm::TipShape kTip{10, 20};

afm::DisplayModel three()
{
    afm::DisplayModel m;
    m.particles = {{1, -1000, -250, 50}, {2, 0, -200, 50}, {3, 1000, -300, 50}};
    return m;
}

afm::Overlay pushing()
{
    afm::Overlay o;
    o.t_s = 1.6;
    o.tip_nm[0] = 0;
    o.tip_nm[1] = -300;
    o.force_nN[0] = 0.2;
    o.force_nN[1] = 1.7;
    o.force_nN[2] = 5.0;
    o.flags = afm::fw_state_t::FLAG_CONTACT;
    o.hand_N[1] = 0.031;
    o.hand_scale_N = 0.08;
    return o;
}

// A scan of the same particles, one of them 3 nm off: what the check sees.
cv::Mat scan_of(const afm::DisplayModel &m)
{
    afm::Display s(kField, kTip);
    afm::DisplayModel moved = m;
    moved.particles[1].x_nm += 3;
    s.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), moved);
    return s.height().clone();
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_the_overlay_never_reaches_the_height_image_the_fidelity_check_reads()
{
    const afm::DisplayModel m = three();
    const cv::Mat scan = scan_of(m);
    afm::Display plain(kField, kTip), drawn(kField, kTip);
    plain.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), m);
    drawn.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), m);
    const afm::LeverView lever = afm::lever_view(270);
    for (int k = 0; k < 5; ++k) {
        afm::Overlay o = pushing();
        o.t_s = k * 0.04;
        o.flags |= afm::fw_state_t::FLAG_INTERLOCK;
        const cv::Mat f = afm::compose_frame(drawn, m, o, lever);
        TEST_ASSERT_EQUAL_INT(kField.px, f.cols);
        TEST_ASSERT_EQUAL_INT(kField.px, f.rows);
    }
    TEST_ASSERT_EQUAL_DOUBLE(0.0, cv::norm(plain.height(), drawn.height(), cv::NORM_INF));
    const afm::Fidelity a = afm::compare_with_scan(plain.height(), scan, kField, m, kTip, 40);
    const afm::Fidelity b = afm::compare_with_scan(drawn.height(), scan, kField, m, kTip, 40);
    TEST_ASSERT_EQUAL_DOUBLE(a.max_position_error_nm, b.max_position_error_nm);
    TEST_ASSERT_EQUAL_DOUBLE(a.rms_height_error_nm, b.rms_height_error_nm);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, cv::norm(a.diff_nm, b.diff_nm, cv::NORM_INF));
    // and the check does see the 3 nm the scan moved: it is not blind
    TEST_ASSERT_DOUBLE_WITHIN(1.0, 3.0, a.max_position_error_nm);
}

// The marker: green pixels on the row through a particle's centre, spanning at least kMinMarkerPx.
void test_a_small_particle_is_marked_at_least_9_px_across()
{
    const afm::DisplayModel m = three();
    afm::Display d(kField, kTip);
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), m);
    const cv::Mat f = afm::compose_frame(d, m, afm::Overlay{}, afm::lever_view(270));
    for (const auto &p : m.particles) {
        const cv::Point2d c = kField.to_px(p.x_nm, p.y_nm);
        const int row = cvRound(c.y);
        int lo = f.cols, hi = -1;
        for (int x = cvRound(c.x) - 12; x <= cvRound(c.x) + 12; ++x) {
            const cv::Vec3b v = f.at<cv::Vec3b>(row, x);
            if (v[1] > 150 && v[1] > v[2] + 60) lo = std::min(lo, x), hi = std::max(hi, x);   // green, not the map's orange
        }
        TEST_ASSERT_TRUE_MESSAGE(hi >= 0, "no marker on the particle's row");
        TEST_ASSERT_GREATER_OR_EQUAL_INT(afm::kMinMarkerPx, hi - lo + 1);
    }
}

void test_labels_are_a_capital_9_px_high_at_256_px_and_grow_with_the_frame()
{
    TEST_ASSERT_GREATER_OR_EQUAL_INT(9, afm::frame_text(256).cap_px);
    TEST_ASSERT_GREATER_OR_EQUAL_INT(9, afm::frame_text(128).cap_px);
    TEST_ASSERT_GREATER_OR_EQUAL_INT(2 * afm::frame_text(256).cap_px - 1, afm::frame_text(512).cap_px);
}

void test_the_lever_cone_is_the_firmwares_threshold()
{
    // fw_force.h: F_x is unobservable for |sin theta| < S_HI = 1/4 (14.48 deg)
    const afm::LeverView v = afm::lever_view(270);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, std::asin(0.25) * 180 / M_PI, v.blind_half_angle_deg);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 1.0, v.axis[0]);   // scan angle 270: the lever along +x (physics.md section 0)
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, v.axis[1]);
    const afm::LeverView w = afm::lever_view(0);       // alpha = -270 deg: along +y
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, w.axis[0]);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 1.0, w.axis[1]);
}

void test_the_fidelity_figure_is_white_at_zero_and_scales_to_the_differences()
{
    cv::Mat d = cv::Mat::zeros(kField.px, kField.px, CV_32F);
    TEST_ASSERT_EQUAL_DOUBLE(0.5, afm::diff_range_nm(d));
    d(cv::Rect(0, 0, 64, 64)).setTo(3.2f);   // the pixels that differ: 4096 at 3.2 nm
    TEST_ASSERT_EQUAL_DOUBLE(5.0, afm::diff_range_nm(d));
    d.at<float>(100, 100) = -400.0f;         // one outlier does not set the scale
    TEST_ASSERT_EQUAL_DOUBLE(5.0, afm::diff_range_nm(d));
    afm::Fidelity fid;
    fid.diff_nm = cv::Mat::zeros(kField.px, kField.px, CV_32F);
    fid.diff_nm.at<float>(200, 200) = 0.5f;
    const cv::Mat img = afm::fidelity_figure(fid, kField, afm::DisplayModel{}, 5.0);
    TEST_ASSERT_GREATER_OR_EQUAL_INT(512, img.cols);
    // the image's middle (no difference): white; the one pixel of +0.5 nm (enlarged 2x): red
    int red = 0, white = 0;
    for (int r = 0; r < img.rows; ++r)
        for (int c = 0; c < 512; ++c) {
            const cv::Vec3b v = img.at<cv::Vec3b>(r, c);
            if (v[2] > 150 && v[0] < 60 && v[1] < 60) ++red;
            if (v == cv::Vec3b(255, 255, 255)) ++white;
        }
    TEST_ASSERT_GREATER_OR_EQUAL_INT(4, red);   // the pixel, 2 x 2 (colour bar's red end is right of 512)
    TEST_ASSERT_GREATER_THAN_INT(256 * 256, white);
}

// The label blend in integers gives, for every pixel, outline and text
// opacity and the colours' channels in use (0, 255 and two between), the
// byte the formula in doubles gives (the overlay's labels as they were).
void test_the_label_blend_in_integers_is_the_formula_in_doubles()
{
    long differ = 0;
    for (int c : {0, 60, 200, 255})
        for (int p = 0; p < 256; ++p)
            for (int o = 0; o < 256; ++o)
                for (int t = 0; t < 256; ++t) {
                    const double under = p * (255 - o) / 255.0;
                    const unsigned char want = cv::saturate_cast<uchar>(under + (c - under) * t / 255.0);
                    differ += afm::label_blend(p, o, t, c) != want;
                }
    TEST_ASSERT_EQUAL_INT(0, differ);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_overlay_never_reaches_the_height_image_the_fidelity_check_reads);
    RUN_TEST(test_a_small_particle_is_marked_at_least_9_px_across);
    RUN_TEST(test_labels_are_a_capital_9_px_high_at_256_px_and_grow_with_the_frame);
    RUN_TEST(test_the_lever_cone_is_the_firmwares_threshold);
    RUN_TEST(test_the_label_blend_in_integers_is_the_formula_in_doubles);
    RUN_TEST(test_the_fidelity_figure_is_white_at_zero_and_scales_to_the_differences);
    return UNITY_END();
}
