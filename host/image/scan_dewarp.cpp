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
#include "scan_raster.hpp"

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

// The fractional index at which the nondecreasing v(0) .. v(n - 1) (n >= 2)
// reach q: linear between them and past either end (the resampling
// replicates the edge there).
template <typename V>
double reach(const V &v, int n, double q)
{
    int lo = 0, hi = n - 2;   // the segment: the last k <= n - 2 with v(k) <= q, else 0
    while (lo < hi) {
        const int mid = (lo + hi + 1) / 2;
        if (v(mid) <= q) lo = mid;
        else hi = mid - 1;
    }
    const double span = v(lo + 1) - v(lo);
    return lo + (span > 0 ? (q - v(lo)) / span : 0.0);
}

// An index's floor in [0, n - 2] and its fraction, clamped to [0, 1].
void cell(double a, int n, int *k, double *f)
{
    *k = std::clamp(static_cast<int>(std::floor(a)), 0, n - 2);
    *f = std::clamp(a - *k, 0.0, 1.0);
}

// A scan's placed pixels with lines and columns made nondecreasing (a line
// the creep folded back behind the one before is taken from the later
// one), and the raster point (fractional pixel a, line b) at which they
// reach a grid point: alternate searches along the line at b and the
// column at a, from the last point found (the model moves x mostly with a
// and y with b: a few rounds).
class Placed {
public:
    explicit Placed(const RasterPositions &p) : nx_(p.nx), ny_(p.ny), x_(p.x_nm), y_(p.y_nm)
    {
        for (int j = 0; j < ny_; ++j)
            for (int i = 0; i < nx_; ++i) {
                if (i > 0) at(x_, i, j) = std::max(at(x_, i, j), at(x_, i - 1, j));
                if (j > 0) at(y_, i, j) = std::max(at(y_, i, j), at(y_, i, j - 1));
            }
    }
    void find(double u, double v, double *a, double *b) const
    {
        constexpr int kRounds = 4;
        for (int round = 0; round < kRounds; ++round) {
            int j, i;
            double f, g;
            cell(*b, ny_, &j, &f);
            *a = reach([&](int k) { return (1 - f) * at(x_, k, j) + f * at(x_, k, j + 1); }, nx_, u);
            cell(*a, nx_, &i, &g);
            *b = reach([&](int k) { return (1 - g) * at(y_, i, k) + g * at(y_, i + 1, k); }, ny_, v);
        }
    }

private:
    double &at(std::vector<double> &v, int i, int j) { return v[static_cast<std::size_t>(j) * nx_ + i]; }
    double at(const std::vector<double> &v, int i, int j) const { return v[static_cast<std::size_t>(j) * nx_ + i]; }
    int nx_, ny_;
    std::vector<double> x_, y_;
};

// The most blocks a creep model is stepped to catch up (past it the model
// has long settled: its slowest term's time constant is 379 t0).
constexpr int64_t kMaxHeldBlocks = int64_t{1} << 21;

}  // namespace

ScanDewarp::ScanDewarp(const Scene &s)
{
    const CardSetup card(s);
    const fw_card_config_t &c = card.config();
    if (c.hyst_enable) {
        for (int i = 0; i < 2; ++i)
            if (fw_hyst_init(&axis_[i], &c.hyst[i]) != FW_OK) return;   // the card refuses it too (card_refusal): the run never starts
        hyst_ = true;
    }
    if (c.creep_enable) {
        const Vec2 o = s.start_nm();   // the card's first command: its rest
        last_nm_[0] = o.x;
        last_nm_[1] = o.y;
        for (int i = 0; i < 2; ++i) {
            if (fw_creep_init(&creep_axis_[i], &c.creep) != FW_OK) return;
            fw_creep_follow_pm(&creep_axis_[i], fwu_pm_from_nm(last_nm_[i]), nullptr);
        }
        period_us_ = c.creep.period_us;
        creep_ = true;
    }
}

void ScanDewarp::follow(int64_t seq, int64_t utime, double drive_x_nm, double drive_y_nm)
{
    if (!active() || seq <= seq_) return;
    double p[2] = {drive_x_nm, drive_y_nm};
    for (int i = 0; i < 2; ++i) {
        // The inverse's plays follow the direct model's output, as the card's
        // follow its wanted positions: the inverse of what follows is then exact.
        if (hyst_) p[i] = direct_nm(&axis_[i], p[i]);
        if (hyst_) inverse_nm(&axis_[i], p[i]);
        if (!creep_) continue;
        const int64_t blocks = std::min(seq - seq_, kMaxHeldBlocks);   // a block not seen holds the last position
        for (int64_t b = 1; b < blocks; ++b) fw_creep_follow_pm(&creep_axis_[i], fwu_pm_from_nm(last_nm_[i]), nullptr);
        fw_creep_follow_pm(&creep_axis_[i], fwu_pm_from_nm(p[i]), nullptr);
        last_nm_[i] = p[i];
    }
    seq_ = seq;
    utime_ = utime;
}

RasterPositions ScanDewarp::raster(const ScanRegion &r, int64_t scan_utime) const
{
    RasterPositions out;
    out.nx = r.nx;
    out.ny = r.ny;
    out.x_nm.resize(static_cast<std::size_t>(r.nx) * r.ny);
    out.y_nm.resize(out.x_nm.size());
    const double dx = r.width_nm / r.nx, dy = r.height_nm / r.ny;
    const double x_first = r.x0_nm + 0.5 * dx, y_first = r.y0_nm + 0.5 * dy;
    fw_hyst_t x = axis_[0], y = axis_[1];
    auto hx = [&](double v) { return hyst_ ? direct_nm(&x, v) : v; };
    auto hy = [&](double v) { return hyst_ ? direct_nm(&y, v) : v; };
    hx(x_first + (r.nx - 1) * dx);   // the line's end, then the retrace
    hx(x_first);
    std::vector<double> trace, lines;
    for (int i = 0; i < r.nx; ++i) trace.push_back(hx(x_first + i * dx));
    for (int j = 0; j < r.ny; ++j) lines.push_back(hy(y_first + j * dy));   // monotone: each as from the first line
    if (creep_) {
        raster_creep(r, scan_utime, trace, lines, &out);
        return out;
    }
    for (int j = 0; j < r.ny; ++j)
        for (int i = 0; i < r.nx; ++i) {
            out.x_nm[static_cast<std::size_t>(j) * r.nx + i] = trace[static_cast<std::size_t>(i)];
            out.y_nm[static_cast<std::size_t>(j) * r.nx + i] = lines[static_cast<std::size_t>(j)];
        }
    return out;
}

void ScanDewarp::raster_creep(const ScanRegion &r, int64_t scan_utime, const std::vector<double> &trace,
                              const std::vector<double> &lines, RasterPositions *out) const
{
    fw_creep_t cx = creep_axis_[0], cy = creep_axis_[1];
    // to the scan's time, the last position held
    const int64_t held = scan_utime > utime_ ? std::min((scan_utime - utime_) / period_us_, kMaxHeldBlocks) : 0;
    for (int64_t k = 0; k < held; ++k) {
        fw_creep_follow_pm(&cx, fwu_pm_from_nm(last_nm_[0]), nullptr);
        fw_creep_follow_pm(&cy, fwu_pm_from_nm(last_nm_[1]), nullptr);
    }
    // Along the raster a period at a time (common/scan_raster.hpp): the
    // fast axis held at the line's start, the slow at the line's; the
    // creep period n's call gives (the states through period n - 1) is the
    // creep at its start, n T, which places every line taken by then.
    const ScanRaster t = scan_raster(r.width_nm / r.nx, r.nx);
    const double T = period_us_ * 1e-6;
    int j = 0;   // the next line to place
    for (int64_t n = 0; j < r.ny; ++n) {
        const int line = std::min(r.ny - 1, static_cast<int>(n * T / t.line_s));
        const double ox = fwu_nm_from_pm(fw_creep_follow_pm(&cx, fwu_pm_from_nm(trace.front()), nullptr));
        const double oy = fwu_nm_from_pm(fw_creep_follow_pm(&cy, fwu_pm_from_nm(lines[static_cast<std::size_t>(line)]), nullptr));
        for (; j < r.ny && t.line_time_s(j) <= n * T; ++j)
            for (int i = 0; i < r.nx; ++i) {
                out->x_nm[static_cast<std::size_t>(j) * r.nx + i] = trace[static_cast<std::size_t>(i)] + ox;
                out->y_nm[static_cast<std::size_t>(j) * r.nx + i] = lines[static_cast<std::size_t>(j)] + oy;
            }
    }
}

ScanRegion ScanDewarp::aim(const ScanRegion &want) const
{
    if (!active() || want.nx < 2 || want.ny < 2) return want;
    const double dx = want.width_nm / want.nx, dy = want.height_nm / want.ny;
    // The first and last pixel of each axis as asked: x first, x last, y first, y last.
    const double w[4] = {want.x0_nm + 0.5 * dx, want.x0_nm + want.width_nm - 0.5 * dx, want.y0_nm + 0.5 * dy,
                         want.y0_nm + want.height_nm - 0.5 * dy};
    double cmd[4] = {w[0], w[1], w[2], w[3]};
    if (hyst_) {
        fw_hyst_t x = axis_[0], y = axis_[1];
        // In the raster's order (raster): the line's end, its start, then the
        // trace to its end; the first line, then the last from there.
        inverse_nm(&x, w[1]);
        cmd[0] = inverse_nm(&x, w[0]);
        cmd[1] = inverse_nm(&x, w[1]);
        cmd[2] = inverse_nm(&y, w[2]);
        cmd[3] = inverse_nm(&y, w[3]);
    }
    auto region = [&](const double c[4]) {
        ScanRegion r = want;
        const double cdx = (c[1] - c[0]) / (want.nx - 1), cdy = (c[3] - c[2]) / (want.ny - 1);
        r.x0_nm = c[0] - 0.5 * cdx;
        r.y0_nm = c[2] - 0.5 * cdy;
        r.width_nm = cdx * want.nx;
        r.height_nm = cdy * want.ny;
        return r;
    };
    // Each corner moved by where the card's models put it (through the
    // raster: the preamble's excursion and the creep), against the square's:
    // the mean of the first and last pixel over the lines (x) and over the
    // line (y); the models' slope about 1.
    constexpr int kRounds = 3;
    for (int round = 0; round < kRounds; ++round) {
        const ScanRegion r = region(cmd);
        const RasterPositions p = raster(r);
        double got[4] = {0, 0, 0, 0};
        for (int j = 0; j < r.ny; ++j) {
            got[0] += p.x(0, j) / r.ny;
            got[1] += p.x(r.nx - 1, j) / r.ny;
        }
        for (int i = 0; i < r.nx; ++i) {
            got[2] += p.y(i, 0) / r.nx;
            got[3] += p.y(i, r.ny - 1) / r.nx;
        }
        for (int k = 0; k < 4; ++k) cmd[k] -= got[k] - w[k];
    }
    return region(cmd);
}

cv::Mat ScanDewarp::apply(const cv::Mat &scan, const ScanRegion &taken, const ScanRegion &grid, double *shift_nm, int64_t scan_utime) const
{
    if (shift_nm) *shift_nm = 0;
    const ScanRegion &r = taken;
    if (!active() || scan.rows != r.ny || scan.cols != r.nx || r.nx < 2 || r.ny < 2 || grid.nx != r.nx || grid.ny != r.ny)
        return scan.clone();
    const RasterPositions p = raster(r, scan_utime);
    const double dx = r.width_nm / r.nx, dy = r.height_nm / r.ny;
    const double gx = grid.width_nm / grid.nx, gy = grid.height_nm / grid.ny;
    double shift = 0;
    for (int j = 0; j < r.ny; ++j)
        for (int i = 0; i < r.nx; ++i)
            shift = std::max({shift, std::fabs(p.x(i, j) - (r.x0_nm + (i + 0.5) * dx)), std::fabs(p.y(i, j) - (r.y0_nm + (j + 0.5) * dy))});
    const Placed placed(p);
    cv::Mat mx(r.ny, r.nx, CV_32F), my(r.ny, r.nx, CV_32F), out;
    for (int j = 0; j < r.ny; ++j) {   // grid line j is row ny - 1 - j
        double a = 0, b = j;
        for (int i = 0; i < r.nx; ++i) {
            placed.find(grid.x0_nm + (i + 0.5) * gx, grid.y0_nm + (j + 0.5) * gy, &a, &b);
            mx.at<float>(r.ny - 1 - j, i) = static_cast<float>(a);
            my.at<float>(r.ny - 1 - j, i) = static_cast<float>(r.ny - 1 - b);
        }
    }
    cv::remap(scan, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    if (shift_nm) *shift_nm = shift;
    return out;
}

}  // namespace afm
