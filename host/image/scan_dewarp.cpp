// ScanDewarp (scan_dewarp.hpp): the card's scanner model followed and a
// scan's pixels placed through it.
#include "scan_dewarp.hpp"

extern "C" {
#include "fw_units.h"
}

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "card_setup.hpp"

namespace afm {

namespace {

// One step of the card's direct model, nm in and out (the firmware's pm).
double direct_nm(fw_hyst_t *h, double x_nm)
{
    return fwu_nm_from_pm(fw_hyst_direct_pm(h, fwu_pm_from_nm(x_nm), nullptr));
}

// One step of the card's inverse model: the command that puts the tip at y_nm.
double inverse_nm(fw_hyst_t *h, double y_nm)
{
    return fwu_nm_from_pm(fw_hyst_inverse_pm(h, fwu_pm_from_nm(y_nm), nullptr));
}

// The fractional index at which the increasing positions p reach q,
// linear between them and past either end (the resampling replicates the
// edge there).
class Inverse {
public:
    explicit Inverse(const std::vector<double> &p) : p_(p) {}
    float at(double q)
    {
        const std::size_t n = p_.size();
        if (n < 2) return 0.0f;
        while (k_ + 2 < n && p_[k_ + 1] <= q) ++k_;   // queries come in increasing order
        const double span = p_[k_ + 1] - p_[k_];
        return static_cast<float>(k_ + (span > 0 ? (q - p_[k_]) / span : 0.0));
    }

private:
    const std::vector<double> &p_;
    std::size_t k_ = 0;
};

}  // namespace

ScanDewarp::ScanDewarp(const Scene &s)
{
    const CardSetup card(s);
    const fw_card_config_t &c = card.config();
    if (!c.hyst_enable) return;
    for (int i = 0; i < 2; ++i)
        if (fw_hyst_init(&axis_[i], &c.hyst[i]) != FW_OK) return;   // the card refuses it too (card_refusal): the run never starts
    active_ = true;
}

void ScanDewarp::follow(int64_t seq, int64_t utime, double drive_x_nm, double drive_y_nm)
{
    if (!active_ || seq <= seq_) return;
    // The inverse's plays follow the direct model's output, as the card's
    // follow its wanted positions: the inverse of what follows is then exact.
    inverse_nm(&axis_[0], direct_nm(&axis_[0], drive_x_nm));
    inverse_nm(&axis_[1], direct_nm(&axis_[1], drive_y_nm));
    seq_ = seq;
    utime_ = utime;
}

RasterPositions ScanDewarp::raster(const ScanRegion &r) const
{
    RasterPositions out;
    const double dx = r.width_nm / r.nx, dy = r.height_nm / r.ny;
    const double x_first = r.x0_nm + 0.5 * dx, y_first = r.y0_nm + 0.5 * dy;
    fw_hyst_t x = axis_[0], y = axis_[1];
    if (active_) {
        direct_nm(&y, y_first);
        direct_nm(&x, x_first + (r.nx - 1) * dx);   // the line's end, then the retrace
        direct_nm(&x, x_first);
    }
    for (int i = 0; i < r.nx; ++i) out.x_nm.push_back(active_ ? direct_nm(&x, x_first + i * dx) : x_first + i * dx);
    for (int j = 0; j < r.ny; ++j) {
        fw_hyst_t line = y;   // each line from the raster's first (sim_afm's World::scan_line)
        out.y_nm.push_back(active_ ? direct_nm(&line, y_first + j * dy) : y_first + j * dy);
    }
    return out;
}

ScanRegion ScanDewarp::aim(const ScanRegion &want) const
{
    if (!active_ || want.nx < 2 || want.ny < 2) return want;
    const double dx = want.width_nm / want.nx, dy = want.height_nm / want.ny;
    const double x_first = want.x0_nm + 0.5 * dx, y_first = want.y0_nm + 0.5 * dy;
    fw_hyst_t x = axis_[0], y = axis_[1];
    // In the raster's order (raster): the line's end, then its start; the
    // first line, then the last from there (every line starts from the first's state).
    const double x_end = inverse_nm(&x, x_first + (want.nx - 1) * dx), x_start = inverse_nm(&x, x_first);
    const double y_start = inverse_nm(&y, y_first), y_end = inverse_nm(&y, y_first + (want.ny - 1) * dy);
    const double cdx = (x_end - x_start) / (want.nx - 1), cdy = (y_end - y_start) / (want.ny - 1);
    ScanRegion r = want;
    r.x0_nm = x_start - 0.5 * cdx;
    r.y0_nm = y_start - 0.5 * cdy;
    r.width_nm = cdx * want.nx;
    r.height_nm = cdy * want.ny;
    return r;
}

cv::Mat ScanDewarp::apply(const cv::Mat &scan, const ScanRegion &taken, const ScanRegion &grid, double *shift_nm) const
{
    if (shift_nm) *shift_nm = 0;
    const ScanRegion &r = taken;
    if (!active_ || scan.rows != r.ny || scan.cols != r.nx || r.nx < 2 || r.ny < 2 || grid.nx != r.nx || grid.ny != r.ny)
        return scan.clone();
    const RasterPositions p = raster(r);
    const double dx = r.width_nm / r.nx, dy = r.height_nm / r.ny;
    const double gx = grid.width_nm / grid.nx, gy = grid.height_nm / grid.ny;
    double shift = 0;
    cv::Mat map_x(1, r.nx, CV_32F), map_y(r.ny, 1, CV_32F);
    Inverse col(p.x_nm), line(p.y_nm);
    for (int i = 0; i < r.nx; ++i) {
        map_x.at<float>(0, i) = col.at(grid.x0_nm + (i + 0.5) * gx);
        shift = std::max(shift, std::fabs(p.x_nm[static_cast<std::size_t>(i)] - (r.x0_nm + (i + 0.5) * dx)));
    }
    for (int j = 0; j < r.ny; ++j) {   // line j is row ny - 1 - j
        map_y.at<float>(r.ny - 1 - j, 0) = static_cast<float>(r.ny - 1) - line.at(grid.y0_nm + (j + 0.5) * gy);
        shift = std::max(shift, std::fabs(p.y_nm[static_cast<std::size_t>(j)] - (r.y0_nm + (j + 0.5) * dy)));
    }
    cv::Mat mx, my, out;
    cv::repeat(map_x, r.ny, 1, mx);
    cv::repeat(map_y, 1, r.nx, my);
    cv::remap(scan, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    if (shift_nm) *shift_nm = shift;
    return out;
}

}  // namespace afm
