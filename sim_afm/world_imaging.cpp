// What a scan sees (world.hpp): the true height, the map the tip images and
// its dilation by the tip (dilation.hpp), one scan point with its noise.

#include "world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "world_internal.hpp"

namespace afm::sim {

double World::height_true(double x, double y) const
{
    const Eigen::Vector2d q = Eigen::Vector2d(x, y) - drift_;
    return base_height(q) + std::max(-groove_depth(q), object_profile(q));
}

double World::object_profile(const Eigen::Vector2d &q) const
{
    double z = -std::numeric_limits<double>::infinity();
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
    for (const auto &m : landmarks_)   // a square pillar of side a and height H
        if (std::fabs(q.x() - m.x_nm) <= m.side_nm / 2 && std::fabs(q.y() - m.y_nm) <= m.side_nm / 2) z = std::max(z, m.height_nm);
    return z;
}

void World::fill_map(double x, double y, int n, double h, double *base, double *groove, double *object) const
{
    const Eigen::Vector2d q0 = Eigen::Vector2d(x, y) - drift_;
    for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d q(q0.x() + i * h, q0.y());
        base[i] = measured_ ? measured_->height(q) : -q.y() * tan_slope_;
        groove[i] = groove_depth(q);
        object[i] = object_profile(q);   // above the substrate: the base is added below
    }
    if (rough_) rough_->add_row(q0.x(), q0.y(), n, h, base);
    for (int i = 0; i < n; ++i) object[i] += base[i];   // -inf stays -inf
}

void World::imaging_state(std::vector<double> &out) const
{
    // Everything fill_map reads that changes while a run goes.
    out.clear();
    out.push_back(drift_.x());
    out.push_back(drift_.y());
    out.push_back(scene_.probe.tip_radius_nm);
    for (const Particle &p : particles_) out.insert(out.end(), {p.c.x(), p.c.y(), p.r});
    for (std::size_t i = 0; i < wires_.size(); ++i) {
        out.push_back(wires_[i]->d_nm);
        out.push_back(wire_axis_height_nm(i));
        for (const auto &x : wires_[i]->nodes()) out.insert(out.end(), {x.x(), x.y()});
    }
    for (const Trench &t : trenches_) {
        out.push_back(static_cast<double>(t.p.size()));
        for (std::size_t k = 0; k < t.p.size(); ++k) out.insert(out.end(), {t.p[k].x(), t.p[k].y(), t.depth_nm[k]});
    }
}

double World::lattice_pitch(double dx) const
{
    // A scan's pixels, subdivided (at most 4 x 4) until the lattice's step is
    // at most half the apex's radius (1 nm at least): the tip's own scale,
    // below which a dilation shows nothing new.
    constexpr int kMaxSubdivision = 4;
    const double fine = 0.5 * std::max(scene_.probe.tip_radius_nm, 2.0);
    const int k = std::clamp(static_cast<int>(std::ceil(dx / fine)), 1, kMaxSubdivision);
    return dx / k;
}

std::shared_ptr<const DilatedField> World::dilated(double x0, double y0, double h) const
{
    // The lattice through (x0, y0), its origin brought into [0, h): scans on
    // the same pixels share it.
    const double ox = x0 - h * std::floor(x0 / h), oy = y0 - h * std::floor(y0 / h);
    imaging_state(state_now_);
    if (dilated_ && dilated_->pitch() == h && dilated_->x0() == ox && dilated_->y0() == oy && state_now_ == dilated_state_) return dilated_;
    dilated_state_ = state_now_;
    const TipShape tip{scene_.probe.tip_radius_nm, gamma_rad_};
    // The relief: the tallest object, the roughness's bound, the map's span.
    double relief = 2 * max_radius_;
    for (std::size_t i = 0; i < wires_.size(); ++i) relief = std::max(relief, wire_axis_height_nm(i) + 0.5 * wires_[i]->d_nm);
    for (const auto &m : landmarks_) relief = std::max(relief, m.height_nm);
    if (rough_) relief += 2 * rough_->amplitude_bound_nm();
    if (measured_) relief += measured_->span_nm();
    dilated_ = std::make_shared<const DilatedField>(tip, ox, oy, h, relief, measured_ ? 0.0 : tan_slope_,
                                                    [this](double x, double y, int n, double hh, double *b, double *g, double *o) {
                                                        fill_map(x, y, n, hh, b, g, o);
                                                    });
    return dilated_;
}

std::shared_ptr<const DilatedField> World::dilated_default() const
{
    const double dx = scene_.field_nm / scene_.out.image_px;
    return dilated(scene_.field_center_nm.x - 0.5 * scene_.field_nm + 0.5 * dx, scene_.field_center_nm.y - 0.5 * scene_.field_nm + 0.5 * dx,
                   lattice_pitch(dx));
}

double World::height_convolved(double x, double y) const
{
    // The tip's dilation of the height map (dilation.hpp), on the display's lattice.
    return dilated_default()->height(x, y);
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
    const std::shared_ptr<const DilatedField> f = imaging_ == &World::height_convolved ? dilated_default() : nullptr;
    const ScanPoint p = scan_point_on(f.get(), x, y);
    t_scan_ += seconds_since(t0);
    return p;
}

ScanPoint World::scan_point_on(const DilatedField *field, double x, double y) const
{
    // The scanner cannot reach beyond its range: the point is taken at the limit.
    const double half = kScannerRangeXY_nm / 2;
    const double xc = std::clamp(x, -half, half), yc = std::clamp(y, -half, half);
    bool clamped = xc != x || yc != y;
    // The contact normal is the imaged surface's (the locus of the apex):
    // central differences over a step far below the tip radius and every
    // feature's size, far above rounding; on the tip's image, the lattice's
    // (dilation.hpp: central differences at its nodes, bilinear between).
    constexpr double kSlopeStep_nm = 0.01;
    Eigen::Vector2d grad;
    double h;
    if (field) {
        h = field->height(xc, yc, &grad);
    } else {
        h = (this->*imaging_)(xc, yc);
        grad.x() = ((this->*imaging_)(xc + kSlopeStep_nm, yc) - (this->*imaging_)(xc - kSlopeStep_nm, yc)) / (2 * kSlopeStep_nm);
        grad.y() = ((this->*imaging_)(xc, yc + kSlopeStep_nm) - (this->*imaging_)(xc, yc - kSlopeStep_nm)) / (2 * kSlopeStep_nm);
    }
    const Eigen::Vector3d n = Eigen::Vector3d(-grad.x(), -grad.y(), 1.0).normalized();

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
    return p;
}

void World::scan_line(double x0, double dx, int n, double y, double y_first, ScanPoint *out, double dy) const
{
    // Where the scanner puts each point: its models' state, copied, taken
    // along the raster to this line (PiezoXY::raster_line).
    const auto t0 = Clock::now();
    if (piezo_model_) {
        raster_x_.resize(2 * static_cast<std::size_t>(n));
        piezo_model_->raster_line(RasterLine{x0, dx, n, y, y_first, dy}, raster_x_.data(), raster_x_.data() + n);
    }
    // With tip_convolution, the lattice through the line's first point and
    // the raster's first line, at the line's pitch subdivided.
    const std::shared_ptr<const DilatedField> f = imaging_ == &World::height_convolved ? dilated(x0, y_first, lattice_pitch(dx)) : nullptr;
    for (int i = 0; i < n; ++i)
        out[i] = piezo_model_ ? scan_point_on(f.get(), raster_x_[static_cast<std::size_t>(i)], raster_x_[static_cast<std::size_t>(n + i)])
                              : scan_point_on(f.get(), x0 + i * dx, y);
    t_scan_ += seconds_since(t0);
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
