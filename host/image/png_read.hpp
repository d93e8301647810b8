// A PNG file read into an OpenCV image through libpng itself (Debian's
// libpng-dev), without OpenCV's imgcodecs: the operator and the renderer
// read the planner's target masks (objects.targets.png) and the renderer
// its own frames back for the contact sheet, and imgcodecs alone brings
// 139 shared libraries (GDAL, GDCM, OpenEXR) into each process's start.
//
// Contract: the pixels are those cv::imread gives for the same file and
// flag (IMREAD_GRAYSCALE for `colour` false, IMREAD_COLOR for true), as
// libpng is asked for the same transforms OpenCV's PNG decoder asks: 16-bit
// samples stripped to 8, alpha stripped, a palette and 1-, 2- and 4-bit
// grey expanded to 8 bits, then BGR order (colour from colour), grey
// replicated (colour from grey) or libpng's grey from colour with the
// weights 0.299 R and 0.587 G (grey from colour); interlaced files are
// read whole. An EXIF orientation (which imread would apply) is not read:
// the bench's PNGs carry none. tests/host/test_png_file.cpp compares
// every colour type and depth with imread.
//
// Errors: a file that cannot be opened or is not a PNG libpng reads gives
// an empty image, as imread does; the caller names the file and its key.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace afm {

// The PNG at path as CV_8UC3 (BGR) when colour, else CV_8UC1; empty when
// it cannot be read.
cv::Mat read_png(const std::string &path, bool colour);

}  // namespace afm
