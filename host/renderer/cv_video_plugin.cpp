// afm_cv_video.so: OpenCV's cv::VideoWriter behind the C table of
// cv_video.hpp, which the renderer loads (dlopen) only when a run asks for
// OpenCV's video (avi, or mp4v where ffmpeg's H.264 is missing). The one
// file of the project that links OpenCV's videoio for a run.
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "cv_video.hpp"

namespace {

void *open_writer(const char *path, const char *fourcc, double fps, int width_px, int height_px)
{
    auto *w = new cv::VideoWriter(path, cv::VideoWriter::fourcc(fourcc[0], fourcc[1], fourcc[2], fourcc[3]), fps,
                                  cv::Size(width_px, height_px));
    if (w->isOpened()) return w;
    delete w;
    return nullptr;
}

void write_frame(void *writer, const unsigned char *bgr, int width_px, int height_px, size_t step_bytes)
{
    const cv::Mat frame(height_px, width_px, CV_8UC3, const_cast<unsigned char *>(bgr), step_bytes);
    static_cast<cv::VideoWriter *>(writer)->write(frame);
}

void release_writer(void *writer)
{
    delete static_cast<cv::VideoWriter *>(writer);
}

}  // namespace

extern "C" __attribute__((visibility("default"))) const afm::CvVideoApi afm_cv_video_api = {open_writer, write_frame,
                                                                                             release_writer};
