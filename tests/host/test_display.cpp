// Unity tests of the videolized display (host/display, fidelity,
// profile): footprints of known objects, local update == full redraw, the
// fidelity check, the video writer read back by OpenCV, the GSF header,
// labels legible on any map.
#include <unity.h>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <unistd.h>

#include "afm/fw_state_t.hpp"
#include "display.hpp"
#include "fidelity.hpp"
#include "profile.hpp"

namespace {
const afm::Field kField{-500, -500, 1000, 200};     // 5 nm pixels
const afm::TipShape kTip{10, 20};
}  // namespace

void setUp() {}
void tearDown() {}

void test_profile_closed_form_top_and_foot()
{
    // Top of a sphere under any tip: 2R. Foot: (R + r_t + (R - r_t) sin g) / cos g.
    const double R = 50, g = 20 * M_PI / 180;
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 2 * R, afm::sphere_profile_nm(R, 0, kTip));
    const double foot = (R + 10 + (R - 10) * std::sin(g)) / std::cos(g);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, foot, afm::sphere_footprint_nm(R, kTip));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, afm::sphere_profile_nm(R, foot + 1e-6, kTip));
    TEST_ASSERT_TRUE(afm::sphere_profile_nm(R, foot - 1e-3, kTip) > 0);
    // Continuous where the contact moves from the apex sphere to the flank.
    const double sw = (R + 10) * std::cos(g);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, afm::sphere_profile_nm(R, sw - 1e-7, kTip), afm::sphere_profile_nm(R, sw + 1e-7, kTip));
    // A blunt tip on a small sphere: the foot is on the apex sphere.
    const afm::TipShape blunt{80, 10};
    const double Rs = 10, Rt = Rs + 80;
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, std::sqrt(Rt * Rt - 70.0 * 70.0), afm::sphere_footprint_nm(Rs, blunt));
    // No tip: true topography.
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, R + std::sqrt(R * R - 30.0 * 30.0), afm::sphere_profile_nm(R, 30, afm::TipShape{}));
}

void test_known_object_renders_to_its_footprint()
{
    afm::Display d(kField, kTip);
    const afm::DisplayObject p{1, 2.5, 2.5, 50};   // on a pixel centre
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), {p});
    const double foot = afm::sphere_footprint_nm(50, kTip);
    int inside = 0, outside_nonzero = 0;
    for (int r = 0; r < kField.px; ++r)
        for (int c = 0; c < kField.px; ++c) {
            const double rho = std::hypot(kField.x_of(c) - p.x_nm, kField.y_of(r) - p.y_nm);
            const float h = d.height().at<float>(r, c);
            if (rho < foot - 1e-6) {
                ++inside;
                TEST_ASSERT_TRUE(h > 0);
            } else if (h != 0.0f) {
                ++outside_nonzero;
            }
        }
    TEST_ASSERT_EQUAL_INT(0, outside_nonzero);
    // About pi foot^2 / pitch^2 pixels.
    TEST_ASSERT_INT_WITHIN(40, static_cast<int>(M_PI * foot * foot / 25.0), inside);
    const cv::Point2d c = kField.to_px(p.x_nm, p.y_nm);
    TEST_ASSERT_FLOAT_WITHIN(1e-4, 100.0f, d.height().at<float>(cvRound(c.y), cvRound(c.x)));
}

void test_local_update_equals_full_redraw()
{
    std::vector<afm::DisplayObject> objs = {{1, -200, 0, 50}, {2, -120, 10, 40}, {3, 300, -300, 60}};
    afm::Display a(kField, kTip), b(kField, kTip);
    cv::Mat scan = cv::Mat::zeros(kField.px, kField.px, CV_32F);
    a.start(scan, objs);
    b.start(scan, objs);
    for (int k = 0; k < 50; ++k) {
        objs[k % 3].x_nm += 3.7;
        objs[(k + 1) % 3].y_nm -= 2.1;
        const long touched = a.update(objs);
        TEST_ASSERT_TRUE(touched < kField.px * kField.px / 4);   // local
        b.redraw(objs);
    }
    cv::Mat diff;
    cv::absdiff(a.height(), b.height(), diff);
    double worst;
    cv::minMaxLoc(diff, nullptr, &worst);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, worst);
    const afm::Overlay o;
    cv::Mat fa = a.frame(o), fb = b.frame(o), d8;
    cv::absdiff(fa, fb, d8);
    TEST_ASSERT_EQUAL_INT(0, cv::countNonZero(d8.reshape(1)));
    // the colours kept (colour(), which compose_frame copies) are the heights
    // colourised afresh: after local updates, after a rescale (a tall object
    // widens the colour scale) and after a local scan pasted
    const auto same_colours = [](const afm::Display &d) {
        cv::Mat dc;
        cv::absdiff(d.colour(), d.colourise(d.height()), dc);
        return cv::countNonZero(dc.reshape(1));
    };
    TEST_ASSERT_EQUAL_INT(0, same_colours(a));
    const double top = a.z_top();
    objs.push_back({4, 0, 400, 400});
    a.update(objs);
    TEST_ASSERT_TRUE(a.z_top() > top);
    TEST_ASSERT_EQUAL_INT(0, same_colours(a));
    a.paste_scan(cv::Mat(20, 20, CV_32F, cv::Scalar(7.5f)), cv::Rect(10, 10, 20, 20));
    TEST_ASSERT_EQUAL_INT(0, same_colours(a));
}

void test_the_hands_force_is_drawn_and_points_its_way()
{
    // The gauge: nothing without a scale; with one, yellow arrow pixels on
    // the side the force points (the image's y runs down: +y is up).
    afm::Display d(kField, kTip);
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), std::vector<afm::DisplayObject>{});
    auto yellow_in = [](const cv::Mat &img, const cv::Rect &r) {
        int n = 0;
        for (int y = r.y; y < r.y + r.height; ++y)
            for (int x = r.x; x < r.x + r.width; ++x) {
                const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
                n += p[0] < 80 && p[1] > 200 && p[2] > 200;   // BGR yellow
            }
        return n;
    };
    const int N = kField.px, rad = std::max(8, N / 16);
    const cv::Point c(N / 2 + rad, N - rad - 16);
    const cv::Rect above(c.x - 2, c.y - rad, 5, rad - 2), below(c.x - 2, c.y + 3, 5, rad - 3);
    afm::Overlay o;
    o.hand_N[1] = 0.05;
    TEST_ASSERT_EQUAL_INT(0, yellow_in(d.frame(o), above));   // no scale: no gauge
    o.hand_scale_N = 0.08;
    const cv::Mat up = d.frame(o);
    TEST_ASSERT_TRUE(yellow_in(up, above) > 3);
    TEST_ASSERT_EQUAL_INT(0, yellow_in(up, below));
    o.hand_N[1] = -0.05;
    const cv::Mat down = d.frame(o);
    TEST_ASSERT_TRUE(yellow_in(down, below) > 3);
    TEST_ASSERT_EQUAL_INT(0, yellow_in(down, above));
}

void test_labels_stay_legible_on_any_map_and_may_run_off_the_frame()
{
    // put_label: thin text over an outline (its mask dilated by a pixel).
    // The time label at the top left must show both its white strokes and a
    // dark rim, on a black map and on a near-white one (heights at the top
    // of the colour scale), where white text alone would vanish.
    auto count = [](const cv::Mat &img, const cv::Rect &r, bool dark) {
        int n = 0;
        for (int y = r.y; y < r.y + r.height; ++y)
            for (int x = r.x; x < r.x + r.width; ++x) {
                const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
                n += dark ? (p[0] < 60 && p[1] < 60 && p[2] < 60) : (p[0] > 160 && p[1] > 160 && p[2] > 160);
            }
        return n;
    };
    const cv::Rect label(0, 0, 110, 16);
    afm::Overlay o;
    o.t_s = 1.25;
    afm::Display dark(kField, kTip), bright(kField, kTip);
    dark.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{});
    bright.start(cv::Mat(kField.px, kField.px, CV_32F, cv::Scalar(100.0f)), afm::DisplayModel{});
    const cv::Mat on_dark = dark.frame(o), on_bright = bright.frame(o);
    TEST_ASSERT_TRUE(count(on_dark, label, false) > 40);     // the strokes
    TEST_ASSERT_TRUE(count(on_bright, label, true) > 80);    // the rim
    std::printf("label pixels: %d bright on the dark map, %d dark on the bright one\n", count(on_dark, label, false),
                count(on_bright, label, true));
    // the map itself has no near-white or dark pixels there without the label
    TEST_ASSERT_EQUAL_INT(0, count(on_bright, cv::Rect(0, 60, 110, 16), true));
    // The colour bar: white at the top of the scale, black at the bottom.
    const int N = kField.px, bx = N - std::max(4, N / 40) - 30;
    TEST_ASSERT_TRUE(on_dark.at<cv::Vec3b>(30, bx + 1) == cv::Vec3b(255, 255, 255));
    TEST_ASSERT_TRUE(on_dark.at<cv::Vec3b>(N - 30, bx + 1) == cv::Vec3b(0, 0, 0));
    // A frame too small for most of its labels: they are cut at its edges.
    const afm::Field tiny{-50, -50, 100, 24};
    afm::Display small(tiny, kTip);
    small.start(cv::Mat::zeros(tiny.px, tiny.px, CV_32F), afm::DisplayModel{});
    o.hand_scale_N = 0.08;
    o.flags = afm::fw_state_t::FLAG_CONTACT | afm::fw_state_t::FLAG_SQUEEZE;
    const cv::Mat f = small.frame(o);
    TEST_ASSERT_EQUAL_INT(tiny.px, f.rows);
    TEST_ASSERT_EQUAL_INT(tiny.px, f.cols);
}

void test_fidelity_passes_honest_and_catches_20nm_misplacement()
{
    const std::vector<afm::DisplayObject> truth = {{1, -200, 0, 50}, {2, 250, 100, 50}};
    afm::Display scanner(kField, kTip);
    scanner.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), afm::DisplayModel{});
    scanner.redraw(truth);
    const cv::Mat scan = scanner.height().clone();

    afm::Display honest(kField, kTip);
    honest.start(scan, truth);
    afm::Fidelity f = afm::compare_with_scan(honest.height(), scan, kField, truth, kTip, 40);
    std::printf("honest: max %.4f nm, rms %.4f nm\n", f.max_position_error_nm, f.rms_height_error_nm);
    TEST_ASSERT_TRUE(f.max_position_error_nm < 0.01);
    TEST_ASSERT_TRUE(f.rms_height_error_nm < 1e-6);

    std::vector<afm::DisplayObject> wrong = truth;
    wrong[1].x_nm += 20;   // the model thinks particle 2 is 20 nm further along x
    afm::Display misled(kField, kTip);
    misled.start(scan, truth);
    misled.update(wrong);
    f = afm::compare_with_scan(misled.height(), scan, kField, wrong, kTip, 40);
    std::printf("misplaced by 20 nm: object 2 error %.3f nm, max %.3f nm, rms %.3f nm\n", f.objects[1].error_nm,
                f.max_position_error_nm, f.rms_height_error_nm);
    TEST_ASSERT_TRUE(f.objects[1].found);
    TEST_ASSERT_DOUBLE_WITHIN(1.0, 20.0, f.objects[1].error_nm);   // centroid on 5 nm pixels
    TEST_ASSERT_TRUE(f.objects[0].error_nm < 0.01);
    TEST_ASSERT_TRUE(f.max_position_error_nm > 5.0);
    TEST_ASSERT_TRUE(f.rms_height_error_nm > 1.0);
}

void test_fidelity_reports_an_object_missing_from_the_scan()
{
    const std::vector<afm::DisplayObject> model = {{1, 0, 0, 50}};
    const cv::Mat empty_scan = cv::Mat::zeros(kField.px, kField.px, CV_32F);
    afm::Display d(kField, kTip);
    d.start(empty_scan, model);
    const afm::Fidelity f = afm::compare_with_scan(d.height(), empty_scan, kField, model, kTip, 40);
    TEST_ASSERT_FALSE(f.objects[0].found);
    TEST_ASSERT_TRUE(f.max_position_error_nm > 1e300);   // infinity: nothing to compare
}

void test_video_reads_back_with_the_frame_count_written()
{
    afm::Display d(kField, kTip);
    std::vector<afm::DisplayObject> objs = {{1, 0, 0, 50}};
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), objs);
    char path[] = "/tmp/afm-test-video-XXXXXX";
    const int fd = mkstemp(path);
    close(fd);
    const std::string mp4 = std::string(path) + ".mp4";
    cv::VideoWriter w(mp4, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), 25, cv::Size(kField.px, kField.px));
    TEST_ASSERT_TRUE(w.isOpened());
    for (int k = 0; k < 37; ++k) {
        objs[0].x_nm += 2;
        d.update(objs);
        w.write(d.frame(afm::Overlay{}));
    }
    w.release();
    cv::VideoCapture cap(mp4);
    TEST_ASSERT_TRUE(cap.isOpened());
    cv::Mat f;
    int n = 0, cols = 0;
    while (cap.read(f)) {
        ++n;
        cols = f.cols;
    }
    TEST_ASSERT_EQUAL_INT(37, n);
    TEST_ASSERT_EQUAL_INT(kField.px, cols);
    unlink(path);
    unlink(mp4.c_str());
}

void test_gsf_header_and_padding()
{
    cv::Mat h(3, 5, CV_32F);
    for (int i = 0; i < 15; ++i) h.at<float>(i / 5, i % 5) = static_cast<float>(i);
    char path[] = "/tmp/afm-test-gsf-XXXXXX";
    close(mkstemp(path));
    std::string err;
    TEST_ASSERT_TRUE(afm::write_gsf(path, h, afm::Field{0, 0, 1000, 5}, "t", &err));
    std::ifstream f(path, std::ios::binary);
    std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    unlink(path);
    TEST_ASSERT_EQUAL_INT(0, all.find("Gwyddion Simple Field 1.0\n"));
    const std::size_t nul = all.find('\0');
    TEST_ASSERT_TRUE(nul != std::string::npos);
    // Header padded to a multiple of 4 with 1..4 NULs, then 15 float32.
    const std::size_t data = nul + (4 - nul % 4);
    for (std::size_t i = nul; i < data; ++i) TEST_ASSERT_EQUAL_INT('\0', all[i]);
    TEST_ASSERT_EQUAL_INT(15 * 4, static_cast<int>(all.size() - data));
    float v;
    std::memcpy(&v, all.data() + data + 4 * 7, 4);
    TEST_ASSERT_FLOAT_WITHIN(1e-15f, 7e-9f, v);   // nm -> m
    TEST_ASSERT_TRUE(all.find("XRes = 5\n") != std::string::npos);
    TEST_ASSERT_TRUE(all.find("YRes = 3\n") != std::string::npos);
    TEST_ASSERT_TRUE(all.find("XYUnits = m\n") != std::string::npos);
    TEST_ASSERT_FALSE(afm::write_gsf("/nonexistent/dir/x.gsf", h, afm::Field{0, 0, 1000, 5}, "t", &err));
    TEST_ASSERT_TRUE(err.find("/nonexistent/dir/x.gsf") != std::string::npos);
}

void test_interlock_flag_draws_a_red_border_and_banner()
{
    // FW_STATE's FLAG_INTERLOCK: a red border round the frame and a red
    // banner under the flags' line; without it, no red there (the afmhot
    // map has no pure red: its blue-free colours are orange to yellow).
    afm::Display d(kField, kTip);
    d.start(cv::Mat::zeros(kField.px, kField.px, CV_32F), std::vector<afm::DisplayObject>{});
    auto red_in = [](const cv::Mat &img, const cv::Rect &r) {
        int n = 0;
        for (int y = r.y; y < r.y + r.height; ++y)
            for (int x = r.x; x < r.x + r.width; ++x) {
                const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
                n += p[0] < 40 && p[1] < 40 && p[2] > 200;   // BGR red
            }
        return n;
    };
    const int N = kField.px;
    const cv::Rect left(0, 50, 2, N - 100), bottom(50, N - 2, N - 100, 2), banner(120, 29, 60, 12);
    afm::Overlay o;
    o.flags = afm::fw_state_t::FLAG_SQUEEZE;
    const cv::Mat plain = d.frame(o);
    TEST_ASSERT_EQUAL_INT(0, red_in(plain, left) + red_in(plain, bottom) + red_in(plain, banner));
    o.flags |= afm::fw_state_t::FLAG_INTERLOCK;
    const cv::Mat locked = d.frame(o);
    TEST_ASSERT_EQUAL_INT(left.area(), red_in(locked, left));
    TEST_ASSERT_EQUAL_INT(bottom.area(), red_in(locked, bottom));
    TEST_ASSERT_TRUE(red_in(locked, banner) > banner.area() / 2);   // the banner, less its white letters
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_profile_closed_form_top_and_foot);
    RUN_TEST(test_known_object_renders_to_its_footprint);
    RUN_TEST(test_local_update_equals_full_redraw);
    RUN_TEST(test_the_hands_force_is_drawn_and_points_its_way);
    RUN_TEST(test_interlock_flag_draws_a_red_border_and_banner);
    RUN_TEST(test_labels_stay_legible_on_any_map_and_may_run_off_the_frame);
    RUN_TEST(test_fidelity_passes_honest_and_catches_20nm_misplacement);
    RUN_TEST(test_fidelity_reports_an_object_missing_from_the_scan);
    RUN_TEST(test_video_reads_back_with_the_frame_count_written);
    RUN_TEST(test_gsf_header_and_padding);
    return UNITY_END();
}
