// Unity tests of the frame a person reads (renderer/frame_overlay.hpp) and
// of the figures (renderer/fidelity_figure.hpp, figure_axes.hpp): the
// overlay never reaches the physical height image the fidelity check
// compares (the check's figures are the same with and without frames
// composed, the heights bit for bit); a frame is at least 512 px; a small
// particle's marker is at least kMinMarkerPx across; the lever's cone is
// the firmware's S_HI; the diverging map is white at 0 and its range rounds
// the differences' 95th percentile up. The texts, over a table of frames
// (displays of 64 to 512 px, the tip at the corners and the edges, the
// interlock, a dense pattern, wires and trenches) and the figures: the
// smallest capital drawn is 9 px or more, no two texts touch (2 px at
// least between their inks), none lies on an axis or tick, none but the
// axes' own on their bands, a y tick's label ends left of its tick (so
// that the tick never reads as a minus sign), and the axes, the legend and
// the status are all there.
#include <unity.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "afm/fw_state_t.hpp"
#include "display.hpp"
#include "fidelity.hpp"
#include "figure_axes.hpp"
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
        TEST_ASSERT_EQUAL_INT(512, f.cols);
        TEST_ASSERT_EQUAL_INT(512, f.rows);
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
    const int k = f.cols / kField.px;
    for (const auto &p : m.particles) {
        const cv::Point2d q = kField.to_px(p.x_nm, p.y_nm), c((q.x + 0.5) * k - 0.5, (q.y + 0.5) * k - 0.5);
        const int row = cvRound(c.y);
        int lo = f.cols, hi = -1;
        for (int x = cvRound(c.x) - 24; x <= cvRound(c.x) + 24; ++x) {
            const cv::Vec3b v = f.at<cv::Vec3b>(row, x);
            if (v[1] > 150 && v[1] > v[2] + 60) lo = std::min(lo, x), hi = std::max(hi, x);   // green, not the map's orange
        }
        TEST_ASSERT_TRUE_MESSAGE(hi >= 0, "no marker on the particle's row");
        TEST_ASSERT_GREATER_OR_EQUAL_INT(afm::kMinMarkerPx, hi - lo + 1);
    }
}

void test_frames_are_512_px_or_more_each_display_pixel_a_whole_square()
{
    for (int px : {16, 64, 100, 128, 256, 300, 512, 1000}) {
        const int n = afm::frame_px(px);
        TEST_ASSERT_GREATER_OR_EQUAL_INT(512, n);
        TEST_ASSERT_EQUAL_INT(0, n % px);
        TEST_ASSERT_LESS_THAN_INT(512 + px, n);
    }
    TEST_ASSERT_EQUAL_INT(512, afm::frame_px(128));
    TEST_ASSERT_EQUAL_INT(600, afm::frame_px(300));
}

void test_labels_are_a_capital_9_px_high_at_512_px_and_grow_with_the_frame()
{
    TEST_ASSERT_GREATER_OR_EQUAL_INT(9, afm::frame_text(512).cap_px);
    TEST_ASSERT_GREATER_OR_EQUAL_INT(9, afm::figure_text().cap_px);
    TEST_ASSERT_GREATER_OR_EQUAL_INT(2 * afm::frame_text(512).cap_px - 1, afm::frame_text(1024).cap_px);
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
    afm::FigureLayout lay;
    const cv::Mat img = afm::fidelity_figure(fid, kField, afm::DisplayModel{}, 5.0, &lay);
    TEST_ASSERT_GREATER_OR_EQUAL_INT(512, lay.picture.width);
    // the image's middle (no difference): white; the one pixel of +0.5 nm (enlarged 2x): red
    int red = 0, white = 0;
    for (int r = lay.picture.y; r < lay.picture.br().y; ++r)
        for (int c = lay.picture.x; c < lay.picture.br().x; ++c) {
            const cv::Vec3b v = img.at<cv::Vec3b>(r, c);
            if (v[2] > 150 && v[0] < 60 && v[1] < 60) ++red;
            if (v == cv::Vec3b(255, 255, 255)) ++white;
        }
    TEST_ASSERT_GREATER_OR_EQUAL_INT(4, red);   // the pixel, 2 x 2
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

namespace {

// The smallest capital a frame or figure drew: the ink of its texts that
// hold a capital or a digit (their height is a capital's at least).
int smallest_capital(const std::vector<afm::TextBox> &texts)
{
    int least = 1 << 20;
    for (const auto &t : texts)
        for (char ch : t.text)
            if ((ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9')) {
                least = std::min(least, t.ink.height);
                break;
            }
    return least;
}

// Two texts touch: fewer than 2 px between their inks.
bool touch(const cv::Rect &a, const cv::Rect &b)
{
    return (cv::Rect(a.x - 2, a.y - 2, a.width + 4, a.height + 4) & b).area() > 0;
}

int count_role(const std::vector<afm::TextBox> &texts, const std::string &role)
{
    int n = 0;
    for (const auto &t : texts) n += t.role == role;
    return n;
}

// The checks every frame and figure passes; what names the case.
void check_texts(const std::vector<afm::TextBox> &texts, const std::vector<cv::Rect> &axes, cv::Size size, const char *what)
{
    char msg[512];
    const cv::Rect all(0, 0, size.width, size.height);
    for (std::size_t i = 0; i < texts.size(); ++i) {
        const afm::TextBox &a = texts[i];
        std::snprintf(msg, sizeof msg, "%s: '%s' (%s) at %d,%d %dx%d", what, a.text.c_str(), a.role.c_str(), a.ink.x, a.ink.y, a.ink.width, a.ink.height);
        TEST_ASSERT_TRUE_MESSAGE(a.ink.area() > 0 && (a.ink & all) == a.ink, msg);
        for (std::size_t j = i + 1; j < texts.size(); ++j) {
            const afm::TextBox &b = texts[j];
            std::snprintf(msg, sizeof msg, "%s: '%s' (%s) touches '%s' (%s)", what, a.text.c_str(), a.role.c_str(), b.text.c_str(), b.role.c_str());
            TEST_ASSERT_FALSE_MESSAGE(touch(a.ink, b.ink), msg);
        }
        for (const cv::Rect &ax : axes) {
            std::snprintf(msg, sizeof msg, "%s: '%s' (%s) lies on an axis or tick at %d,%d %dx%d", what, a.text.c_str(), a.role.c_str(), ax.x, ax.y,
                          ax.width, ax.height);
            if (a.role != "banner") TEST_ASSERT_FALSE_MESSAGE((a.ink & ax).area() > 0, msg);
        }
        if (a.role == "y tick") {   // its tick lies right of it, on its rows, 2 px away or more
            bool ticked = false;
            for (const cv::Rect &ax : axes)
                ticked |= ax.height == 1 && ax.y >= a.ink.y && ax.y < a.ink.br().y && ax.x >= a.ink.br().x + 2;
            std::snprintf(msg, sizeof msg, "%s: y label '%s' has no tick right of it", what, a.text.c_str());
            TEST_ASSERT_TRUE_MESSAGE(ticked, msg);
        }
    }
    std::snprintf(msg, sizeof msg, "%s: the smallest capital", what);
    TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(9, smallest_capital(texts), msg);
    std::snprintf(msg, sizeof msg, "%s: ticks labelled", what);
    TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(3, count_role(texts, "x tick"), msg);
    TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(3, count_role(texts, "y tick"), msg);
}

// A particle every `pitch` nm over the field's middle: a dense pattern.
afm::DisplayModel grid(const afm::Field &f, double pitch, double radius)
{
    afm::DisplayModel m;
    int id = 0;
    for (double y = f.y0_nm + f.size_nm * 0.15; y < f.y0_nm + f.size_nm * 0.85; y += pitch)
        for (double x = f.x0_nm + f.size_nm * 0.15; x < f.x0_nm + f.size_nm * 0.85; x += pitch) m.particles.push_back({++id, x, y, radius});
    m.wires.push_back({1, 20, {{f.x0_nm + 0.1 * f.size_nm, f.y0_nm + 0.9 * f.size_nm}, {f.x0_nm + 0.5 * f.size_nm, f.y0_nm + 0.92 * f.size_nm}}});
    m.trenches.push_back({1, {{f.x0_nm + 0.6 * f.size_nm, f.y0_nm + 0.1 * f.size_nm, 5, 40}, {f.x0_nm + 0.9 * f.size_nm, f.y0_nm + 0.1 * f.size_nm, 5, 40}}});
    return m;
}

}  // namespace

void test_no_frame_text_is_small_touches_another_or_lies_on_the_axes()
{
    const afm::Field fields[] = {kField, {-1000, -1000, 2000, 128}, {0, 0, 2048, 512}, {-300, 200, 640, 64}};
    // the tip's place as a fraction of the field: the middle, the four corners, the left and bottom edges
    const double tips[][2] = {{0.5, 0.45}, {0.02, 0.02}, {0.98, 0.98}, {0.02, 0.98}, {0.98, 0.02}, {0.03, 0.5}, {0.5, 0.03}};
    int frames = 0, lever_named = 0, least = 1 << 20;
    for (const afm::Field &f : fields)
        for (int dense = 0; dense < 2; ++dense)
            for (const auto &at : tips)
                for (int flags : {static_cast<int>(afm::fw_state_t::FLAG_CONTACT), afm::fw_state_t::FLAG_CONTACT | afm::fw_state_t::FLAG_INTERLOCK})
                    for (double angle : {270.0, 0.0, 135.0}) {
                        const afm::DisplayModel m = dense ? grid(f, f.size_nm / 12, f.size_nm / 60) : three();
                        afm::Display d(f, kTip);
                        d.start(cv::Mat::zeros(f.px, f.px, CV_32F), m);
                        afm::Overlay o = pushing();
                        o.flags = flags;
                        o.tip_nm[0] = f.x0_nm + at[0] * f.size_nm;
                        o.tip_nm[1] = f.y0_nm + at[1] * f.size_nm;
                        if (angle == 0.0) o.hand_scale_N = 0;   // a planner's run: no gauge
                        afm::FrameLayout lay;
                        const cv::Mat img = afm::compose_frame(d, m, o, afm::lever_view(angle), &lay);
                        char what[160];
                        std::snprintf(what, sizeof what, "frame of %d px (display %d), tip at %.2f,%.2f, flags %d, angle %g, %s", img.cols, f.px, at[0], at[1],
                                      flags, angle, dense ? "dense" : "three");
                        TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(512, img.cols, what);
                        check_texts(lay.texts, lay.axes, img.size(), what);
                        for (const auto &t : lay.texts)
                            if (t.role != "x tick" && t.role != "y tick" && t.role != "axis unit")
                                for (const cv::Rect &b : lay.bands) TEST_ASSERT_FALSE_MESSAGE((t.ink & b).area() > 0, (what + (" '" + t.text + "' on an axis band")).c_str());
                        TEST_ASSERT_EQUAL_INT_MESSAGE(1, count_role(lay.texts, "axis unit"), what);
                        TEST_ASSERT_EQUAL_INT_MESSAGE(o.hand_scale_N > 0 ? 3 : 2, count_role(lay.texts, "legend"), what);
                        TEST_ASSERT_EQUAL_INT_MESSAGE(2, count_role(lay.texts, "status"), what);
                        TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(2, count_role(lay.texts, "bar"), what);
                        TEST_ASSERT_EQUAL_INT_MESSAGE(flags & afm::fw_state_t::FLAG_INTERLOCK ? 1 : 0, count_role(lay.texts, "banner"), what);
                        lever_named += count_role(lay.texts, "lever");
                        if (!dense && &at == &tips[0]) TEST_ASSERT_EQUAL_INT_MESSAGE(1, count_role(lay.texts, "lever"), what);   // room for it
                        least = std::min(least, smallest_capital(lay.texts));
                        ++frames;
                    }
    std::printf("frames: %d checked, the smallest capital %d px, the lever named in %d\n", frames, least, lever_named);
}

void test_no_figure_text_is_small_touches_another_or_lies_on_the_axes()
{
    int least = 1 << 20;
    for (const afm::Field &f : {kField, afm::Field{-1000, -1000, 2000, 128}, afm::Field{0, 0, 2048, 512}}) {
        const afm::DisplayModel m = grid(f, f.size_nm / 12, f.size_nm / 60);
        afm::Fidelity fid;
        fid.diff_nm = cv::Mat::zeros(f.px, f.px, CV_32F);
        fid.max_position_error_nm = 3.2;
        for (const auto &p : m.particles) {
            afm::ObjectFidelity o{};
            o.kind = "particle";
            o.id = p.id;
            o.found = p.id % 3 != 0;
            o.error_nm = 1.0 + p.id % 7;
            fid.objects.push_back(o);
        }
        afm::FigureLayout lay;
        const cv::Mat img = afm::fidelity_figure(fid, f, m, 5.0, &lay);
        char what[96];
        std::snprintf(what, sizeof what, "fidelity figure, display %d px", f.px);
        check_texts(lay.texts, lay.axes, img.size(), what);
        TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(5, count_role(lay.texts, "bar"), what);
        TEST_ASSERT_EQUAL_INT_MESSAGE(2, count_role(lay.texts, "axis unit"), what);
        least = std::min(least, smallest_capital(lay.texts));
        afm::Display d(f, kTip);
        d.start(cv::Mat::zeros(f.px, f.px, CV_32F), m);
        const cv::Mat scan = afm::scan_figure(d, d.height(), "initial scan: height (nm)", &lay);
        std::snprintf(what, sizeof what, "scan figure, display %d px", f.px);
        check_texts(lay.texts, lay.axes, scan.size(), what);
        TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(512, lay.picture.width, what);
        TEST_ASSERT_GREATER_OR_EQUAL_INT_MESSAGE(3, count_role(lay.texts, "bar"), what);
        TEST_ASSERT_EQUAL_INT_MESSAGE(2, count_role(lay.texts, "axis unit"), what);
        least = std::min(least, smallest_capital(lay.texts));
    }
    std::printf("figures: the smallest capital %d px\n", least);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_overlay_never_reaches_the_height_image_the_fidelity_check_reads);
    RUN_TEST(test_a_small_particle_is_marked_at_least_9_px_across);
    RUN_TEST(test_frames_are_512_px_or_more_each_display_pixel_a_whole_square);
    RUN_TEST(test_labels_are_a_capital_9_px_high_at_512_px_and_grow_with_the_frame);
    RUN_TEST(test_no_frame_text_is_small_touches_another_or_lies_on_the_axes);
    RUN_TEST(test_no_figure_text_is_small_touches_another_or_lies_on_the_axes);
    RUN_TEST(test_the_lever_cone_is_the_firmwares_threshold);
    RUN_TEST(test_the_label_blend_in_integers_is_the_formula_in_doubles);
    RUN_TEST(test_the_fidelity_figure_is_white_at_zero_and_scales_to_the_differences);
    return UNITY_END();
}
