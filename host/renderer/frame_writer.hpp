// The display's frames into their files: frames/frame_NNNNN.png and the
// video, in order, on a thread of the renderer's own, allowed on every CPU
// of the run. The PNG files are png_file.hpp's (ISA-L's deflate).
//
// Why (docs/bus.md "The latency model"; ./afm bench render times a frame's
// PNG, video and H.264 encoding): a frame's files cost CPU, the H.264
// encoding more in ffmpeg. On the renderer's thread they kept the renderer
// from taking the bus while they were encoded. The thread may run on any
// CPU of the run, at nice 19, and so does the encoder it starts: they
// take the time the lockstep's processes leave on their CPU and the
// observers leave on theirs, and never hold a process of the lockstep
// off its CPU (normal priority, they took it for about 60 us a block of
// the demo: docs/bus.md, "The lockstep's cost per block").
//
// What stays as it was: the frames' pixels and their order; the renderer
// announces a frame (RENDER_FRAME) when it is composed, before its files
// are written. Nothing is dropped: write() waits while kMaxPending frames
// (64: 12 MB at 256 px) wait to be written (on a machine with no idle CPU
// the renderer, and so the simulator within its frame window, slows down
// to the writer's pace; with 8, the writer's slow spells held the
// renderer 3-5 times a run). The video's encoder starts as the thread
// does, and the renderer waits for it (wait_open()) before it says it is
// ready, so that its start is not in the loop. An error (a file that
// cannot be written) stops the writer and is thrown by the next write()
// or finish(), naming the file.
//
// The video: "mp4" is H.264 through Debian's ffmpeg (video_pipe.hpp), which
// browsers play; the pipe is opened by the writer's thread as it starts
// (so that the encoder runs where the writer may run). Where ffmpeg
// or its libx264 is missing, OpenCV's mp4v writer (which browsers do not
// play) writes video.mp4 instead; video() says which ran and why
// (renderer_report.json "video", so run.json's renderer.video). "avi" is
// OpenCV's MJPG. OpenCV's writer is a module loaded only then
// (cv_video.hpp), not at the renderer's start.
#pragma once

#include <opencv2/core.hpp>
#include <nlohmann/json.hpp>

#include <cstddef>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "cv_video.hpp"
#include "video_pipe.hpp"
#include "worker.hpp"

namespace afm {

class FrameWriter {
public:
    static constexpr std::size_t kMaxPending = 64;

    // out_dir: the run's folder (frames/ in it exists). png: write
    // frames/frame_NNNNN.png. video: "mp4", "avi" or "none" (the scene's
    // outputs.video), opened here at fps for px x px frames. cpus: where the
    // thread may run (empty: the process's CPUs). Throws
    // std::runtime_error when the video cannot be opened (for "mp4": not
    // even with the fallback, tried at once).
    FrameWriter(std::string out_dir, bool png, const std::string &video, double fps, int px, std::vector<int> cpus,
                std::size_t max_pending = kMaxPending);
    // Stops the thread; what is still queued is not written (finish() writes it).
    ~FrameWriter();
    FrameWriter(const FrameWriter &) = delete;
    FrameWriter &operator=(const FrameWriter &) = delete;

    // Queues frame k (its pixels are shared, not copied: the caller does not
    // draw on it again). Waits while kMaxPending frames are queued.
    void write(int k, cv::Mat frame);
    // Waits until the video is open (ffmpeg started, or the fallback chosen);
    // rethrows the error when it could not be. The renderer calls it before
    // it says it is ready, so that the encoder's start (two ffmpeg
    // processes, a noticeable spell of CPU) falls before the
    // loop's first block and not in it.
    void wait_open();
    // Writes what is queued, closes the video; rethrows the writer's error.
    void finish();

    // Frames written, and the writer thread's CPU time (s) in writing them.
    int written() const;
    double cpu_seconds() const;
    // The writes that waited for room, and the wall time (s) they waited:
    // the renderer held while the writer caught up.
    int waits() const;
    double wait_seconds() const;
    // The video as written: file, codec ("h264", "mp4v", "mjpeg"), encoder
    // ("ffmpeg libx264", "opencv"), fallback_why (why not H.264, or null),
    // encoder_cpu_s (ffmpeg's CPU, after finish()); null without a video.
    nlohmann::json video() const;

private:
    using Frame = std::pair<int, cv::Mat>;
    void write_one(int k, const cv::Mat &frame);
    void open_video_once(int px);
    static void yield_to_the_lockstep();
    void close_video(bool throwing);

    const std::string out_;
    const bool png_;
    CvVideo video_;                   // OpenCV's writer, loaded when asked (cv_video.hpp)
    std::string video_path_;          // "" without a video
    double fps_ = 0;
    bool h264_wanted_ = false;        // "mp4": the pipe is tried at the thread's start
    bool video_tried_ = false;
    int px_ = 0;
    VideoPipe pipe_;
    mutable std::mutex m_;            // video_info_
    nlohmann::json video_info_;       // video()
    Worker<Frame> worker_;            // the thread (common/worker.hpp): a frame at a time, max_pending, blocking
};

}  // namespace afm
