// The tip's contact geometry in three dimensions (tip_geometry.hpp).

#include "tip_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace afm::sim {

namespace {

// Points nearer the tip's axis than this (nm) take the tip frame's x as
// their radial direction; nearer its apex centre, the flank's formula
// (equal to the sphere's there) instead of a division by their distance.
constexpr double kAxisGuard_nm = 1e-9;
// A cylinder shorter than this (nm) is the sphere at its first end.
constexpr double kShortSegment_nm = 1e-9;
// The height search: the disc's radius in pitches at most, and the starts.
constexpr double kMaxRadiusPitches = 1024;
constexpr int kMaxStarts = 16;
constexpr int kRefineHalf = 4;   // the refining grids: 2 kRefineHalf + 1 points
// resting_reach_nm's search ends here (nm): a tip that still overlaps there has none.
constexpr double kMaxReach_nm = 1e9;

std::string num(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
}

[[noreturn]] void refuse(const std::string &what) { throw std::invalid_argument("tip geometry: " + what); }

void check_search(const HeightSearch &s)
{
    if (!(s.pitch_nm > 0) || !std::isfinite(s.pitch_nm)) refuse("height search pitch_nm " + num(s.pitch_nm) + " is not finite and > 0");
    if (!(s.radius_nm >= 0) || !(s.radius_nm <= kMaxRadiusPitches * s.pitch_nm))
        refuse("height search radius_nm " + num(s.radius_nm) + " is outside [0, 1024 pitch_nm = " + num(kMaxRadiusPitches * s.pitch_nm) + "]");
    if (!(s.tol_nm > 0) || !(s.tol_nm <= s.pitch_nm))
        refuse("height search tol_nm " + num(s.tol_nm) + " is outside (0, pitch_nm = " + num(s.pitch_nm) + "]");
    if (s.starts < 1 || s.starts > kMaxStarts) refuse("height search starts " + std::to_string(s.starts) + " is outside [1, 16]");
}

// One point of the substrate and its signed distance to the tip.
struct SurfacePoint {
    double sd_nm;
    Eigen::Vector3d p;
};

SurfacePoint surface_point(const TipGeometry &tip, const HeightField &z, const Eigen::Vector2d &xy)
{
    const double h = z(xy);
    if (!std::isfinite(h)) refuse("height field gives " + num(h) + " at (" + num(xy.x()) + ", " + num(xy.y()) + ") nm, not a finite height");
    const Eigen::Vector3d p(xy.x(), xy.y(), h);
    return {tip.nearest(p).sd_nm, p};
}

// The least of f (x -> SurfacePoint) found from the samples x0 + k h, k in
// [0, n]: from each of up to `starts` best samples no two within 2 h, grids
// of 2 kRefineHalf + 1 points about the best so far, of half side twice
// the last step, the step halving until it is below tol. The best point
// found, and its argument in *arg.
template <class F>
SurfacePoint least_1d(F f, double x0, double h, int n, int starts, double tol, double *arg)
{
    std::vector<std::pair<SurfacePoint, double>> samples;
    samples.reserve(static_cast<std::size_t>(n) + 1);
    for (int k = 0; k <= n; ++k) samples.emplace_back(f(x0 + k * h), x0 + k * h);
    std::sort(samples.begin(), samples.end(), [](const auto &a, const auto &b) { return a.first.sd_nm < b.first.sd_nm; });
    std::vector<double> picked;
    SurfacePoint best = samples.front().first;
    *arg = samples.front().second;
    for (const auto &[start, x_start] : samples) {
        if (static_cast<int>(picked.size()) == starts) break;
        if (std::any_of(picked.begin(), picked.end(), [&](double x) { return std::fabs(x - x_start) <= 2 * h; })) continue;
        picked.push_back(x_start);
        SurfacePoint here = start;
        double x = x_start;
        for (double step = h / 2;; step /= 2) {
            const double c = x;
            for (int i = -kRefineHalf; i <= kRefineHalf; ++i) {
                if (i == 0) continue;
                const SurfacePoint q = f(c + i * step);
                if (q.sd_nm < here.sd_nm) here = q, x = c + i * step;
            }
            if (step < tol) break;
        }
        if (here.sd_nm < best.sd_nm) best = here, *arg = x;
    }
    return best;
}

// The substrate's least signed distance along the ray from c at azimuth phi.
SurfacePoint ray_least(const TipGeometry &tip, const HeightField &z, const Eigen::Vector2d &c, double phi, const HeightSearch &s)
{
    const Eigen::Vector2d dir(std::cos(phi), std::sin(phi));
    const int n = static_cast<int>(std::floor(s.radius_nm / s.pitch_nm));   // <= kMaxRadiusPitches
    double rho;
    return least_1d([&](double r) { return surface_point(tip, z, c + r * dir); }, 0.0, s.pitch_nm, n, s.starts, s.tol_nm, &rho);
}

}  // namespace

TipGeometry::TipGeometry(double radius_nm, double half_angle_rad, const TipPose &pose) : r_(radius_nm), gamma_(half_angle_rad)
{
    if (!(radius_nm >= 0) || !std::isfinite(radius_nm)) refuse("apex radius_nm " + num(radius_nm) + " is not finite and >= 0");
    if (!(half_angle_rad >= 0 && half_angle_rad <= M_PI / 2))
        refuse("cone half_angle_rad " + num(half_angle_rad) + " is outside [0, pi/2]");
    if (!pose.apex_nm.allFinite()) refuse("apex position is not finite");
    if (!std::isfinite(pose.tilt_rad) || !std::isfinite(pose.twist_rad) || !std::isfinite(pose.alpha_rad))
        refuse("tilt_rad " + num(pose.tilt_rad) + ", twist_rad " + num(pose.twist_rad) + ", alpha_rad " + num(pose.alpha_rad) + ": not all finite");
    sin_g_ = std::sin(gamma_);
    cos_g_ = std::cos(gamma_);
    const Eigen::Matrix3d turn = (Eigen::AngleAxisd(pose.alpha_rad, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(pose.twist_rad, Eigen::Vector3d::UnitX()) *
                                  Eigen::AngleAxisd(-pose.tilt_rad, Eigen::Vector3d::UnitY())).toRotationMatrix();
    apex_ = pose.apex_nm;
    axis_ = turn.col(2);
    e1_ = turn.col(0);
    centre_ = apex_ + r_ * axis_;
}

TipGeometry TipGeometry::from_probe(const ProbeSpec &probe, const TipPose &pose)
{
    return TipGeometry(probe.tip_radius_nm, probe.tip_half_angle_deg * M_PI / 180.0, pose);
}

TipGeometry::Nearest TipGeometry::nearest(const Eigen::Vector3d &q) const
{
    // In the plane through the axis and q: rho from the axis, sigma along it
    // from the apex centre. The flank's generator leaves the tangent point
    // T along g = (sin gamma, cos gamma); tau = (q - centre) . g is < 0 on
    // the apex's side of the line through the centre and T (the boundary of
    // the two parts' regions, inside the tip and out).
    const Eigen::Vector3d d = q - centre_;
    const double sigma = d.dot(axis_);
    const Eigen::Vector3d radial = d - sigma * axis_;
    const double rho = radial.norm();
    const double tau = rho * sin_g_ + sigma * cos_g_;
    const double dn = d.norm();
    if (tau < 0 && dn > kAxisGuard_nm) return {dn - r_, d / dn, TipPart::apex};
    const Eigen::Vector3d e = rho > kAxisGuard_nm ? Eigen::Vector3d(radial / rho) : e1_;
    // Distance to the generator's line (the vertex lies R / sin gamma below
    // the centre; written from the centre, so gamma = 0 needs no vertex).
    return {rho * cos_g_ - sigma * sin_g_ - r_, cos_g_ * e - sin_g_ * axis_, TipPart::flank};
}

TipContact TipGeometry::contact_at(const Eigen::Vector3d &q, double r) const
{
    const Nearest n = nearest(q);
    TipContact c;
    c.gap_nm = n.sd_nm - r;
    c.normal = -n.outward;
    c.on_tip_nm = q - n.sd_nm * n.outward;
    c.on_object_nm = q - r * n.outward;
    c.part = n.part;
    c.axial_nm = (c.on_tip_nm - apex_).dot(axis_);
    return c;
}

TipContact TipGeometry::sphere(const Eigen::Vector3d &centre_nm, double radius_nm) const
{
    if (!(radius_nm >= 0) || !std::isfinite(radius_nm)) refuse("sphere radius_nm " + num(radius_nm) + " is not finite and >= 0");
    if (!centre_nm.allFinite()) refuse("sphere centre is not finite");
    return contact_at(centre_nm, radius_nm);
}

double TipGeometry::segment_nearest(const Eigen::Vector3d &a, const Eigen::Vector3d &d) const
{
    // The tip's signed distance along a + u d is convex in u; its slope is
    // the outward normal's component along d (a subgradient on the axis).
    auto slope = [&](double u) { return nearest(a + u * d).outward.dot(d); };
    if (slope(0.0) >= 0) return 0.0;
    if (slope(1.0) <= 0) return 1.0;
    double lo = 0.0, hi = 1.0;
    for (;;) {
        const double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) return mid;   // the parameter's last bit
        (slope(mid) > 0 ? hi : lo) = mid;
    }
}

TipContact TipGeometry::cylinder(const Eigen::Vector3d &a_nm, const Eigen::Vector3d &b_nm, double radius_nm) const
{
    if (!(radius_nm >= 0) || !std::isfinite(radius_nm)) refuse("cylinder radius_nm " + num(radius_nm) + " is not finite and >= 0");
    if (!a_nm.allFinite() || !b_nm.allFinite()) refuse("cylinder end point is not finite");
    const Eigen::Vector3d d = b_nm - a_nm;
    const double len2 = d.squaredNorm();
    if (len2 < kShortSegment_nm * kShortSegment_nm) return contact_at(a_nm, radius_nm);
    // The apex's sphere: the segment's point nearest its centre, exact. It
    // is the answer when it lies in the apex's region (the tip's distance
    // there is the sphere's, whose minimum along the segment it is, and a
    // local minimum of a convex function is the minimum).
    const double ua = std::clamp((centre_ - a_nm).dot(d) / len2, 0.0, 1.0);
    const TipContact at_apex = contact_at(a_nm + ua * d, radius_nm);
    if (at_apex.part == TipPart::apex) return at_apex;
    return contact_at(a_nm + segment_nearest(a_nm, d) * d, radius_nm);
}

double TipGeometry::resting_reach_nm(double radius_nm, const Eigen::Vector2d &dir, bool cylinder, double half_length_nm) const
{
    if (!(radius_nm >= 0) || !std::isfinite(radius_nm)) refuse("reach radius_nm " + num(radius_nm) + " is not finite and >= 0");
    if (!(half_length_nm > 0) || !std::isfinite(half_length_nm)) refuse("reach half_length_nm " + num(half_length_nm) + " is not finite and > 0");
    if (!dir.allFinite() || std::fabs(dir.norm() - 1) > 1e-9) refuse("reach direction (" + num(dir.x()) + ", " + num(dir.y()) + ") is not a unit vector");
    if (radius_nm == 0) return 0.0;
    const Eigen::Vector3d d3(dir.x(), dir.y(), 0), across(-dir.y(), dir.x(), 0);
    auto gap = [&](double s) {
        const Eigen::Vector3d c = apex_ + s * d3 + Eigen::Vector3d(0, 0, radius_nm);
        return cylinder ? this->cylinder(c - half_length_nm * across, c + half_length_nm * across, radius_nm).gap_nm
                        : contact_at(c, radius_nm).gap_nm;
    };
    double lo = 0, hi = std::max(radius_nm, r_) + 1.0;
    while (gap(hi) < 0) {   // the gap grows without bound along the line, unless the tip is a plane (gamma 90 deg)
        lo = hi, hi *= 2;
        if (hi > kMaxReach_nm) refuse("no reach: the tip overlaps a resting object of radius_nm " + num(radius_nm) + " at any distance (half angle " + num(gamma_) + " rad)");
    }
    while (hi - lo > 1e-9 * std::max(1.0, hi)) {
        const double mid = 0.5 * (lo + hi);
        (gap(mid) < 0 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

TipContact TipGeometry::height_field(const HeightField &z, const HeightSearch &search) const
{
    // Polar about the apex's xy: the least along each ray (the step of an
    // edge is found in one dimension, whatever its direction), then the
    // least over the rays' azimuths, each by least_1d. The rays' spacing is
    // at most one pitch at the disc's rim; the azimuth's tolerance is
    // tol_nm of arc there.
    check_search(search);
    if (!z) refuse("height field is empty");
    const Eigen::Vector2d c = apex_.head<2>();
    const double rim = std::max(search.radius_nm, search.pitch_nm);
    const int rays = std::max(8, static_cast<int>(std::ceil(2 * M_PI * rim / search.pitch_nm)));
    double phi;
    const SurfacePoint best = least_1d([&](double a) { return ray_least(*this, z, c, a, search); }, -M_PI, 2 * M_PI / rays, rays - 1,
                                       search.starts, search.tol_nm / rim, &phi);
    return contact_at(best.p, 0.0);
}

LiftOff lift_off_push(const Lever &lever, const LiftInput &in)
{
    LiftOff out;
    const Eigen::Vector2d mC = lever.R.transpose() * in.motion;   // frame C per unit of push along the motion
    auto at = [&](double H) {
        const Eigen::Vector2d fC = -(H + in.friction_nN) * mC;       // the sample's force on the tip, frame C
        TipPose pose;
        pose.apex_nm = Eigen::Vector3d(in.apex_xy.x(), in.apex_xy.y(), 0.0);
        pose.tilt_rad = lever.bend_slope(fC.x(), in.load_nN);
        pose.twist_rad = lever.twist(fC.y());
        pose.alpha_rad = lever.alpha;
        return TipGeometry(in.radius_nm, in.half_angle_rad, pose).cylinder(in.a, in.b, in.cylinder_radius_nm);
    };
    const double lift = std::max(0.0, in.lift_nN);
    double H = 0;
    for (int i = 0; i < 32; ++i) {
        const TipContact c = at(H);
        out.normal = c.normal;
        out.part = c.part;
        out.iterations = i + 1;
        const double nh = c.normal.head<2>().norm(), nz = c.normal.z();
        if (!(nz > 0)) {
            out.push_nN = std::numeric_limits<double>::infinity();
            return out;
        }
        const double next = lift * nh / nz;
        const bool done = std::fabs(next - H) <= 1e-9 * std::max(1.0, next);
        H = next;
        if (done) break;
    }
    out.push_nN = H;
    return out;
}

}  // namespace afm::sim
