#include "cv_video.hpp"

#include <dlfcn.h>

#include <mutex>

namespace afm {

namespace {

// The module, loaded once per process; nullptr with *why set when it cannot be.
const CvVideoApi *load_api(std::string *why)
{
    static std::once_flag once;
    static const CvVideoApi *api = nullptr;
    static std::string error;
    std::call_once(once, [] {
        void *h = dlopen(AFM_CV_VIDEO_PLUGIN, RTLD_NOW | RTLD_LOCAL);
        if (!h) {
            error = std::string("cannot load ") + AFM_CV_VIDEO_PLUGIN + ": " + dlerror();
            return;
        }
        api = static_cast<const CvVideoApi *>(dlsym(h, kCvVideoApiSymbol));
        if (!api) error = std::string(AFM_CV_VIDEO_PLUGIN) + ": no symbol " + kCvVideoApiSymbol;
    });
    if (!api) *why = error;
    return api;
}

}  // namespace

bool CvVideo::open(const std::string &path, const char fourcc[4], double fps, int px)
{
    release();
    api_ = load_api(&why_);
    if (!api_) return false;
    writer_ = api_->open(path.c_str(), fourcc, fps, px, px);
    if (!writer_) why_ = "OpenCV's video writer did not open " + path;
    return writer_ != nullptr;
}

void CvVideo::write(const cv::Mat &frame)
{
    if (writer_) api_->write(writer_, frame.data, frame.cols, frame.rows, frame.step[0]);
}

void CvVideo::release()
{
    if (writer_) api_->release(writer_);
    writer_ = nullptr;
}

}  // namespace afm
