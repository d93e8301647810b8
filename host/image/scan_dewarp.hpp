// A scan de-warped by the card's scanner model (docs/card.md, "The
// scanner's compensation"; physics.md 17.1). An open-loop scanner takes
// each scan line's points where its hysteresis puts the tip, not at the
// commanded positions the image is drawn at, so a raw scan is stretched and
// sheared. With the card's hysteresis compensation on
// (firmware.hyst_enable), the card holds a direct model of each axis, the
// one ./afm calib scanner fitted (firmware.scanner, as the scene-to-card
// table gives it: card_setup.hpp); ScanDewarp places each pixel where that
// model says the tip was, through the firmware's own fw_hyst (fw_hyst.h),
// never the simulator's truth and never a second copy of the model.
//
// The model's state is the card's, followed here: the card steps its model
// with every sample's drive; within a block the drive moves monotonically
// towards one set point, and a play's state after a monotone stretch
// depends on its end alone, so each block's last drive (FW_STATE's
// piezo_nm) gives the card's state at the block's end (follow). A block
// whose FW_STATE is lost, or has not come yet when a scan is taken, leaves
// the state as of the last that did: the drive moves at most the
// scanner's speed over a block between the two.
//
// The raster's commanded ramp, as sim_afm serves a scan request (the
// request's pixel centres: x_i = x0 + (i + 1/2) w / nx, y_j likewise; to
// the first line, to line j, to the line's end, back along the retrace to
// its start, then along the line), through a copy of that state gives each
// pixel's position (raster). A scan is aimed by the card's inverse model
// (aim: fw_hyst_inverse_pm, the card's own compensation, its plays kept in
// step with the direct model's by follow): the rectangle to command so
// that the model puts the raster's first and last pixel of each axis on
// the square's, the pixels between on the branch between them. The
// de-warped image is the scan resampled at the asked square's grid
// (bilinear; past what the scan reached, its edge); a scan not aimed is
// resampled at its commanded grid.
// Creep moves nothing here: the card's creep model of a raster taken at
// once is none, and the simulator takes its scans at once (physics.md
// 17.2: they show no creep). Without the card's hysteresis compensation
// the scan stays as it came.
#pragma once

extern "C" {
#include "fw_hyst.h"
}

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

#include "scan_client.hpp"
#include "scene.hpp"

namespace afm {

// Each pixel's position where the card's model puts the tip, frame A, nm:
// x_nm[i] for pixel i of every line (each line's ramp starts from the same
// state), y_nm[j] for line j (0 at the bottom).
struct RasterPositions {
    std::vector<double> x_nm, y_nm;
};

class ScanDewarp {
public:
    ScanDewarp() = default;                 // inactive: scans stay as they came
    explicit ScanDewarp(const Scene &s);    // active when the scene's card compensates the hysteresis

    bool active() const { return active_; }
    // The card's drive at the end of block `seq` (FW_STATE's piezo_nm);
    // a block not past the last followed is ignored.
    void follow(int64_t seq, int64_t utime, double drive_x_nm, double drive_y_nm);
    int64_t state_seq() const { return seq_; }       // the last block followed, -1 before any
    int64_t state_utime() const { return utime_; }   // its end, simulated us (0 before any)

    // Where the card's model puts each pixel of a scan of r taken now.
    RasterPositions raster(const ScanRegion &r) const;
    // The rectangle to command (as many pixels) so that the card's model
    // puts a scan taken now on `want`'s pixels (header). Inactive, or
    // fewer than 2 pixels on an axis: want.
    ScanRegion aim(const ScanRegion &want) const;
    // The scan (CV_32F, taken.ny x taken.nx, row 0 at the top), commanded
    // over `taken`, resampled at `grid`'s pixels (as many as taken's);
    // *shift_nm (may be null): the largest distance between a pixel's
    // commanded and modelled position. Inactive: a copy.
    cv::Mat apply(const cv::Mat &scan, const ScanRegion &taken, const ScanRegion &grid, double *shift_nm = nullptr) const;
    // The same resampled at its commanded grid (a scan not aimed).
    cv::Mat apply(const cv::Mat &scan, const ScanRegion &r, double *shift_nm = nullptr) const { return apply(scan, r, r, shift_nm); }

private:
    bool active_ = false;
    fw_hyst_t axis_[2]{};    // the card's models, x and y, in the state followed (the direct's and the inverse's plays)
    int64_t seq_ = -1, utime_ = 0;
};

}  // namespace afm
