// Gwyddion Simple Field (.gsf), the one owner of the format in C++: the
// renderer's scans and displays are written (host/image/display.cpp's
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

// The range of each numeric header field, the one table read_gsf checks
// them against (tests/host/test_gsf.cpp tries every entry at and just past
// each bound). Lengths in m: a map from 0.1 nm (an atom; its pixel pitch
// stays above 1e-14 m) to 1 m across, its corner within 1 m of frame A's
// origin, keeps every figure the simulator derives from it in nm (pitch,
// corner, cell index) finite and exact to far below a pm; XReal = 1e300
// passed as finite and made the pitch infinite, the cell index NaN and
// MeasuredSurface::height read out of bounds.
struct GsfRange {
    const char *key;
    double lo, hi;       // closed: lo <= value <= hi
    bool integer;        // a whole number
    bool required;       // else 0 when missing
};
inline constexpr GsfRange kGsfRanges[] = {
    {"XRes", 2, kGsfMaxRes, true, true},
    {"YRes", 2, kGsfMaxRes, true, true},
    {"XReal", 1e-10, 1.0, false, true},
    {"YReal", 1e-10, 1.0, false, true},
    {"XOffset", -1.0, 1.0, false, false},
    {"YOffset", -1.0, 1.0, false, false},
};

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
// a numeric field outside its kGsfRanges entry, XYUnits or ZUnits other than
// m (when require_metres), data bytes other than 4 XRes YRes, a value not
// finite. The message quotes the file's name and text escaped (text.hpp).
GsfGrid read_gsf(const std::string &path, bool require_metres = true);

}  // namespace afm
