#include "frame_writer.hpp"

#include <time.h>

#include <cstdio>
#include <stdexcept>

#include "placement.hpp"
#include "png_file.hpp"

namespace afm {

namespace {

double thread_cpu_seconds()
{
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

}  // namespace

FrameWriter::FrameWriter(std::string out_dir, bool png, const std::string &video, double fps, int px, std::vector<int> cpus,
                         std::size_t max_pending)
    : out_(std::move(out_dir)), png_(png), max_pending_(max_pending > 0 ? max_pending : 1)
{
    if (video != "none") {
        const bool mp4 = video == "mp4";
        const std::string path = out_ + (mp4 ? "/video.mp4" : "/video.avi");
        video_path_ = path;
        video_.open(path, mp4 ? cv::VideoWriter::fourcc('m', 'p', '4', 'v') : cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps,
                    cv::Size(px, px));
        if (!video_.isOpened()) throw std::runtime_error("cannot open a video writer for " + path);
    }
    thread_ = start_pinned(std::move(cpus), "renderer: the frame writer", [this] { run(); });
}

FrameWriter::~FrameWriter()
{
    {
        std::lock_guard<std::mutex> l(m_);
        stop_ = true;
        queue_.clear();
    }
    work_.notify_one();
    room_.notify_all();
    if (thread_.joinable()) thread_.join();
    // Stopped before its first frame (a run interrupted at its start): a
    // video without a frame does not open, so none is left that claims one.
    video_.release();
    if (!video_path_.empty() && written_ == 0) std::remove(video_path_.c_str());
}

void FrameWriter::write(int k, cv::Mat frame)
{
    std::unique_lock<std::mutex> l(m_);
    room_.wait(l, [&] { return queue_.size() < max_pending_ || error_; });
    if (error_) std::rethrow_exception(error_);
    queue_.emplace_back(k, std::move(frame));
    work_.notify_one();
}

void FrameWriter::finish()
{
    std::unique_lock<std::mutex> l(m_);
    room_.wait(l, [&] { return (queue_.empty() && !busy_) || error_; });
    if (error_) std::rethrow_exception(error_);
    l.unlock();
    video_.release();
}

int FrameWriter::written() const
{
    std::lock_guard<std::mutex> l(m_);
    return written_;
}

double FrameWriter::cpu_seconds() const
{
    std::lock_guard<std::mutex> l(m_);
    return cpu_s_;
}

void FrameWriter::write_one(int k, const cv::Mat &frame)
{
    if (png_) {
        char name[64];
        std::snprintf(name, sizeof name, "/frames/frame_%05d.png", k);
        write_png(out_ + name, frame);
    }
    if (video_.isOpened()) video_.write(frame);
}

void FrameWriter::run()
{
    std::unique_lock<std::mutex> l(m_);
    while (true) {
        work_.wait(l, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        std::pair<int, cv::Mat> f = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
        room_.notify_all();
        l.unlock();
        const double t0 = thread_cpu_seconds();
        std::exception_ptr err;
        try {
            write_one(f.first, f.second);
        } catch (...) {
            err = std::current_exception();
        }
        const double dt = thread_cpu_seconds() - t0;
        l.lock();
        busy_ = false;
        cpu_s_ += dt;
        if (err) {
            error_ = err;
            queue_.clear();
            room_.notify_all();
            return;
        }
        ++written_;
        room_.notify_all();
    }
}

}  // namespace afm
