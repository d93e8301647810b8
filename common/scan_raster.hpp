// A scan's raster in time (physics.md 17.2), the one owner of its timing:
// the simulator takes a scan's points where its scanner's creep has put the
// tip at each point's time (sim_afm: PiezoXY::raster_line), and the card's
// de-warp places them by the card's creep model on the same timeline
// (host/image/scan_dewarp.hpp).
//
// The raster starts when the scan is taken (t = 0: the simulator's time
// then), with a step from where the tip is to the first line's first point.
// Line j (0 at the first line) takes [j L, (j + 1) L): its trace, pixel i
// held over [j L + i tau, j L + (i + 1) tau) and taken at the end of that
// interval, then its retrace back over the same pixels in the same time;
// the slow axis holds line j's y the whole line and steps to the next at
// its end. tau = dx / v: a pixel's width at the scan speed v
// (kScanSpeed_nm_per_s), L = 2 n tau for n pixels a line. A 5 um line at
// 20 um/s takes 0.5 s (2 lines a second), a 256-line scan of it 128 s.
#pragma once

#include <cmath>

namespace afm {

// The tip's speed along a line, trace and retrace, nm/s.
constexpr double kScanSpeed_nm_per_s = 20000.0;

struct ScanRaster {
    double pixel_s = 0;   // tau: a pixel's time
    double line_s = 0;    // L: a line's trace and retrace
    // Pixel i of line j is taken at this time after the scan's start, s.
    double pixel_time_s(int i, int j) const { return j * line_s + (i + 1) * pixel_s; }
};

// The raster of lines of n pixels dx_nm apart.
inline ScanRaster scan_raster(double dx_nm, int n)
{
    ScanRaster r;
    r.pixel_s = std::fabs(dx_nm) / kScanSpeed_nm_per_s;
    r.line_s = 2.0 * n * r.pixel_s;
    return r;
}

// The time a whole scan of ny lines of nx pixels dx_nm apart takes, s.
inline double scan_seconds(double dx_nm, int nx, int ny) { return ny * scan_raster(dx_nm, nx).line_s; }

}  // namespace afm
