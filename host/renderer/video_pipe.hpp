// The video a browser plays: raw BGR frames piped into Debian's ffmpeg,
// which encodes them as H.264 (libx264, yuv420p) in an MP4 whose index
// comes first (-movflags +faststart), so that a page can play it while it
// loads. OpenCV's own MP4 writer (mp4v, MPEG-4 part 2) makes files no
// browser plays (Chromium: MEDIA_ERR_SRC_NOT_SUPPORTED); frame_writer.hpp
// falls back to it when this pipe cannot be opened, and says so.
//
// Contract:
//   - ffmpeg is `$AFM_FFMPEG` if set, else `ffmpeg` on PATH; open() asks it
//     first whether it has libx264 (`-h encoder=libx264`) and returns false,
//     with the reason, when it is absent, lacks the encoder or cannot be
//     started. Nothing is written then.
//   - open() returns once ffmpeg waits for its first frame (blocked reading
//     its stdin, /proc/PID/syscall; at most 2 s), so that its start (0.1 s
//     of CPU loading its libraries) is over before the renderer says it is
//     ready and not in the loop's first blocks.
//   - libx264 on one thread (-threads 1): the same video on every machine
//     (its default, threads by the CPU count, changes the bytes from one
//     machine to another) and less CPU a frame (a 512-px frame of the demo:
//     4.0 ms on 3 threads, 3.3 ms on one, docs/bus.md).
//   - ffmpeg inherits the CPUs and the scheduling policy of the thread that
//     calls open() (the frame writer's: every CPU of the run, nice 19)
//     and writes its errors to our stderr
//     (the renderer's log). It runs in a process group of its own, so a
//     signal to the renderer's group does not cut the file short: it ends
//     when its input ends (close(), or the renderer's death).
//   - write() sends one frame (CV_8UC3, the size given to open()); false when
//     ffmpeg is gone. SIGPIPE is blocked on the calling thread first, so a
//     dead encoder is an error, not a signal.
//   - close() ends the input and waits for ffmpeg; false (with its exit
//     status) unless it exited 0. The destructor closes and waits too.
//   - child_cpu_seconds(): ffmpeg's user + system CPU, once it has exited.
#pragma once

#include <opencv2/core.hpp>

#include <sys/types.h>

#include <string>

namespace afm {

class VideoPipe {
public:
    VideoPipe() = default;
    ~VideoPipe();
    VideoPipe(const VideoPipe &) = delete;
    VideoPipe &operator=(const VideoPipe &) = delete;

    // The ffmpeg this pipe runs: $AFM_FFMPEG, or "ffmpeg" (found on PATH).
    static std::string program();

    bool open(const std::string &path, int width_px, int height_px, double fps, std::string *why);
    bool write(const cv::Mat &frame);
    bool close(std::string *why);
    bool is_open() const { return pid_ > 0; }
    double child_cpu_seconds() const { return child_cpu_s_; }

private:
    pid_t pid_ = -1;
    int fd_ = -1;
    int width_ = 0, height_ = 0;
    double child_cpu_s_ = 0;
};

}  // namespace afm
