// What a scan sees (world.hpp): the true height, the tip's profile and its
// convolution with the objects, one scan point with its noise.

#include "world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "world_internal.hpp"

namespace afm::sim {

double World::height_true(double x, double y) const
{
    const Eigen::Vector2d q = Eigen::Vector2d(x, y) - drift_;
    const double base = base_height(q);
    double z = -groove_depth(q);
    near(q, max_radius_, scratch2_);
    for (int idx : scratch2_) {
        const Particle &p = particles_[idx];
        const double w2 = (q - p.c).squaredNorm();
        if (w2 < p.r * p.r) z = std::max(z, p.r + std::sqrt(p.r * p.r - w2));
    }
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        const auto &w = wires_[i];
        if (!w->near(q, 0.0)) continue;
        const double r = 0.5 * w->d_nm, d = w->axis_distance(q);
        if (d < r) z = std::max(z, wire_axis_height_nm(i) + std::sqrt(r * r - d * d));
    }
    return base + std::max(z, landmark_height(q, false));
}

double World::landmark_height(const Eigen::Vector2d &q, bool dilated) const
{
    // A square pillar of side a and height H: flat top; under the tip, its
    // top edge is met by the tip's profile at horizontal distance d from
    // the pillar, so the apex stands at H - t(d).
    double z = -std::numeric_limits<double>::infinity();
    for (const auto &m : landmarks_) {
        const double dx = std::max(0.0, std::fabs(q.x() - m.x_nm) - m.side_nm / 2);
        const double dy = std::max(0.0, std::fabs(q.y() - m.y_nm) - m.side_nm / 2);
        const double d = std::hypot(dx, dy);
        if (d == 0) z = std::max(z, m.height_nm);
        else if (dilated) {
            const double h = m.height_nm - tip_profile(d);
            if (h > 0) z = std::max(z, h);
        }
    }
    return z;
}

double World::tip_profile(double u) const
{
    // Spherical apex of radius r_t, tangent to a cone of half angle gamma.
    const double rt = scene_.probe.tip_radius_nm;
    const double u0 = rt * cos_gamma_;
    if (u <= u0) return rt - std::sqrt(rt * rt - u * u);
    return rt - rt * sin_gamma_ + (u - u0) / tan_gamma_;
}

double World::bump_convolved(double rho, double r) const
{
    // Dilation by the tip of a sphere (or a cylinder, seen across its axis)
    // of radius r resting on the surface, at horizontal distance rho: the apex
    // height at which the tip first touches. The touching point lies in the
    // vertical plane through the tip axis and the centre; along it the gap
    // s(w) - t(|rho - w|) is concave, so a golden-section search finds it.
    if (tip_profile(std::max(0.0, rho - r)) >= 2 * r) return 0.0;   // tip flank clears the top
    auto gap = [&](double w) { return r + std::sqrt(std::max(0.0, r * r - w * w)) - tip_profile(std::fabs(rho - w)); };
    double a = -r, b = r;
    const double phi = (std::sqrt(5.0) - 1) / 2;
    double c = b - phi * (b - a), d = a + phi * (b - a);
    double fc = gap(c), fd = gap(d);
    for (int i = 0; i < 60 && b - a > 1e-6; ++i) {
        if (fc > fd) { b = d; d = c; fd = fc; c = b - phi * (b - a); fc = gap(c); }
        else { a = c; c = d; fc = fd; d = a + phi * (b - a); fd = gap(d); }
    }
    return std::max(0.0, gap(0.5 * (a + b)));
}

double World::height_convolved(double x, double y) const
{
    // Objects are dilated by the tip; the substrate plane and the trenches
    // are shown undilated (a V-groove cut by this very tip fits it).
    const Eigen::Vector2d q = Eigen::Vector2d(x, y) - drift_;
    double z = -groove_depth(q);
    // The tip's flank reaches sideways by at most its profile at the height
    // of the tallest object.
    near(q, max_radius_ + 2 * max_radius_ * tan_gamma_ + scene_.probe.tip_radius_nm, scratch2_);
    // An object the tip does not touch here (dilation 0) must not fill a
    // groove beside it: only a positive dilation competes with the groove.
    for (int idx : scratch2_) {
        const Particle &p = particles_[idx];
        const double b = bump_convolved((q - p.c).norm(), p.r);
        if (b > 0) z = std::max(z, b);
    }
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        const auto &w = wires_[i];
        const double r = 0.5 * w->d_nm;
        if (!w->near(q, r + 2 * r * tan_gamma_ + scene_.probe.tip_radius_nm)) continue;
        const double b = bump_convolved(w->axis_distance(q), r);
        if (b > 0) z = std::max(z, b + wire_axis_height_nm(i) - r);   // a rod sunk into a groove: lower by its seat
    }
    z = std::max(z, landmark_height(q, true));
    return base_height(q) + z;
}

double World::image_height(double x, double y) const
{
    const auto t0 = Clock::now();
    const double z = (this->*imaging_)(x, y);
    t_scan_ += seconds_since(t0);
    return z;
}

ScanPoint World::scan_point(double x, double y) const
{
    const auto t0 = Clock::now();
    // The scanner cannot reach beyond its range: the point is taken at the limit.
    const double half = kScannerRangeXY_nm / 2;
    const double xc = std::clamp(x, -half, half), yc = std::clamp(y, -half, half);
    bool clamped = xc != x || yc != y;
    // The contact normal is the imaged surface's (the locus of the apex):
    // central differences over a step far below the tip radius and every
    // feature's size, far above rounding.
    constexpr double kSlopeStep_nm = 0.01;
    const double h = (this->*imaging_)(xc, yc);
    const double hx = ((this->*imaging_)(xc + kSlopeStep_nm, yc) - (this->*imaging_)(xc - kSlopeStep_nm, yc)) / (2 * kSlopeStep_nm);
    const double hy = ((this->*imaging_)(xc, yc + kSlopeStep_nm) - (this->*imaging_)(xc, yc - kSlopeStep_nm)) / (2 * kSlopeStep_nm);
    const Eigen::Vector3d n = Eigen::Vector3d(-hx, -hy, 1.0).normalized();

    // Sliding in +x at the scan's load (operator.scan_load_nN, else the
    // scene's; the mechanics' contact physics).
    const Eigen::Vector2d m = Eigen::Vector2d::UnitX();
    const double load = scene_.op.scan_load_nN.value_or(scene_.op.load_nN);
    auto f = sliding_friction(m, n, load);
    Eigen::Vector2d fC = f ? Eigen::Vector2d(lever_.R.transpose() * *f) : Eigen::Vector2d::Zero();
    const ZHold zh = hold_z(h, fC.x(), load);
    ScanPoint p;
    // The height image is the z extension plus the set point's deflection:
    // the surface while z follows it, the range's limit when it cannot.
    p.height_nm = zh.clamped ? zh.z_nm + lever_.bend_slope(fC.x(), load) * 2.0 * lever_.l / 3.0 : h;
    clamped = clamped || zh.clamped;
    if (zh.clamped && zh.touching) {
        f = sliding_friction(m, n, zh.fz_nN);   // at the normal force the clamped z leaves
        fC = f ? Eigen::Vector2d(lever_.R.transpose() * *f) : Eigen::Vector2d::Zero();
    }
    if (!zh.touching) {
        p.sn_v = p.sl_v = 0.0;   // off the surface: the lever hangs free
    } else {
        p.sn_v = lever_.sn_volts(fC.x(), zh.fz_nN);
        p.sl_v = lever_.sl_volts(fC.y());
        if (!f) saturate_against(m, p.sn_v, p.sl_v);
    }
    p.sn_v = std::clamp(p.sn_v, -kSignalLimitV, kSignalLimitV);
    p.sl_v = std::clamp(p.sl_v, -kSignalLimitV, kSignalLimitV);
    if (clamped) ++scan_clamped_;
    t_scan_ += seconds_since(t0);
    return p;
}

void World::scan_line(double x0, double dx, int n, double y, double y_first, ScanPoint *out) const
{
    // The hysteresis's state, copied, taken along the raster to this line
    // and its retrace (a play's state after a monotone stretch depends on
    // its end alone, so each stretch is one step).
    std::optional<PlayHysteresis> hx, hy;
    double yt = y;
    if (piezo_model_ && piezo_model_->hx) {
        hx = piezo_model_->hx;
        hy = piezo_model_->hy;
        hy->step(y_first);
        yt = hy->step(y);
        hx->step(x0 + (n - 1) * dx);
        hx->step(x0);
    }
    for (int i = 0; i < n; ++i) {
        const double x = x0 + i * dx;
        out[i] = scan_point(hx ? hx->step(x) : x, yt);
    }
    if (!artefacts_) return;
    scratch_line_.resize(2 * static_cast<std::size_t>(n));
    double *h = scratch_line_.data(), *err = h + n;
    for (int i = 0; i < n; ++i) h[i] = out[i].height_nm;
    artefacts_->apply(x0, dx, y, n, h, err);
    for (int i = 0; i < n; ++i) {
        out[i].height_nm = h[i];
        // what z has not followed bends the lever (S_n per nm: 1 / K_n); a
        // point off the surface (S_n 0: the lever hangs free) has no error
        if (out[i].sn_v != 0.0) out[i].sn_v = std::clamp(out[i].sn_v + err[i] / lever_.deflection, -kSignalLimitV, kSignalLimitV);
    }
}

Eigen::Vector3d World::normal_rough(const Eigen::Vector2d &q) const
{
    const Eigen::Vector2d g = rough_->gradient(q);
    return Eigen::Vector3d(-g.x(), tan_slope_ - g.y(), 1.0).normalized();   // height -y tan + r(q)
}

Eigen::Vector3d World::normal_measured(const Eigen::Vector2d &q) const
{
    Eigen::Vector2d g = measured_->gradient(q);
    if (rough_) g += rough_->gradient(q);
    return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

}  // namespace afm::sim
