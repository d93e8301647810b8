// Unity tests of the renderer's frame writer (host/frame_writer.hpp):
// the frames come out as PNG files, byte for byte what afm::encode_png
// makes (png_file.hpp; its own tests read them back pixel for pixel), and
// in the video in order, however small its queue; a file it cannot write
// fails the next write() or finish() with the file's name; a video it
// cannot open is refused at once. "mp4" is H.264 through ffmpeg where it
// is (read back, in order), else OpenCV's mp4v with the reason recorded.
// frame_writer.hpp (nlohmann/json) before unity.h, whose isnan macro breaks it
#include "frame_writer.hpp"
#include <unity.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "png_file.hpp"

namespace fs = std::filesystem;

namespace {

std::string dir;

cv::Mat frame_of(int k, int px = 64)
{
    cv::Mat f(px, px, CV_8UC3, cv::Scalar(10 * k, 255 - 10 * k, 128));
    cv::circle(f, cv::Point(8 + 4 * k, px / 2), 5, cv::Scalar(255, 255, 255), cv::FILLED);
    return f;
}

std::vector<char> bytes_of(const std::string &path)
{
    std::ifstream f(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::string png_of(int k)
{
    char name[64];
    std::snprintf(name, sizeof name, "/frames/frame_%05d.png", k);
    return dir + name;
}

}  // namespace

void setUp()
{
    char tmpl[] = "/tmp/afm-test-writer-XXXXXX";
    TEST_ASSERT_NOT_NULL(mkdtemp(tmpl));
    dir = tmpl;
    fs::create_directories(dir + "/frames");
}
void tearDown() { fs::remove_all(dir); }

// Through a queue of one: every frame's PNG is encode_png's and reads back
// as the frame, the video holds every frame in order.
void test_frames_come_out_as_encode_png_makes_them_and_in_order()
{
    const int n = 12;
    {
        afm::FrameWriter w(dir, true, "avi", 25.0, 64, {}, 1);
        for (int k = 0; k < n; ++k) w.write(k, frame_of(k));
        w.finish();
        TEST_ASSERT_EQUAL_INT(n, w.written());
        TEST_ASSERT_TRUE(w.cpu_seconds() > 0);
    }
    for (int k = 0; k < n; ++k) {
        const std::vector<std::uint8_t> ref = afm::encode_png(frame_of(k));
        const std::vector<char> got = bytes_of(png_of(k));
        TEST_ASSERT_TRUE_MESSAGE(std::vector<char>(ref.begin(), ref.end()) == got, png_of(k).c_str());
        TEST_ASSERT_EQUAL_DOUBLE_MESSAGE(0.0, cv::norm(cv::imread(png_of(k)), frame_of(k), cv::NORM_INF), png_of(k).c_str());
    }
    cv::VideoCapture cap(dir + "/video.avi");
    TEST_ASSERT_TRUE(cap.isOpened());
    cv::Mat f;
    int got = 0;
    while (cap.read(f)) {
        // MJPG is lossy: each frame is nearest its own source
        double best = 1e18;
        int best_k = -1;
        for (int k = 0; k < n; ++k) {
            const double d = cv::norm(f, frame_of(k), cv::NORM_L1);
            if (d < best) best = d, best_k = k;
        }
        TEST_ASSERT_EQUAL_INT(got, best_k);
        ++got;
    }
    TEST_ASSERT_EQUAL_INT(n, got);
}

// No PNG and no video: nothing written, and finish() still returns.
void test_no_outputs_writes_nothing()
{
    afm::FrameWriter w(dir, false, "none", 25.0, 64, {});
    for (int k = 0; k < 3; ++k) w.write(k, frame_of(k));
    w.finish();
    TEST_ASSERT_EQUAL_INT(3, w.written());
    TEST_ASSERT_TRUE(fs::is_empty(dir + "/frames"));
}

// A PNG that cannot be written (frames/ is gone) fails the run, naming the file.
void test_a_file_it_cannot_write_is_named_by_the_next_call()
{
    fs::remove_all(dir + "/frames");
    afm::FrameWriter w(dir, true, "none", 25.0, 64, {});
    bool thrown = false;
    try {
        for (int k = 0; k < 50; ++k) w.write(k, frame_of(k));
        w.finish();
    } catch (const std::runtime_error &e) {
        thrown = true;
        TEST_ASSERT_NOT_EQUAL(std::string::npos, std::string(e.what()).find("frame_00000.png"));
    }
    TEST_ASSERT_TRUE(thrown);
}

// A video it cannot open is refused when the writer is made, naming the file.
void test_a_video_it_cannot_open_is_refused_by_name()
{
    fs::remove_all(dir);
    try {
        afm::FrameWriter w(dir, false, "avi", 25.0, 64, {});
        TEST_FAIL_MESSAGE("a video in a missing folder was opened");
    } catch (const std::runtime_error &e) {
        TEST_ASSERT_NOT_EQUAL(std::string::npos, std::string(e.what()).find("video.avi"));
    }
    fs::create_directories(dir);
}

// A writer dropped without finish() stops without writing what is queued, and without hanging.
void test_a_writer_dropped_unfinished_stops()
{
    {
        afm::FrameWriter w(dir, true, "none", 25.0, 64, {});
        for (int k = 0; k < 4; ++k) w.write(k, frame_of(k));
    }
    TEST_ASSERT_TRUE(fs::exists(dir + "/frames"));
}

// mp4 frames read back by OpenCV: as many as written, each nearest its own source.
void check_mp4_frames(int n)
{
    cv::VideoCapture cap(dir + "/video.mp4");
    TEST_ASSERT_TRUE(cap.isOpened());
    cv::Mat f;
    int got = 0;
    while (cap.read(f)) {
        double best = 1e18;
        int best_k = -1;
        for (int k = 0; k < n; ++k) {
            const double d = cv::norm(f, frame_of(k), cv::NORM_L1);
            if (d < best) best = d, best_k = k;
        }
        TEST_ASSERT_EQUAL_INT(got, best_k);
        ++got;
    }
    TEST_ASSERT_EQUAL_INT(n, got);
}

// With ffmpeg (./afm setup installs it): H.264, the index (moov) before the data.
void test_mp4_is_h264_through_ffmpeg_with_its_index_first()
{
    unsetenv("AFM_FFMPEG");
    const int n = 10;
    nlohmann::json v;
    {
        afm::FrameWriter w(dir, false, "mp4", 25.0, 64, {});
        for (int k = 0; k < n; ++k) w.write(k, frame_of(k));
        w.finish();
        v = w.video();
    }
    TEST_ASSERT_EQUAL_STRING_MESSAGE("h264", v.value("codec", "").c_str(), v.dump().c_str());
    TEST_ASSERT_TRUE(v["fallback_why"].is_null());
    TEST_ASSERT_TRUE(v.value("encoder_cpu_s", 0.0) > 0);
    const std::vector<char> b = bytes_of(dir + "/video.mp4");
    const std::string head(b.begin(), b.end());
    TEST_ASSERT_EQUAL_STRING("ftyp", head.substr(4, 4).c_str());
    TEST_ASSERT_TRUE(head.find("moov") != std::string::npos && head.find("moov") < head.find("mdat"));
    check_mp4_frames(n);
}

// Without ffmpeg: OpenCV's mp4v, and the reason, naming what was missing.
void test_without_ffmpeg_mp4v_runs_and_says_why()
{
    setenv("AFM_FFMPEG", "/nonexistent/ffmpeg", 1);
    const int n = 6;
    nlohmann::json v;
    {
        afm::FrameWriter w(dir, false, "mp4", 25.0, 64, {});
        for (int k = 0; k < n; ++k) w.write(k, frame_of(k));
        w.finish();
        v = w.video();
    }
    unsetenv("AFM_FFMPEG");
    TEST_ASSERT_EQUAL_STRING("mp4v", v.value("codec", "").c_str());
    TEST_ASSERT_NOT_EQUAL(std::string::npos, v.value("fallback_why", "").find("/nonexistent/ffmpeg"));
    check_mp4_frames(n);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_frames_come_out_as_encode_png_makes_them_and_in_order);
    RUN_TEST(test_no_outputs_writes_nothing);
    RUN_TEST(test_a_file_it_cannot_write_is_named_by_the_next_call);
    RUN_TEST(test_a_video_it_cannot_open_is_refused_by_name);
    RUN_TEST(test_a_writer_dropped_unfinished_stops);
    RUN_TEST(test_mp4_is_h264_through_ffmpeg_with_its_index_first);
    RUN_TEST(test_without_ffmpeg_mp4v_runs_and_says_why);
    return UNITY_END();
}
