// PNG files of the display's images: the frames (frames/frame_NNNNN.png),
// the first scan, the fidelity difference and the contact sheet.
//
// Why not cv::imwrite (docs/bus.md "The latency model"): a frame's PNG was
// the largest share of the renderer's CPU, and on a machine whose two CPUs
// the lockstep and its observers keep busy, the observers' CPU is the
// lockstep's too. OpenCV's PNG is libpng with zlib at level 1 (most of its
// time zlib's deflate); libdeflate and stb_image_write were no faster.
// Here the deflate is ISA-L's (Intel's Intelligent Storage Acceleration
// Library, Debian's libisal-dev) at its level 1, faster than zlib's on
// these frames (./afm bench render times both), and its output a little
// smaller. The container around it (the signature, IHDR,
// one IDAT, IEND, each chunk's CRC-32 from zlib) is what the PNG
// specification (ISO/IEC 15948) asks of a non-interlaced 8-bit image.
//
// What a file holds: the image's pixels exactly (lossless; any PNG reader
// gives them back: tests/host/test_png_file.cpp reads them with libpng
// through OpenCV, tests/e2e/test_end_to_end.py a run's with Pillow), 8 bits
// a sample, grey (CV_8UC1), RGB
// (CV_8UC3, OpenCV's BGR order turned into PNG's RGB) or RGBA (CV_8UC4,
// from BGRA); each row with filter type 1 (Sub, as OpenCV's default uses);
// no ancillary chunks. The bytes differ from imwrite's (another deflate);
// the pixels do not.
//
// Ranges and errors: an empty image, one of more than 2 dimensions, another
// depth or channel count, a side above 65535 px or more than 1e9 samples is
// refused (std::invalid_argument, naming what it got). A file that cannot
// be written throws std::runtime_error naming the file and the system's
// reason, and leaves no partial file behind.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace afm {

// The PNG file's bytes for img (see above for what img may be).
std::vector<std::uint8_t> encode_png(const cv::Mat &img);

// encode_png(img) written to path (created or truncated, mode 0644).
void write_png(const std::string &path, const cv::Mat &img);

}  // namespace afm
