#include "frame_writer.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "png_file.hpp"

namespace afm {

FrameWriter::FrameWriter(std::string out_dir, bool png, const std::string &video, double fps, int px, std::vector<int> cpus,
                         std::size_t max_pending)
    : out_(std::move(out_dir)), png_(png), fps_(fps), px_(px),
      worker_({max_pending > 0 ? max_pending : 1, Full::block, 0, 1},
              [this](std::vector<Frame> &one, int64_t) { write_one(one.front().first, one.front().second); })
{
    if (video != "none") {
        const bool mp4 = video == "mp4";
        const std::string path = out_ + (mp4 ? "/video.mp4" : "/video.avi");
        video_path_ = path;
        if (mp4) {
            // H.264 is tried at the thread's start, on the writer's thread; a
            // file that cannot be made is refused now, as OpenCV's would be.
            if (!std::ofstream(path, std::ios::binary)) throw std::runtime_error("cannot open a video writer for " + path);
            h264_wanted_ = true;
        } else {
            if (!video_.open(path, "MJPG", fps, px)) throw std::runtime_error("cannot open a video writer for " + path + ": " + video_.why());
            video_tried_ = true;
            video_info_ = {{"file", "video.avi"}, {"codec", "mjpeg"}, {"encoder", "opencv"}, {"fallback_why", nullptr}};
        }
    }
    // the encoder starts while the run does, not at the first frame
    worker_.start(std::move(cpus), "renderer: the frame writer", [this] {
        yield_to_the_lockstep();
        open_video_once(px_);
    });
}

// The writer's thread, and the encoder it starts (a child keeps its
// parent's nice value), at nice 19: on the lockstep's CPU they take only the
// time its processes leave, and a datagram that wakes one of them puts it
// back on the CPU at once (docs/bus.md, "The lockstep's cost per block").
// Not SCHED_IDLE: under other runs' load (a sweep's points side by side)
// its share, a fifth of nice 19's, let 64 queued frames take a minute to
// write. A nice value refused is said on stderr, and the thread runs as it was.
void FrameWriter::yield_to_the_lockstep()
{
    if (setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 19) != 0)
        std::fprintf(stderr, "renderer: the frame writer stays at its priority: nice 19 refused: %s\n", std::strerror(errno));
}

// At the thread's start: H.264 through ffmpeg, or OpenCV's mp4v with the reason.
void FrameWriter::open_video_once(int px)
{
    if (video_tried_ || !h264_wanted_) return;
    video_tried_ = true;
    std::string why;
    if (pipe_.open(video_path_, px, px, fps_, &why)) {
        std::lock_guard<std::mutex> l(m_);
        video_info_ = {{"file", "video.mp4"}, {"codec", "h264"}, {"encoder", "ffmpeg libx264"}, {"fallback_why", nullptr}};
        return;
    }
    std::fprintf(stderr, "renderer: video.mp4 as OpenCV's mp4v, which browsers do not play: %s\n", why.c_str());
    if (!video_.open(video_path_, "mp4v", fps_, px))
        throw std::runtime_error("cannot open a video writer for " + video_path_ + ": " + video_.why());
    std::lock_guard<std::mutex> l(m_);
    video_info_ = {{"file", "video.mp4"}, {"codec", "mp4v"}, {"encoder", "opencv"}, {"fallback_why", why}};
}

// Closes the video; with `throwing`, an encoder that failed is an error.
void FrameWriter::close_video(bool throwing)
{
    video_.release();
    if (!pipe_.is_open()) return;
    std::string why;
    const bool ok = pipe_.close(&why);
    {
        std::lock_guard<std::mutex> l(m_);
        video_info_["encoder_cpu_s"] = pipe_.child_cpu_seconds();
    }
    if (!ok && throwing) throw std::runtime_error(video_path_ + ": " + why);
}

FrameWriter::~FrameWriter()
{
    worker_.stop(Stop::discard);
    // Stopped before its first frame (a run interrupted at its start): a
    // video without a frame does not open, so none is left that claims one.
    close_video(false);
    if (!video_path_.empty() && written() == 0) std::remove(video_path_.c_str());
}

void FrameWriter::write(int k, cv::Mat frame)
{
    worker_.post({k, std::move(frame)});
}

void FrameWriter::wait_open()
{
    worker_.wait_started();
}

void FrameWriter::finish()
{
    worker_.flush();
    close_video(true);
}

nlohmann::json FrameWriter::video() const
{
    std::lock_guard<std::mutex> l(m_);
    return video_info_;
}

int FrameWriter::written() const
{
    return static_cast<int>(worker_.counts().handled);
}

int FrameWriter::waits() const
{
    return static_cast<int>(worker_.counts().waits);
}

double FrameWriter::wait_seconds() const
{
    return worker_.counts().wait_s;
}

double FrameWriter::cpu_seconds() const
{
    return worker_.counts().cpu_s;
}

void FrameWriter::write_one(int k, const cv::Mat &frame)
{
    if (png_) {
        char name[64];
        std::snprintf(name, sizeof name, "/frames/frame_%05d.png", k);
        write_png(out_ + name, frame);
    }
    if (pipe_.is_open() && !pipe_.write(frame)) {
        std::string why;
        pipe_.close(&why);
        throw std::runtime_error(video_path_ + ": the encoder took no more frames (" + why + ")");
    }
    if (video_.isOpened()) video_.write(frame);
}

}  // namespace afm
