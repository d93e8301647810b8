// The substrates beside the flat one (world.hpp): a measured height map
// (MeasuredSurface, from a GSF file) and a rough one (RoughSurface).

#include "world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "world_internal.hpp"

namespace afm::sim {

MeasuredSurface::MeasuredSurface(const GsfGrid &g)
    : nx_(g.xres), ny_(g.yres), dx_nm_(g.xreal_m * 1e9 / g.xres), dy_nm_(g.yreal_m * 1e9 / g.yres)
{
    x0_nm_ = g.xoff_m * 1e9 + 0.5 * dx_nm_;
    ytop_nm_ = (g.yoff_m + g.yreal_m) * 1e9 - 0.5 * dy_nm_;
    // read_gsf keeps every field in gsf.hpp's kGsfRanges; a grid made some other way is held to the same
    if (nx_ < 2 || ny_ < 2 || !(dx_nm_ > 0 && dy_nm_ > 0 && std::isfinite(dx_nm_) && std::isfinite(dy_nm_) && std::isfinite(x0_nm_) &&
                                std::isfinite(ytop_nm_)) || g.values.size() != static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_))
        throw InputError("a measured substrate needs at least 2 x 2 pixels, a finite positive pitch and a finite corner");
    h_nm_.reserve(g.values.size());
    for (const float v : g.values) h_nm_.push_back(static_cast<double>(v) * 1e9);   // m -> nm
}

void MeasuredSurface::cell(const Eigen::Vector2d &q, int *i, int *j, double *t, double *u, bool *out_x, bool *out_y) const
{
    double fx = (q.x() - x0_nm_) / dx_nm_, fy = (ytop_nm_ - q.y()) / dy_nm_;
    *out_x = !(fx >= 0 && fx <= nx_ - 1);
    *out_y = !(fy >= 0 && fy <= ny_ - 1);
    fx = fx >= 0 ? std::min(fx, nx_ - 1.0) : 0.0;   // NaN to 0 too: the cell stays inside the map whatever q is
    fy = fy >= 0 ? std::min(fy, ny_ - 1.0) : 0.0;
    *i = std::min(static_cast<int>(fx), nx_ - 2);
    *j = std::min(static_cast<int>(fy), ny_ - 2);
    *t = fx - *i;
    *u = fy - *j;
}

double MeasuredSurface::height(const Eigen::Vector2d &q) const
{
    int i, j;
    double t, u;
    bool ox, oy;
    cell(q, &i, &j, &t, &u, &ox, &oy);
    const double *r0 = &h_nm_[static_cast<std::size_t>(j) * nx_ + i], *r1 = r0 + nx_;
    return (1 - u) * ((1 - t) * r0[0] + t * r0[1]) + u * ((1 - t) * r1[0] + t * r1[1]);
}

double MeasuredSurface::span_nm() const
{
    const auto [lo, hi] = std::minmax_element(h_nm_.begin(), h_nm_.end());
    return *hi - *lo;
}

Eigen::Vector2d MeasuredSurface::gradient(const Eigen::Vector2d &q) const
{
    int i, j;
    double t, u;
    bool ox, oy;
    cell(q, &i, &j, &t, &u, &ox, &oy);
    const double *r0 = &h_nm_[static_cast<std::size_t>(j) * nx_ + i], *r1 = r0 + nx_;
    const double dhdx = ((1 - u) * (r0[1] - r0[0]) + u * (r1[1] - r1[0])) / dx_nm_;
    const double dhdy = -((1 - t) * (r1[0] - r0[0]) + t * (r1[1] - r0[1])) / dy_nm_;   // rows run down y
    return Eigen::Vector2d(ox ? 0.0 : dhdx, oy ? 0.0 : dhdy);
}

RoughSurface::RoughSurface(double rms_nm, double corr_nm, uint64_t seed)
{
    // Its own stream, derived from the scene seed ("rough" in ASCII).
    std::mt19937_64 rng(seed ^ 0x726f756768ULL);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    const double sigma_k = std::sqrt(2.0) / corr_nm;           // per component
    const double golden = M_PI * (3.0 - std::sqrt(5.0));        // rad
    const double theta0 = 2 * M_PI * u01(rng);
    for (int i = 0; i < kWaves; ++i) {
        // |k| is Rayleigh(sigma_k): inverse CDF at a jittered quantile.
        const double u = (i + u01(rng)) / kWaves;
        const double kr = sigma_k * std::sqrt(-2.0 * std::log1p(-u));
        const double th = theta0 + i * golden;
        k_.emplace_back(kr * std::cos(th), kr * std::sin(th));
        phase_.push_back(2 * M_PI * u01(rng));
    }
    amp_ = rms_nm * std::sqrt(2.0 / kWaves);
}

double RoughSurface::height(const Eigen::Vector2d &q) const
{
    double z = 0;
    for (int i = 0; i < kWaves; ++i) z += std::cos(k_[i].dot(q) + phase_[i]);
    return amp_ * z;
}

void RoughSurface::add_row(double x, double y, int n, double h, double *out) const
{
    // Each wave's phase at the row's start, then turned by k_x h a node (the
    // rotation's rounding grows by about 1e-16 a step: 1e-13 of amp_ over a
    // row of a thousand nodes).
    for (int i = 0; i < kWaves; ++i) {
        const double a = k_[i].x() * x + k_[i].y() * y + phase_[i];
        double c = std::cos(a), s = std::sin(a);
        const double dc = std::cos(k_[i].x() * h), ds = std::sin(k_[i].x() * h);
        for (int j = 0; j < n; ++j) {
            out[j] += amp_ * c;
            const double c2 = c * dc - s * ds;
            s = s * dc + c * ds;
            c = c2;
        }
    }
}

Eigen::Vector2d RoughSurface::gradient(const Eigen::Vector2d &q) const
{
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (int i = 0; i < kWaves; ++i) g -= std::sin(k_[i].dot(q) + phase_[i]) * k_[i];
    return amp_ * g;
}

}  // namespace afm::sim
