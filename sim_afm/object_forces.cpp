// Forces between objects: van der Waals by Hamaker and Derjaguin, Coulomb
// between charged spheres and rods (object_forces.hpp; physics.md 15).
#include "object_forces.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <string>

#include "process.hpp"

namespace afm::sim::objforce {

namespace {

using Eigen::Vector3d;

constexpr double kMaxRadiusNm = 1e9;
constexpr double kMaxChargeE = 1e9;
constexpr double kMaxHamakerAJ = 100.0;
constexpr double kMaxEpsR = 1e3;
constexpr int kGaussPoints = 16;

[[noreturn]] void refuse(const char *field, const char *want, double got)
{
    std::ostringstream o;
    o << "object forces: " << field << " must be " << want << ", got " << got;
    throw InputError(o.str());
}

void check_body(const char *which, const Body &b)
{
    const std::string w(which);
    if (!(b.radius_nm > 0 && b.radius_nm <= kMaxRadiusNm)) refuse((w + ".radius_nm").c_str(), "in (0, 1e9]", b.radius_nm);
    if (!(std::abs(b.charge_e) <= kMaxChargeE)) refuse((w + ".charge_e").c_str(), "within +-1e9", b.charge_e);
    if (!b.a_nm.allFinite() || !b.b_nm.allFinite()) refuse((w + ".position_nm").c_str(), "finite", b.a_nm.sum() + b.b_nm.sum());
}

void check_settings(const Settings &s)
{
    if (!(s.hamaker_aJ >= 0 && s.hamaker_aJ <= kMaxHamakerAJ)) refuse("hamaker_aJ", "in [0, 100]", s.hamaker_aJ);
    if (!(s.eps_r >= 1 && s.eps_r <= kMaxEpsR)) refuse("eps_r", "in [1, 1e3]", s.eps_r);
    if (!(s.range_nm > 0 && std::isfinite(s.range_nm))) refuse("range_nm", "positive and finite", s.range_nm);
}

// Gauss-Legendre nodes and weights on [-1, 1], by Newton on P_n (computed
// once; double precision to the last bits for n = 16).
struct Gauss {
    std::array<double, kGaussPoints> x{}, w{};
    Gauss()
    {
        const int n = kGaussPoints;
        for (int i = 0; i < n; ++i) {
            double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 0;
            for (int it = 0; it < 100; ++it) {
                double p0 = 1, p1 = 0;
                for (int k = 1; k <= n; ++k) {
                    const double p2 = p1;
                    p1 = p0;
                    p0 = ((2.0 * k - 1) * z * p1 - (k - 1.0) * p2) / k;
                }
                dp = n * (z * p0 - p1) / (z * z - 1);
                const double dz = p0 / dp;
                z -= dz;
                if (std::abs(dz) < 1e-16) break;
            }
            x[i] = z;
            w[i] = 2.0 / ((1 - z * z) * dp * dp);
        }
    }
};
const Gauss &gauss()
{
    static const Gauss g;
    return g;
}

// The nearest point of segment [a, b] to p.
Vector3d nearest_on_segment(const Vector3d &a, const Vector3d &b, const Vector3d &p)
{
    const Vector3d ab = b - a;
    const double len2 = ab.squaredNorm();
    if (len2 <= 0) return a;
    const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
    return a + t * ab;
}

// The least distance between segments [p1, q1] and [p2, q2], exact (the
// closest points' parameters in closed form, clamped to the segments;
// Ericson, Real-Time Collision Detection, 5.1.9). A segment of zero length
// is its point; parallel segments take the first's start.
double segments_distance(const Vector3d &p1, const Vector3d &q1, const Vector3d &p2, const Vector3d &q2)
{
    const Vector3d d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
    const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
    double s = 0, t = 0;
    if (a <= 0 && e <= 0) return r.norm();
    if (a <= 0) {
        t = std::clamp(f / e, 0.0, 1.0);
    } else if (e <= 0) {
        s = std::clamp(-d1.dot(r) / a, 0.0, 1.0);
    } else {
        const double b = d1.dot(d2), c = d1.dot(r), denom = a * e - b * b;
        s = denom > 0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
        t = (b * s + f) / e;
        if (t < 0) {
            t = 0;
            s = std::clamp(-c / a, 0.0, 1.0);
        } else if (t > 1) {
            t = 1;
            s = std::clamp((b - c) / a, 0.0, 1.0);
        }
    }
    return (p1 + s * d1 - (p2 + t * d2)).norm();
}

// The field (per unit of k / eps_r, in e/nm^2) at p of a charge q spread
// uniformly along [a, b]: closed form in the line's frame (header); a
// point on the segment itself has no direction: zero.
Vector3d line_field(const Vector3d &a, const Vector3d &b, double q, const Vector3d &p)
{
    const Vector3d ab = b - a;
    const double L = ab.norm();
    if (L <= 0) {
        const Vector3d d = p - a;
        const double r = d.norm();
        return r > 0 ? Vector3d(q * d / (r * r * r)) : Vector3d::Zero();
    }
    const Vector3d u = ab / L;
    const double sp = (p - a).dot(u);
    const Vector3d perp = (p - a) - sp * u;
    const double rho = perp.norm();
    const double s1 = -sp, s2 = L - sp;   // the ends' coordinates from p's foot
    const double lambda = q / L;
    const double r1 = std::hypot(rho, s1), r2 = std::hypot(rho, s2);
    if (r1 <= 0 || r2 <= 0 || (rho <= 0 && s1 < 0 && s2 > 0)) return Vector3d::Zero();
    const double E_u = lambda * (1 / r2 - 1 / r1);
    const double E_n = rho > 0 ? lambda / rho * (s2 / r2 - s1 / r1) : 0.0;
    return E_u * u + (rho > 0 ? Vector3d(E_n * perp / rho) : Vector3d::Zero());
}

// The field of a body's charge at p (k / eps_r units, as line_field).
Vector3d body_field(const Body &b, const Vector3d &p)
{
    if (b.kind == Body::Kind::sphere) return line_field(b.a_nm, b.a_nm, b.charge_e, p);
    return line_field(b.a_nm, b.b_nm, b.charge_e, p);
}

// Coulomb force on `second` from `first`, nN.
Vector3d coulomb(const Body &first, const Body &second, double eps_r)
{
    if (first.charge_e == 0 || second.charge_e == 0) return Vector3d::Zero();
    const double k = kCoulomb_nN_nm2 / eps_r;
    if (second.kind == Body::Kind::sphere) return k * second.charge_e * body_field(first, second.a_nm);
    const Gauss &g = gauss();
    Vector3d f = Vector3d::Zero();
    const Vector3d mid = 0.5 * (second.a_nm + second.b_nm), half = 0.5 * (second.b_nm - second.a_nm);
    for (int i = 0; i < kGaussPoints; ++i) {
        const double qi = second.charge_e * g.w[i] / 2;
        f += k * qi * body_field(first, mid + g.x[i] * half);
    }
    return f;
}

// Van der Waals force on `second` from `first`, and the gap.
PairForce van_der_waals(const Body &first, const Body &second, const Settings &s)
{
    PairForce out;
    const bool s1 = first.kind == Body::Kind::sphere, s2 = second.kind == Body::Kind::sphere;
    if (!s1 && !s2) {
        if (s.hamaker_aJ > 0) refuse("hamaker_aJ between two rods", "0 (rod-rod van der Waals is not modelled)", s.hamaker_aJ);
        out.gap_nm = segments_distance(first.a_nm, first.b_nm, second.a_nm, second.b_nm) - first.radius_nm - second.radius_nm;
        return out;
    }
    // The sphere's centre, and the nearest point of the other body's axis.
    const Body &sph = s1 ? first : second, &other = s1 ? second : first;
    const Vector3d c = sph.a_nm;
    const Vector3d q = other.kind == Body::Kind::sphere ? other.a_nm : nearest_on_segment(other.a_nm, other.b_nm, c);
    const Vector3d d = c - q;   // from the other towards the sphere
    const double r = d.norm();
    out.gap_nm = r - sph.radius_nm - other.radius_nm;
    if (s.hamaker_aJ <= 0 || r <= 0 || out.gap_nm > s.range_nm) return out;
    const double F = other.kind == Body::Kind::sphere
                         ? vdw_sphere_sphere_force(s.hamaker_aJ, other.radius_nm, sph.radius_nm, r)
                         : vdw_sphere_rod_force(s.hamaker_aJ, sph.radius_nm, other.radius_nm, out.gap_nm);
    const Vector3d on_sphere = F * d / r;   // F > 0 repulsive: along d
    out.on_second_nN = &sph == &second ? on_sphere : Vector3d(-on_sphere);
    return out;
}

}  // namespace

// Scaling: A in aJ = nN nm, lengths in nm: U in aJ, F in nN. The gap is
// held at kContactCutoffNm from below (header).
double vdw_sphere_sphere_energy(double A, double R1, double R2, double r)
{
    const double s = R1 + R2, d = R1 - R2;
    r = std::max(r, s + kContactCutoffNm);
    const double a = r * r - s * s, b = r * r - d * d;
    return -A / 6 * (2 * R1 * R2 / a + 2 * R1 * R2 / b + std::log(a / b));
}

double vdw_sphere_sphere_force(double A, double R1, double R2, double r)
{
    const double s = R1 + R2, d = R1 - R2;
    r = std::max(r, s + kContactCutoffNm);
    const double a = r * r - s * s, b = r * r - d * d;
    // F = -dU/dr of the energy above, differentiated term by term.
    return A / 6 * (-4 * R1 * R2 * r / (a * a) - 4 * R1 * R2 * r / (b * b) + 2 * r / a - 2 * r / b);
}

double vdw_sphere_rod_force(double A, double R, double Rc, double gap)
{
    const double D = std::max(gap, kContactCutoffNm);
    return -A / (6 * D * D) / std::sqrt((1 / R + 1 / Rc) * (1 / R));
}

PairForce between(const Body &first, const Body &second, const Settings &s)
{
    check_body("first", first);
    check_body("second", second);
    check_settings(s);
    PairForce out = van_der_waals(first, second, s);
    out.on_second_nN += coulomb(first, second, s.eps_r);
    return out;
}

}  // namespace afm::sim::objforce
