// A frame as a JPEG in memory (the page's VIEW_FRAME, view_frames.hpp)
// through libjpeg itself (Debian's libjpeg62-turbo-dev), without OpenCV's
// imgcodecs, which brings 139 shared libraries into the renderer's start.
//
// Contract: the encoder is set as OpenCV's cv::imencode(".jpg", frame,
// {IMWRITE_JPEG_QUALITY, q}) sets it: libjpeg's defaults (baseline, 4:2:0,
// no optimised tables, JFIF), the quality scaled to baseline tables
// (jpeg_set_quality(q, TRUE)); a BGR image (CV_8UC3) as colour, a grey one
// (CV_8UC1) as grey. tests/host/test_png_file.cpp compares the bytes with
// imencode's.
//
// Errors: another type, an empty image or libjpeg's own error throws
// std::invalid_argument / std::runtime_error naming it.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

namespace afm {

// The JPEG file's bytes of img at quality (1-100).
std::vector<unsigned char> encode_jpeg(const cv::Mat &img, int quality);

}  // namespace afm
