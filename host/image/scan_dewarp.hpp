// A scan de-warped by the card's scanner model (docs/card.md, "The scans
// de-warped"; physics.md 17.1, 17.2). An open-loop scanner takes each scan
// line's points where its hysteresis and creep put the tip, not at the
// commanded positions the image is drawn at, so a raw scan is stretched,
// sheared and, after a large move, bent. With the card's compensation on
// (firmware.hyst_enable, firmware.creep_enable), the card holds a direct
// hysteresis model of each axis (the one ./afm calib scanner fitted,
// firmware.scanner) and a creep law (firmware.creep_*), as the
// scene-to-card table gives them (card_setup.hpp); ScanDewarp places each
// pixel where those models say the tip was, through the firmware's own
// fw_hyst (fw_hyst.h) and fw_creep (fw_creep.h, fw_creep_follow_pm), never
// the simulator's truth and never a second copy of a model.
//
// The models' state is the card's, followed here (follow): the card steps
// its hysteresis model with every sample's drive; within a block the drive
// moves monotonically towards one set point, and a play's state after a
// monotone stretch depends on its end alone, so each block's last drive
// (FW_STATE's piezo_nm) gives the card's state at the block's end. The
// creep model is stepped once a block (its period) with the direct
// model's output, the position before creep, as the card's feed-forward is
// with its command; a block not seen (lost, or not come yet) holds the
// last position seen. Before any block, the models are at rest at the
// scene's first point, as the card starts.
//
// The raster (raster): the request's pixel centres (x_i = x0 + (i + 1/2) w
// / nx, y_j likewise) on the raster's timeline (common/scan_raster.hpp),
// as sim_afm takes a scan: through copies of the models, the hysteresis to
// the first line, to the line's end and back along the retrace to its
// start, then along each line; the creep model advanced from the state's
// block to the scan's (held), then stepped a period at a time along the
// raster, its input the line's start on the fast axis and the line on the
// slow. Each pixel is placed at its hysteresis output plus its line's
// creep at the line's time. A scan is aimed by the card's inverse model (aim:
// fw_hyst_inverse_pm, the card's own compensation, its plays kept in step
// with the direct model's by follow): the rectangle to command so that the
// model puts the raster's first and last pixel of each axis on the
// square's, then corrected through the raster (the line's first excursion,
// the creep) for a few rounds: each edge moved by what the models put its
// pixels off the square's, their mean over the lines (x) or the line (y).
// The de-warped image is the scan resampled at the asked square's grid
// (bilinear, each grid point found in the raster by alternate searches
// along its line and its column; lines the creep folded back are taken
// from the later one; past what the scan reached, its edge); a scan not
// aimed is resampled at its commanded grid. Without the card's
// compensation the scan stays as it came.
#pragma once

extern "C" {
#include "fw_creep.h"
#include "fw_hyst.h"
}

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

#include "scan_client.hpp"
#include "scene.hpp"

namespace afm {

// Each pixel's position where the card's model puts the tip, frame A, nm:
// pixel i of line j (0 at the bottom) at x(i, j), y(i, j).
struct RasterPositions {
    int nx = 0, ny = 0;
    std::vector<double> x_nm, y_nm;   // [j * nx + i]
    double x(int i, int j) const { return x_nm[static_cast<std::size_t>(j) * nx + i]; }
    double y(int i, int j) const { return y_nm[static_cast<std::size_t>(j) * nx + i]; }
};

class ScanDewarp {
public:
    ScanDewarp() = default;                 // inactive: scans stay as they came
    explicit ScanDewarp(const Scene &s);    // active when the scene's card compensates the hysteresis or the creep

    bool active() const { return hyst_ || creep_; }
    // The card's drive at the end of block `seq` (FW_STATE's piezo_nm);
    // a block not past the last followed is ignored.
    void follow(int64_t seq, int64_t utime, double drive_x_nm, double drive_y_nm);
    int64_t state_seq() const { return seq_; }       // the last block followed, -1 before any
    int64_t state_utime() const { return utime_; }   // its end, simulated us (0 before any)

    // Where the card's model puts each pixel of a scan of r taken at
    // scan_utime (simulated us: the block end after which it was taken; at
    // or before the state's: taken then).
    RasterPositions raster(const ScanRegion &r, int64_t scan_utime = 0) const;
    // The rectangle to command (as many pixels) so that the card's model
    // puts a scan taken now on `want`'s pixels (header). Inactive, or
    // fewer than 2 pixels on an axis: want.
    ScanRegion aim(const ScanRegion &want) const;
    // The scan (CV_32F, taken.ny x taken.nx, row 0 at the top), commanded
    // over `taken` and taken at scan_utime, resampled at `grid`'s pixels
    // (as many as taken's); *shift_nm (may be null): the largest distance
    // along either axis between a pixel's commanded and modelled position.
    // Inactive: a copy.
    cv::Mat apply(const cv::Mat &scan, const ScanRegion &taken, const ScanRegion &grid, double *shift_nm = nullptr,
                  int64_t scan_utime = 0) const;
    // The same resampled at its commanded grid (a scan not aimed).
    cv::Mat apply(const cv::Mat &scan, const ScanRegion &r, double *shift_nm = nullptr) const { return apply(scan, r, r, shift_nm); }

private:
    void raster_creep(const ScanRegion &r, int64_t scan_utime, const std::vector<double> &trace, const std::vector<double> &lines,
                      RasterPositions *out) const;

    bool hyst_ = false, creep_ = false;
    fw_hyst_t axis_[2]{};     // the card's hysteresis models, x and y, in the state followed (the direct's and the inverse's plays)
    fw_creep_t creep_axis_[2]{};   // the card's creep models, x and y, in the state followed
    int64_t period_us_ = 1000;     // the creep model's period: the card's block
    double last_nm_[2] = {0, 0};   // the position before creep at the last block followed
    int64_t seq_ = -1, utime_ = 0;
};

}  // namespace afm
