// OpenCV's video writer (cv::VideoWriter: "avi" as MJPG, and video.mp4 as
// mp4v where ffmpeg's H.264 is missing; frame_writer.hpp), loaded only when
// a run asks for one of those. OpenCV's videoio brings about 240 shared
// libraries (libavcodec, GStreamer, and imgcodecs' GDAL, GDCM, OpenEXR) into
// a process's start: 0.3 s of CPU the renderer paid at every run, frames or
// not. So the writer lives in a module of the project's own,
// afm_cv_video.so (cv_video_plugin.cpp, built beside the renderer, its path
// compiled in: AFM_CV_VIDEO_PLUGIN), which the renderer opens (dlopen) the
// first time open() is called; a run without such a video never loads it.
//
// Contract:
//   - open(path, fourcc, fps, px) opens a px x px colour video at path with
//     the codec fourcc ("MJPG", "mp4v") as cv::VideoWriter::open does;
//     false when the writer cannot be opened, and when the module cannot be
//     loaded (why() says which, with dlerror's text).
//   - write(frame) adds a CV_8UC3 frame of the opened size (as
//     cv::VideoWriter::write: nothing when not open).
//   - release() closes the file (the destructor too). The module stays
//     loaded for the process's life.
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <string>

namespace afm {

// The module's interface (C, so that dlsym finds it by name): one table.
extern "C" {
struct CvVideoApi {
    void *(*open)(const char *path, const char *fourcc, double fps, int width_px, int height_px);
    void (*write)(void *writer, const unsigned char *bgr, int width_px, int height_px, size_t step_bytes);
    void (*release)(void *writer);
};
}
// The symbol the module exports: a `const CvVideoApi`.
constexpr const char *kCvVideoApiSymbol = "afm_cv_video_api";

class CvVideo {
public:
    CvVideo() = default;
    ~CvVideo() { release(); }
    CvVideo(const CvVideo &) = delete;
    CvVideo &operator=(const CvVideo &) = delete;

    bool open(const std::string &path, const char fourcc[4], double fps, int px);
    void write(const cv::Mat &frame);
    void release();
    bool isOpened() const { return writer_ != nullptr; }
    const std::string &why() const { return why_; }

private:
    const CvVideoApi *api_ = nullptr;
    void *writer_ = nullptr;
    std::string why_;
};

}  // namespace afm
