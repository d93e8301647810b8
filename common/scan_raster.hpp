// A scan's raster in time (physics.md 17.2), the one owner of its timing:
// the simulator takes each scan line where its scanner's creep has put the
// tip by the line's time (sim_afm: PiezoXY::raster_line), and the card's
// de-warp places it by the card's creep model at the same time
// (host/image/scan_dewarp.hpp).
//
// The raster starts when the scan is taken (t = 0: the simulator's time
// then), with a step from where the tip is to the first line's first point.
// Line j (0 at the first line) takes [j L, (j + 1) L): its trace across the
// line and its retrace back to the line's start, at the scan speed v
// (kScanSpeed_nm_per_s), L = 2 n dx / v for n pixels dx apart; the slow
// axis holds line j's y the whole line and steps to the next at its end.
// As the creep sees it, a line is taken at once at its trace's middle,
// j L + L / 4 (line_time_s), and its trace and retrace leave the fast axis
// where the line started: the creep of a line's points is that of the
// steps before the line (the tip's before the scan, the step to the scan's
// start, the slow axis's lines), none of the trace's own ramp. A 5 um line
// at 20 um/s takes 0.5 s (2 lines a second), a 256-line scan of it 128 s.
#pragma once

#include <cmath>

namespace afm {

// The tip's speed along a line, trace and retrace, nm/s.
constexpr double kScanSpeed_nm_per_s = 20000.0;

struct ScanRaster {
    double line_s = 0;   // L: a line's trace and retrace
    // Line j is taken (as the creep sees it) at this time after the scan's start, s.
    double line_time_s(int j) const { return (j + 0.25) * line_s; }
};

// The raster of lines of n pixels dx_nm apart.
inline ScanRaster scan_raster(double dx_nm, int n)
{
    ScanRaster r;
    r.line_s = 2.0 * n * std::fabs(dx_nm) / kScanSpeed_nm_per_s;
    return r;
}

// The time a whole scan of ny lines of nx pixels dx_nm apart takes, s.
inline double scan_seconds(double dx_nm, int nx, int ny) { return ny * scan_raster(dx_nm, nx).line_s; }

}  // namespace afm
