// Unity tests of the display's PNG files (host/png_file.hpp): every
// image comes back pixel for pixel through libpng (OpenCV's imread), in
// each kind it takes (grey, BGR, BGRA), at the sizes where a row's filter
// or the deflate has edges (1 px, odd widths, a view into a larger image,
// noise that does not compress, samples that wrap round 0 and 255); what it
// does not take is refused naming what it got; a file it cannot write is
// named and not left half written. The readers and encoders that stand in
// for OpenCV's imgcodecs in the renderer and the operator give what
// imgcodecs gives: read_png (host/image/png_read.hpp) imread's pixels for
// every colour type and depth, grey and colour; encode_jpeg
// (host/renderer/jpeg_file.hpp) imencode's bytes.
#include <unity.h>

#include <png.h>
#include <signal.h>
#include <sys/resource.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "jpeg_file.hpp"
#include "png_file.hpp"
#include "png_read.hpp"

namespace fs = std::filesystem;

namespace {

std::string dir;

// Written, read back by libpng with nothing converted, and compared.
void assert_round_trip(const cv::Mat &img, const char *what)
{
    const std::string path = dir + "/x.png";
    afm::write_png(path, img);
    const cv::Mat back = cv::imread(path, cv::IMREAD_UNCHANGED);
    TEST_ASSERT_FALSE_MESSAGE(back.empty(), what);
    TEST_ASSERT_EQUAL_INT_MESSAGE(img.type(), back.type(), what);
    TEST_ASSERT_EQUAL_INT_MESSAGE(img.cols, back.cols, what);
    TEST_ASSERT_EQUAL_INT_MESSAGE(img.rows, back.rows, what);
    TEST_ASSERT_EQUAL_DOUBLE_MESSAGE(0.0, cv::norm(img, back, cv::NORM_INF), what);
    // the file is the encoding, byte for byte
    const std::vector<std::uint8_t> bytes = afm::encode_png(img);
    std::ifstream f(path, std::ios::binary);
    const std::vector<std::uint8_t> file{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
    TEST_ASSERT_TRUE_MESSAGE(bytes == file, what);
}

cv::Mat noise(int rows, int cols, int type, unsigned seed)
{
    cv::Mat m(rows, cols, type);
    cv::RNG rng(seed);
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    return m;
}

// A frame as the display draws one: a colour ramp, discs, text.
cv::Mat frame_like(int px)
{
    cv::Mat f(px, px, CV_8UC3);
    for (int y = 0; y < px; ++y)
        for (int x = 0; x < px; ++x) f.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 255 / px, y * 255 / px, 128);
    for (int k = 0; k < 6; ++k) cv::circle(f, cv::Point(20 + 35 * k, px / 2), 12, cv::Scalar(255, 255 - 40 * k, 40 * k), cv::FILLED, cv::LINE_AA);
    cv::putText(f, "1 um  12.3 nN", cv::Point(8, px - 10), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    return f;
}

// A PNG written by libpng itself: `colormap` a palette image (libpng's
// simplified API), else an interlaced (Adam7) RGB one.
void write_with_libpng(const std::string &path, const cv::Mat &bgr, bool colormap)
{
    cv::Mat rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    if (colormap) {
        png_image im{};
        im.version = PNG_IMAGE_VERSION;
        im.width = static_cast<png_uint_32>(rgb.cols);
        im.height = static_cast<png_uint_32>(rgb.rows);
        im.format = PNG_FORMAT_RGB;   // libpng builds the palette (at most 256 colours; the image has 8)
        im.flags = 0;
        std::vector<png_color> map(256);
        std::vector<png_byte> idx(rgb.total());
        for (std::size_t i = 0; i < rgb.total(); ++i) {
            const cv::Vec3b v = rgb.at<cv::Vec3b>(static_cast<int>(i));
            idx[i] = static_cast<png_byte>((v[0] >> 7) | ((v[1] >> 7) << 1) | ((v[2] >> 7) << 2));
            map[idx[i]] = {static_cast<png_byte>(v[0] & 0x80 ? 255 : 0), static_cast<png_byte>(v[1] & 0x80 ? 255 : 0),
                           static_cast<png_byte>(v[2] & 0x80 ? 255 : 0)};
        }
        im.format = PNG_FORMAT_RGB_COLORMAP;
        im.colormap_entries = 8;
        TEST_ASSERT_TRUE_MESSAGE(png_image_write_to_file(&im, path.c_str(), 0, idx.data(), 0, map.data()), im.message);
        return;
    }
    std::FILE *f = std::fopen(path.c_str(), "wb");
    TEST_ASSERT_NOT_NULL(f);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    TEST_ASSERT_EQUAL_INT(0, setjmp(png_jmpbuf(png)));
    png_init_io(png, f);
    png_set_IHDR(png, info, static_cast<png_uint_32>(rgb.cols), static_cast<png_uint_32>(rgb.rows), 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_ADAM7, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    std::vector<png_bytep> rows(static_cast<std::size_t>(rgb.rows));
    for (int y = 0; y < rgb.rows; ++y) rows[static_cast<std::size_t>(y)] = rgb.ptr(y);
    png_write_image(png, rows.data());
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
}

}  // namespace

void setUp()
{
    char tmpl[] = "/tmp/afm-test-png-XXXXXX";
    TEST_ASSERT_NOT_NULL(mkdtemp(tmpl));
    dir = tmpl;
}
void tearDown() { fs::remove_all(dir); }

void test_a_frame_comes_back_pixel_for_pixel_and_smaller_than_raw()
{
    const cv::Mat f = frame_like(256);
    assert_round_trip(f, "frame 256 px");
    // it compresses: a frame's raw samples are 196608 bytes
    TEST_ASSERT_LESS_THAN_UINT64(60000, afm::encode_png(f).size());
}

void test_each_kind_it_takes_comes_back()
{
    assert_round_trip(noise(17, 23, CV_8UC1, 1), "grey");
    assert_round_trip(noise(17, 23, CV_8UC3, 2), "BGR");
    assert_round_trip(noise(17, 23, CV_8UC4, 3), "BGRA");
}

// The channels' order: blue stays blue (BGR in memory, RGB in the file:
// libpng hands OpenCV RGB, which it turns back to BGR).
void test_blue_is_blue_when_read_back()
{
    const cv::Mat blue(4, 4, CV_8UC3, cv::Scalar(255, 0, 0));
    assert_round_trip(blue, "blue");
    const cv::Mat back = cv::imread(dir + "/x.png", cv::IMREAD_UNCHANGED);
    TEST_ASSERT_EQUAL_UINT8(255, back.at<cv::Vec3b>(0, 0)[0]);
    TEST_ASSERT_EQUAL_UINT8(0, back.at<cv::Vec3b>(0, 0)[2]);
}

// Edges of a row's filter: one pixel, one column, one row, odd widths.
void test_one_pixel_one_row_one_column_and_odd_widths()
{
    assert_round_trip(cv::Mat(1, 1, CV_8UC3, cv::Scalar(1, 2, 3)), "1 x 1 BGR");
    assert_round_trip(cv::Mat(1, 1, CV_8UC1, cv::Scalar(200)), "1 x 1 grey");
    assert_round_trip(noise(1, 301, CV_8UC3, 4), "one row");
    assert_round_trip(noise(301, 1, CV_8UC4, 5), "one column");
    for (int w : {2, 3, 5, 7, 31, 33, 63, 65}) assert_round_trip(noise(9, w, CV_8UC3, 6 + w), "odd width");
}

// The Sub filter is modulo 256: a 255 next to a 0, and a 0 next to a 255.
void test_samples_that_wrap_round_0_and_255()
{
    cv::Mat m(8, 16, CV_8UC3);
    for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x) m.at<cv::Vec3b>(y, x) = (x + y) % 2 ? cv::Vec3b(255, 0, 255) : cv::Vec3b(0, 255, 0);
    assert_round_trip(m, "checkerboard of 0 and 255");
}

// A view into a larger image: its rows are not contiguous.
void test_a_view_into_a_larger_image()
{
    const cv::Mat big = noise(100, 120, CV_8UC3, 7);
    const cv::Mat roi = big(cv::Rect(13, 7, 51, 40));
    TEST_ASSERT_FALSE(roi.isContinuous());
    assert_round_trip(roi, "view");
}

// Noise does not compress: the deflate's output bound (stored blocks) holds.
void test_noise_that_does_not_compress()
{
    const cv::Mat n = noise(512, 512, CV_8UC4, 8);
    assert_round_trip(n, "512 px noise");
    TEST_ASSERT_GREATER_OR_EQUAL_UINT64(512u * 512u * 4u, afm::encode_png(n).size());
}

// Encoding is the same each time (the thread's buffers are reused).
void test_the_same_image_gives_the_same_bytes_after_a_larger_one()
{
    const cv::Mat small = frame_like(64);
    const std::vector<std::uint8_t> a = afm::encode_png(small);
    (void)afm::encode_png(noise(300, 300, CV_8UC3, 9));
    TEST_ASSERT_TRUE(a == afm::encode_png(small));
}

// ... and whatever was encoded before it, at any size and content: the
// tiny, repetitive images (a 4 x 4 of one colour) where the deflate's
// tables shrink, after images of every size from 1 px to 300 px of noise
// and of flat colour (a run's first scan, then its frames; on CI's CPU
// the thread's reused state once changed a 4 x 4 image's bytes).
void test_the_same_bytes_whatever_came_before()
{
    const cv::Mat tiny[] = {cv::Mat(4, 4, CV_8UC3, cv::Scalar(255, 0, 0)), cv::Mat(1, 3, CV_8UC1, cv::Scalar(0)), frame_like(16)};
    std::vector<std::vector<std::uint8_t>> first;
    for (const cv::Mat &t : tiny) first.push_back(afm::encode_png(t));
    for (int side = 1; side <= 300; side += 13) {
        const cv::Mat before[] = {noise(side, side + 3, CV_8UC4, 100 + side), cv::Mat(side, side, CV_8UC3, cv::Scalar(side % 256, 7, 0))};
        for (const cv::Mat &b : before) {
            (void)afm::encode_png(b);
            for (std::size_t k = 0; k < first.size(); ++k)
                TEST_ASSERT_TRUE_MESSAGE(first[k] == afm::encode_png(tiny[k]), ("image " + std::to_string(k) + " after " +
                                                                                 std::to_string(b.cols) + " x " + std::to_string(b.rows))
                                                                                    .c_str());
        }
    }
}

void test_what_it_does_not_take_is_refused_by_name()
{
    const struct {
        cv::Mat img;
        const char *said;
    } bad[] = {
        {cv::Mat(), "empty"},
        {cv::Mat(4, 4, CV_16UC1, cv::Scalar(0)), "16UC1"},
        {cv::Mat(4, 4, CV_8UC2, cv::Scalar(0)), "8UC2"},
        {cv::Mat(4, 4, CV_32FC3, cv::Scalar(0)), "32FC3"},
        {cv::Mat(1, 70000, CV_8UC1, cv::Scalar(0)), "70000 x 1"},
        {cv::Mat(std::vector<int>{2, 3, 4}, CV_8UC1, cv::Scalar(0)), "3 dimensions"},
    };
    for (const auto &b : bad) {
        std::string said;   // asserted outside the catch (Unity leaves by longjmp)
        try {
            (void)afm::encode_png(b.img);
        } catch (const std::invalid_argument &e) {
            said = e.what();
        }
        TEST_ASSERT_FALSE_MESSAGE(said.empty(), b.said);
        TEST_ASSERT_NOT_EQUAL_MESSAGE(std::string::npos, said.find(b.said), said.c_str());
    }
}

void test_a_folder_that_is_not_there_is_named()
{
    const std::string path = dir + "/gone/frame_00000.png";
    std::string said;
    try {
        afm::write_png(path, frame_like(16));
    } catch (const std::runtime_error &e) {
        said = e.what();
    }
    TEST_ASSERT_FALSE_MESSAGE(said.empty(), "wrote into a missing folder");
    TEST_ASSERT_NOT_EQUAL_MESSAGE(std::string::npos, said.find(path), said.c_str());
    TEST_ASSERT_NOT_EQUAL_MESSAGE(std::string::npos, said.find("No such file"), said.c_str());
}

// A file cut short (here by the process's file-size limit, as a full disk
// would) is named, and removed rather than left half written.
void test_a_file_cut_short_is_named_and_removed()
{
    const std::string path = dir + "/frame_00001.png";
    struct rlimit old {};
    TEST_ASSERT_EQUAL_INT(0, getrlimit(RLIMIT_FSIZE, &old));
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit small = old;
    small.rlim_cur = 1000;
    TEST_ASSERT_EQUAL_INT(0, setrlimit(RLIMIT_FSIZE, &small));
    std::string said;   // what was thrown; asserted once the limit is back
    const cv::Mat img = noise(64, 64, CV_8UC3, 10);
    try {
        afm::write_png(path, img);
    } catch (const std::runtime_error &e) {
        said = e.what();
    }
    TEST_ASSERT_EQUAL_INT(0, setrlimit(RLIMIT_FSIZE, &old));
    signal(SIGXFSZ, SIG_DFL);
    TEST_ASSERT_FALSE_MESSAGE(said.empty(), "a file cut short was not reported");
    TEST_ASSERT_NOT_EQUAL_MESSAGE(std::string::npos, said.find(path), said.c_str());
    TEST_ASSERT_FALSE(fs::exists(path));
}

// read_png gives imread's pixels, grey and colour, for a file written by
// imwrite at each depth and channel count, 1-bit grey, one interlaced
// (Adam7), and a palette image; a file that is not a PNG is an empty image.
void test_read_png_gives_imreads_pixels()
{
    struct Case { cv::Mat img; std::vector<int> params; const char *what; };
    cv::Mat bits = noise(19, 23, CV_8UC1, 11) > 128;
    const Case cases[] = {
        {noise(31, 37, CV_8UC1, 1), {}, "grey 8"},
        {noise(31, 37, CV_16UC1, 2), {}, "grey 16"},
        {noise(31, 37, CV_8UC3, 3), {}, "BGR 8"},
        {noise(31, 37, CV_16UC3, 4), {}, "BGR 16"},
        {noise(31, 37, CV_8UC4, 5), {}, "BGRA 8"},
        {noise(31, 37, CV_16UC4, 6), {}, "BGRA 16"},
        {bits, {cv::IMWRITE_PNG_BILEVEL, 1}, "grey 1 bit"},
        {frame_like(64), {}, "a frame"},
    };
    const std::string path = dir + "/r.png";
    for (const Case &c : cases) {
        TEST_ASSERT_TRUE_MESSAGE(cv::imwrite(path, c.img, c.params), c.what);
        for (const bool colour : {false, true}) {
            const cv::Mat want = cv::imread(path, colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
            const cv::Mat got = afm::read_png(path, colour);
            TEST_ASSERT_EQUAL_INT_MESSAGE(want.type(), got.type(), c.what);
            TEST_ASSERT_EQUAL_INT_MESSAGE(want.cols, got.cols, c.what);
            TEST_ASSERT_EQUAL_INT_MESSAGE(want.rows, got.rows, c.what);
            TEST_ASSERT_EQUAL_DOUBLE_MESSAGE(0.0, cv::norm(want, got, cv::NORM_INF), c.what);
        }
    }
    for (const bool colormap : {true, false}) {
        const std::string p = dir + (colormap ? "/palette.png" : "/interlaced.png");
        write_with_libpng(p, frame_like(40), colormap);
        for (const bool colour : {false, true}) {
            const cv::Mat want = cv::imread(p, colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
            TEST_ASSERT_FALSE_MESSAGE(want.empty(), p.c_str());
            TEST_ASSERT_EQUAL_DOUBLE_MESSAGE(0.0, cv::norm(want, afm::read_png(p, colour), cv::NORM_INF), p.c_str());
        }
    }
    std::ofstream(dir + "/not.png") << "not a PNG";
    TEST_ASSERT_TRUE(afm::read_png(dir + "/not.png", false).empty());
    TEST_ASSERT_TRUE(afm::read_png(dir + "/absent.png", true).empty());
}

// encode_jpeg gives imencode's bytes, colour and grey, at the view's qualities.
void test_encode_jpeg_gives_imencodes_bytes()
{
    const cv::Mat frame = frame_like(96);
    cv::Mat grey;
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    for (const cv::Mat &img : {frame, grey})
        for (int q : {85, 30}) {
            std::vector<unsigned char> want;
            TEST_ASSERT_TRUE(cv::imencode(".jpg", img, want, {cv::IMWRITE_JPEG_QUALITY, q}));
            TEST_ASSERT_TRUE_MESSAGE(want == afm::encode_jpeg(img, q), img.channels() == 3 ? "colour" : "grey");
        }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_a_frame_comes_back_pixel_for_pixel_and_smaller_than_raw);
    RUN_TEST(test_each_kind_it_takes_comes_back);
    RUN_TEST(test_blue_is_blue_when_read_back);
    RUN_TEST(test_one_pixel_one_row_one_column_and_odd_widths);
    RUN_TEST(test_samples_that_wrap_round_0_and_255);
    RUN_TEST(test_a_view_into_a_larger_image);
    RUN_TEST(test_noise_that_does_not_compress);
    RUN_TEST(test_the_same_image_gives_the_same_bytes_after_a_larger_one);
    RUN_TEST(test_the_same_bytes_whatever_came_before);
    RUN_TEST(test_what_it_does_not_take_is_refused_by_name);
    RUN_TEST(test_a_folder_that_is_not_there_is_named);
    RUN_TEST(test_a_file_cut_short_is_named_and_removed);
    RUN_TEST(test_read_png_gives_imreads_pixels);
    RUN_TEST(test_encode_jpeg_gives_imencodes_bytes);
    return UNITY_END();
}
