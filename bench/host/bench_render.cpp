// ./afm bench render: ms per frame of the display's local update against a
// full redraw, at 256, 512 and 1024 pixels square. A benchmark: it prints a
// table and asserts nothing.
//
// Scene: the default 5 um field with 20 latex particles (100 nm); per frame
// one particle moves by 2 nm (a push) and the frame is composed as the
// renderer composes it (renderer/frame_overlay.hpp: axes, markers and ids,
// the lever and F_x's blind cones, the force glyph and legend, the hand's
// gauge, the colour bar), and, beside it, Display::frame's plainer one.
// Encoding (PNG, video) is timed separately: the run's PNG file
// (png_file.hpp) beside OpenCV's imwrite; the run's H.264 (ffmpeg through
// video_pipe.hpp: the pipe's cost to the writer, and ffmpeg's own CPU)
// beside OpenCV's mp4v.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "afm/fw_state_t.hpp"
#include "command_line.hpp"
#include "display.hpp"
#include "frame_overlay.hpp"
#include "png_file.hpp"
#include "video_pipe.hpp"

namespace {

double ms_since(std::chrono::steady_clock::time_point t0)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

struct Row { int px; double local_ms, full_ms, compose_ms, plain_ms, png_ms, imwrite_ms, video_ms, h264_ms, h264_cpu_ms; };

// The H.264 pipe: ms per frame to hand it over, and ffmpeg's CPU ms per frame (-1: no ffmpeg).
void measure_h264(const cv::Mat &frame, int n, const std::string &path, Row *r)
{
    afm::VideoPipe pipe;
    std::string why;
    r->h264_ms = r->h264_cpu_ms = -1;
    if (!pipe.open(path, frame.cols, frame.rows, 25, &why)) return;
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < n; ++k) pipe.write(frame);
    r->h264_ms = ms_since(t0) / n;
    if (pipe.close(&why)) r->h264_cpu_ms = 1e3 * pipe.child_cpu_seconds() / n;
}

Row measure(int px, int frames)
{
    const afm::Field f{-2500, -2500, 5000, px};
    const afm::TipShape tip{10, 20};
    std::vector<afm::DisplayObject> objs;
    for (int i = 0; i < 20; ++i) objs.push_back({i, -2000.0 + 200 * i, -1800.0 + 180 * (i % 7), 50});
    // The "scan": the same objects drawn once, as the simulator's scan would show them.
    afm::Display scanner(f, tip);
    scanner.start(cv::Mat::zeros(px, px, CV_32F), afm::DisplayModel{});
    scanner.redraw(objs);
    const cv::Mat scan = scanner.height().clone();

    afm::Display local(f, tip), full(f, tip);
    local.start(scan, objs);
    full.start(scan, objs);
    afm::Overlay o;   // pushing, with a hand: every part of the overlay drawn
    o.tip_nm[1] = -1900;
    o.force_nN[0] = 0.3;
    o.force_nN[1] = 1.5;
    o.force_nN[2] = 5;
    o.flags = afm::fw_state_t::FLAG_CONTACT;
    o.hand_N[1] = 0.03;
    o.hand_scale_N = 0.08;
    const afm::LeverView lever = afm::lever_view(270);
    afm::DisplayModel model{objs, {}, {}};
    Row r{px, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < frames; ++k) {
        objs[k % objs.size()].y_nm += 2;
        local.update(objs);
    }
    r.local_ms = ms_since(t0) / frames;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < frames; ++k) {
        objs[k % objs.size()].y_nm += 2;
        full.redraw(objs);
    }
    r.full_ms = ms_since(t0) / frames;
    t0 = std::chrono::steady_clock::now();
    cv::Mat frame;
    for (int k = 0; k < frames; ++k) {
        o.t_s = k * 0.04;
        frame = afm::compose_frame(local, model, o, lever);
    }
    r.compose_ms = ms_since(t0) / frames;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < frames; ++k) (void)local.frame(o);
    r.plain_ms = ms_since(t0) / frames;
    const std::string tmp = "/tmp/afm-bench-render";
    const int enc = std::max(5, frames / 10);
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < enc; ++k) afm::write_png(tmp + ".png", frame);
    r.png_ms = ms_since(t0) / enc;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < enc; ++k) cv::imwrite(tmp + ".png", frame);
    r.imwrite_ms = ms_since(t0) / enc;
    cv::VideoWriter vw(tmp + ".mp4", cv::VideoWriter::fourcc('m', 'p', '4', 'v'), 25, cv::Size(px, px));
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < enc; ++k) vw.write(frame);
    vw.release();
    r.video_ms = ms_since(t0) / enc;
    measure_h264(frame, enc, tmp + "-h264.mp4", &r);
    std::remove((tmp + "-h264.mp4").c_str());
    std::remove((tmp + ".png").c_str());
    std::remove((tmp + ".mp4").c_str());
    return r;
}

struct Options {
    int frames = 200;
};

const afm::cli::CommandLine<Options> kCommandLine = {
    "bench_render",
    "usage: bench_render [FRAMES]\n"
    "  The display's cost per frame at 256, 512 and 1024 px: FRAMES frames per size\n"
    "  (default 200, at least 10).\n",
    {{{"FRAMES", nullptr, nullptr, nullptr}, afm::cli::whole(&Options::frames, 10, 1000000, "a number of frames")}}};

}  // namespace

int main(int argc, char **argv)
{
    Options o;
    if (const int code = afm::cli::read_command_line(kCommandLine, argc, argv, &o); code >= 0) return code;
    const int frames = o.frames;
    std::printf("display cost per frame, 20 particles in 5 um, one moved per frame (%d frames per size)\n\n", frames);
    std::printf("| px   | local update ms | full redraw ms | full/local | compose ms | plain compose ms | frames/s (local+compose) | PNG ms | imwrite PNG ms | mp4v ms | H.264 pipe ms | ffmpeg CPU ms |\n");
    std::printf("|------|-----------------|----------------|------------|------------|------------------|--------------------------|--------|----------------|---------|---------------|---------------|\n");
    for (int px : {256, 512, 1024}) {
        const Row r = measure(px, frames);
        std::printf("| %4d | %15.4f | %14.3f | %10.1f | %10.3f | %16.3f | %24.0f | %6.2f | %14.2f | %7.2f | %13.2f | %13.2f |\n", r.px,
                    r.local_ms, r.full_ms, r.full_ms / r.local_ms, r.compose_ms, r.plain_ms, 1e3 / (r.local_ms + r.compose_ms), r.png_ms,
                    r.imwrite_ms, r.video_ms, r.h264_ms, r.h264_cpu_ms);
    }
    std::printf("\ncompose: the renderer's frame (frame_overlay.hpp); plain: Display::frame's, without axes, ids, lever or legend\n");
    std::printf("H.264: the writer's cost to hand a frame to ffmpeg, and ffmpeg's CPU per frame (-1: no ffmpeg with libx264)\n");
    std::printf("PNG: the run's frame file (host/png_file.hpp, ISA-L's deflate); imwrite PNG: OpenCV's, for comparison\n");
    std::printf("targets: local update >= 10x cheaper than full redraw; >= 300 frames/s at 512 px\n");
    return 0;
}
