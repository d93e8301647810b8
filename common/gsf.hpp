// Gwyddion Simple Field (.gsf), the one owner of the format in C++: the
// renderer's scans and displays are written (host_bridge/image/display.cpp's
// write_gsf turns its images into a GsfGrid and calls write_gsf_grid here),
// and a scene's measured substrate (sample.substrate: {gsf: FILE}) is read.
//
// The format: a text header, "Gwyddion Simple Field 1.0\n" then "Key = value"
// lines; NUL padding to a multiple of 4 bytes (at least one NUL); then XRes *
// YRes little-endian float32 values, row by row from the top (row 0 at the
// largest y, YOffset + YReal; column 0 at XOffset). Pixel centres: x =
// XOffset + (c + 0.5) XReal / XRes, y = YOffset + YReal - (r + 0.5) YReal / YRes
// (analysis/gsf.py reads the same way, independently).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace afm {

inline constexpr int kGsfMaxRes = 4096;   // read_gsf refuses more columns or rows

struct GsfGrid {
    int xres = 0, yres = 0;
    double xreal_m = 0, yreal_m = 0;      // the grid's physical size, XYUnits (m)
    double xoff_m = 0, yoff_m = 0;        // its lower-left corner (frame A, m)
    std::string xy_units = "m", z_units = "m", title;
    std::vector<std::pair<std::string, std::string>> keys;   // extra header lines, in order
    std::vector<float> values;            // yres rows of xres, row 0 at the top, in z_units
};

// Writes g to path. Extra keys without spaces, '=' or line breaks, values
// without line breaks. Returns false (and sets *err, naming the file) on failure.
bool write_gsf_grid(const std::string &path, const GsfGrid &g, std::string *err);

// Reads path; throws std::runtime_error naming the file, the header field and
// the value on any fault: not a regular file, no magic line, no NUL padding,
// XRes / YRes not integers in [2, kGsfMaxRes], XReal / YReal not finite and
// positive, offsets not finite, XYUnits or ZUnits other than m (when
// require_metres), data bytes other than 4 XRes YRes, a value not finite.
GsfGrid read_gsf(const std::string &path, bool require_metres = true);

}  // namespace afm
