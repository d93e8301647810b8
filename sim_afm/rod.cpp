// The rigid rod (wire.hpp: rod_push_twist, RigidWire): its friction power
// minimised over the twist a push leaves it.

#include "wire.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "wire_internal.hpp"

namespace afm::sim {

namespace {
// Velocity floor of the reweighting (per unit push travel): keeps a friction
// point that sits on the rotation centre from getting an infinite weight.
constexpr double kVelocityFloor = 1e-9;
// A rod with uniform friction: a rotation centre closer to the axis than
// kIcrFloor L is taken that far off it, so that the friction power's
// curvature (log-divergent when the centre lies on the rod) stays finite.
constexpr double kIcrFloor = 1e-12;
// The rod's friction power is integrated in closed form when its rotation
// centre lies within one rod length of it, and by 10-point Gauss-Legendre
// quadrature when it lies farther (then the integrand is analytic over a
// Bernstein ellipse of parameter >= 2 + sqrt 5, the error of order
// (2 + sqrt 5)^-20 < 1e-12 relative; there the closed forms would cancel).
constexpr int kGaussPoints = 5;   // positive nodes of the symmetric 10-point rule
constexpr double kGaussNode[kGaussPoints] = {0.1488743389816312, 0.4333953941292472, 0.6794095682990244,
                                             0.8650633666889845, 0.9739065285171717};
constexpr double kGaussWeight[kGaussPoints] = {0.2955242247147529, 0.2692667193099963, 0.2190863625159820,
                                               0.1494513491505806, 0.0666713443086881};
// An oblique push whose tangential part |p_t| is below this starts from the
// side push's twist when that dissipates less than the warm one.
constexpr double kRodNearSide = 0.1;
}  // namespace

using detail::kArmijo;
using detail::kMaxHalvings;

RodTwist rod_push_twist(const std::vector<double> &u, double w, double up, const Eigen::Vector2d &p,
                        const RodTwist &warm, double tol, int max_iter, const std::vector<Eigen::Matrix2d> *metric)
{
    // Unknowns x = (vt, vn, omega); the contact point's velocity is
    // (vt, vn + omega up) and the constraint c . x = 1 makes it advance by one
    // unit along p. Friction power D(x) = sum_k w |G_k (vt, vn + omega u_k)|
    // (G_k = I on a plain substrate; anisotropic where a trench holds the
    // wire).
    RodTwist out;
    if (!(w > 0)) {   // no friction: nothing selects a motion but the push itself
        out.vt = p.x() / p.squaredNorm();
        out.vn = p.y() / p.squaredNorm();
        return out;
    }
    const Eigen::Vector3d c(p.x(), p.y(), p.y() * up);
    Eigen::Vector3d x(warm.vt, warm.vn, warm.omega);
    double cx = c.dot(x);
    if (!(std::fabs(cx) > 1e-6)) {
        x = c / c.squaredNorm();
        cx = 1.0;
    }
    x /= cx;
    auto vel = [&](const Eigen::Vector3d &v, std::size_t k) {
        const Eigen::Vector2d vk(v[0], v[1] + v[2] * u[k]);
        return metric ? Eigen::Vector2d((*metric)[k] * vk) : vk;
    };
    int it = 0;
    for (; it < max_iter; ++it) {
        // Minimise sum_k a_k |G_k A_k x|^2 subject to c . x = 1, a_k = w / |G_k A_k x|:
        // x = M^-1 c / (c . M^-1 c).
        Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
        if (!metric) {
            double sa = 0, sau = 0, sau2 = 0;
            for (double uk : u) {
                const double vn = x[1] + x[2] * uk;
                const double a = w / std::max(std::sqrt(x[0] * x[0] + vn * vn), kVelocityFloor);
                sa += a;
                sau += a * uk;
                sau2 += a * uk * uk;
            }
            M << sa, 0, 0, 0, sa, sau, 0, sau, sau2;
        } else {
            for (std::size_t k = 0; k < u.size(); ++k) {
                const double a = w / std::max(vel(x, k).norm(), kVelocityFloor);
                Eigen::Matrix<double, 2, 3> A;
                A << 1, 0, 0, 0, 1, u[k];
                const Eigen::Matrix<double, 2, 3> GA = (*metric)[k] * A;
                M += a * GA.transpose() * GA;
            }
        }
        const Eigen::Vector3d y = M.ldlt().solve(c);
        const Eigen::Vector3d xn = y / c.dot(y);
        const bool done = (xn - x).norm() <= tol * xn.norm();
        x = xn;
        if (done) break;
    }
    double D = 0;
    for (std::size_t k = 0; k < u.size(); ++k) D += w * vel(x, k).norm();
    out.vt = x[0];
    out.vn = x[1];
    out.omega = x[2];
    out.force_nN = D;
    out.iterations = std::min(it + 1, max_iter);
    return out;
}

namespace {

// The friction power of a rod of length L with uniform friction density f,
// D(x) = f int_{-L/2}^{L/2} |(vt, vn + omega u)| du, with its gradient and
// Hessian, in the scaled twist xs = (vt, vn, omega L) (all three per unit of
// push travel, dimensionless): D in nN, g = dD/dxs in nN, H in nN.
struct RodPower {
    double D = 0;
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
};

// Far rotation centre (or a translation): 10-point Gauss-Legendre in u;
// derivatives with respect to the unscaled (vt, vn, omega).
RodPower rod_power_far(double L, double f, double vt, double vn, double w)
{
    RodPower P;
    for (int k = 0; k < 2 * kGaussPoints; ++k) {
        const double uk = 0.5 * L * (k < kGaussPoints ? kGaussNode[k] : -kGaussNode[k - kGaussPoints]);
        const double W = 0.5 * L * f * kGaussWeight[k % kGaussPoints];
        const double z = vn + w * uk, r = std::sqrt(vt * vt + z * z);
        P.D += W * r;
        const Eigen::Vector3d a(vt, z, uk * z);                 // A^T v, per unit of r
        const Eigen::Vector3d b(-z, vt, uk * vt);               // A^T v_perp
        P.g += (W / r) * a;
        P.H += (W / (r * r * r)) * b * b.transpose();
    }
    return P;
}

// Rotation centre within a rod length: closed forms in the centre's
// coordinates (a along the axis from the middle, h off it; v(u) =
// omega (h, u - a), y = u - a, rho = sqrt(h^2 + y^2)).
RodPower rod_power_near(double L, double f, double vt, double vn, double w)
{
    const double a = -vn / w, sg = w > 0 ? 1.0 : -1.0;
    double h = vt / w;
    if (std::fabs(h) < kIcrFloor * L) h = h < 0 ? -kIcrFloor * L : kIcrFloor * L;
    const double s = std::fabs(h), s2 = h * h;
    // Antiderivatives at y, differences between the rod's ends.
    double J0 = 0, Jinv = 0, Jy = 0, Jyy = 0, Kyy = 0, Ky = 0, hK1 = 0;
    for (int e = 0; e < 2; ++e) {
        const double y = (e ? 0.5 * L : -0.5 * L) - a, sign = e ? 1.0 : -1.0;
        const double rho = std::sqrt(s2 + y * y), A = std::asinh(y / s);
        J0 += sign * 0.5 * (y * rho + s2 * A);     // int rho
        Jinv += sign * A;                          // int 1 / rho
        Jy += sign * rho;                          // int y / rho
        Jyy += sign * 0.5 * (y * rho - s2 * A);    // int y^2 / rho
        Kyy += sign * (A - y / rho);               // int y^2 / rho^3
        Ky += sign * (-1.0 / rho);                 // int y / rho^3
        hK1 += sign * (y / rho);                   // h^2 int 1 / rho^3
    }
    RodPower P;
    const double aw = std::fabs(w), k = f / aw;
    P.D = f * aw * J0;
    P.g << f * sg * h * Jinv, f * sg * Jy, f * sg * (Jyy + a * Jy) / L;
    P.H(0, 0) = k * Kyy;
    P.H(0, 1) = P.H(1, 0) = -k * h * Ky;
    P.H(0, 2) = P.H(2, 0) = -k * h * (Kyy + a * Ky) / L;
    P.H(1, 1) = k * hK1;
    P.H(1, 2) = P.H(2, 1) = k * (s2 * Ky + a * hK1) / L;
    P.H(2, 2) = k * (s2 * (Kyy + 2 * a * Ky) + a * a * hK1) / (L * L);
    return P;
}

RodPower rod_power(double L, double f, const Eigen::Vector3d &xs)
{
    const double vt = xs[0], vn = xs[1], w = xs[2] / L;
    // The centre's distance from the rod, times |omega|, against L |omega|.
    const double off = std::max(std::fabs(vn) - 0.5 * std::fabs(w) * L, 0.0);
    if (off * off + vt * vt > w * w * L * L) {
        RodPower P = rod_power_far(L, f, vt, vn, w);
        P.g[2] /= L;          // d/d(omega L) = (1/L) d/d(omega)
        P.H.row(2) /= L;
        P.H.col(2) /= L;
        return P;
    }
    return rod_power_near(L, f, vt, vn, w);
}

// Eq. 20: a side push on a rod with uniform friction.
RodTwist rod_side_push(double L, double f, double up, double pn)
{
    RodTwist out;
    out.vt = 0;
    if (std::fabs(up) <= kRodMiddle * L) {   // the middle: translation, the whole friction f L
        out.vn = 1.0 / pn;
        out.omega = 0;
        out.force_nN = f * L / std::fabs(pn);
        return out;
    }
    // Static point at axial position a (from the middle), on the far side of
    // the middle from the push: |a| <= L/2, |up - a| >= L/2.
    const double a = up - std::copysign(std::sqrt(up * up + 0.25 * L * L), up);
    out.omega = 1.0 / (pn * (up - a));
    out.vn = -out.omega * a;
    out.force_nN = f * std::fabs(out.omega) * (0.25 * L * L + a * a);   // f |omega| int |u - a| du
    return out;
}

// A backtracking (Armijo) line search for rod_oblique_push along Q dy from
// xs, whose power is P and slope along dy `slope` (< 0); halves the step up
// to kMaxHalvings times. True (xs, P moved) when a step passes.
bool rod_line_search(double L, double f, const Eigen::Matrix<double, 3, 2> &Q, const Eigen::Vector2d &dy, double slope,
                     Eigen::Vector3d &xs, RodPower &P)
{
    double alpha = 1;
    for (int ls = 0; ls < kMaxHalvings; ++ls, alpha *= 0.5) {
        const Eigen::Vector3d xt = xs + alpha * (Q * dy);
        const RodPower Pt = rod_power(L, f, xt);
        if (Pt.D <= P.D + kArmijo * alpha * slope) {
            xs = xt;
            P = Pt;
            return true;
        }
    }
    return false;
}

// An oblique push (an end cap's contact) on a rod with uniform friction:
// Newton's method on D over the plane c . xs = 1 (c: the push's scaled
// constraint), from xs (on it). D is convex; its Hessian on the plane may
// be near singular (near a side push, or at a translation, the curvature
// across the axis vanishes), so a step changes the twist by at most its
// own size, and a Newton step that fails the line search gives way to the
// projected gradient's. Stops when the gradient is parallel to c to `tol`,
// when the Newton decrement is below rounding (1e-15 of D), or when no step
// lowers D (at the minimum to rounding), or after max_iter steps.
RodTwist rod_oblique_push(double L, double f, const Eigen::Vector3d &c, Eigen::Vector3d xs, double tol, int max_iter)
{
    const Eigen::Vector3d q1 = c.unitOrthogonal(), q2 = c.normalized().cross(q1);
    Eigen::Matrix<double, 3, 2> Q;
    Q << q1, q2;
    RodPower P = rod_power(L, f, xs);
    int it = 0;
    for (; it < max_iter; ++it) {
        // Stationary on the plane: the gradient (the friction's force and
        // torque) parallel to c (the push's).
        const Eigen::Vector2d r = Q.transpose() * P.g;
        if (r.norm() <= tol * P.g.norm()) break;
        const Eigen::Matrix2d Hr = Q.transpose() * P.H * Q;
        Eigen::Vector2d dy = -Hr.ldlt().solve(r);
        double slope = r.dot(dy);
        if (!(slope < 0) || !dy.allFinite()) {   // no Newton direction (singular): none
            dy.setZero();
            slope = 0;
        }
        if (slope < 0 && -slope <= 1e-15 * P.D) break;
        const double cap = xs.norm() / dy.norm();   // Q has orthonormal columns
        if (cap < 1) {
            dy *= cap;
            slope *= cap;
        }
        if (slope < 0 && rod_line_search(L, f, Q, dy, slope, xs, P)) continue;
        // The projected gradient, as long as the twist.
        const Eigen::Vector2d dg = -r * (xs.norm() / r.norm());
        if (!rod_line_search(L, f, Q, dg, r.dot(dg), xs, P)) break;
    }
    RodTwist out;
    out.vt = xs[0];
    out.vn = xs[1];
    out.omega = xs[2] / L;
    out.force_nN = P.D;
    out.iterations = it;
    return out;
}

}  // namespace

RodTwist rod_push_twist_uniform(double L, double f, double up, const Eigen::Vector2d &p, const RodTwist &warm,
                                double tol, int max_iter)
{
    const double p2 = p.squaredNorm();
    if (!(L > 0) || !(f > 0) || !(p2 > 0)) {   // nothing resists: translation along p
        RodTwist out;
        out.vt = p2 > 0 ? p.x() / p2 : 0.0;
        out.vn = p2 > 0 ? p.y() / p2 : 0.0;
        out.force_nN = std::max(L, 0.0) * std::max(f, 0.0);
        return out;
    }
    up = std::clamp(up, -0.5 * L, 0.5 * L);
    if (std::fabs(p.x()) <= kRodPerpendicular * std::sqrt(p2)) return rod_side_push(L, f, up, p.y());
    // Scaled twist xs = (vt, vn, omega L); the constraint c . xs = 1. The
    // start: the warm twist when it advances the contact point; near a side
    // push (|p_t| < kRodNearSide), the side push's twist instead if it
    // dissipates less (the warm twist may be a translation, from which the
    // curvature across the axis vanishes); without a warm twist, the side
    // push's or the translation along p, whichever dissipates less.
    const Eigen::Vector3d c(p.x(), p.y(), p.y() * up / L);
    const Eigen::Vector3d warm_xs(warm.vt, warm.vn, warm.omega * L);
    const double cw = c.dot(warm_xs);
    const bool has_warm = cw > 1e-6 * warm_xs.norm() * c.norm();
    Eigen::Vector3d xs = has_warm ? Eigen::Vector3d(warm_xs / cw) : Eigen::Vector3d(Eigen::Vector3d(p.x(), p.y(), 0) / p2);
    if (p.y() != 0 && (!has_warm || std::fabs(p.x()) < kRodNearSide * std::sqrt(p2))) {
        const RodTwist side = rod_side_push(L, f, up, p.y());
        const Eigen::Vector3d xside = Eigen::Vector3d(0, side.vn, side.omega * L) / c.dot(Eigen::Vector3d(0, side.vn, side.omega * L));
        if (rod_power(L, f, xside).D < rod_power(L, f, xs).D) xs = xside;
    }
    return rod_oblique_push(L, f, c, xs, tol, max_iter);
}

RigidWire::RigidWire(int id_, const Eigen::Vector2d &a, const Eigen::Vector2d &b, double d, double f_, int K) : f(f_)
{
    id = id_;
    d_nm = d;
    L_nm = (b - a).norm();
    place(0.5 * (a + b), std::atan2(b.y() - a.y(), b.x() - a.x()));
    // Midpoint rule: K equal pieces, each carrying f L / K at its middle.
    u.resize(K);
    for (int k = 0; k < K; ++k) u[k] = -0.5 * L_nm + (k + 0.5) * L_nm / K;
}

void RigidWire::place(const Eigen::Vector2d &c, double angle)
{
    centre = c;
    psi = angle;
    const Eigen::Vector2d t(std::cos(psi), std::sin(psi));
    x = {centre - 0.5 * L_nm * t, centre + 0.5 * L_nm * t};
    update_box();
}

bool RigidWire::push(const Eigen::Vector2d &q, double r_tip, double k, double ride_nN)
{
    double pen, u_from_a;
    Eigen::Vector2d n;
    contact(q, r_tip, pen, n, u_from_a);
    const double F = contact_force(k, pen);
    in_contact = F > 0;
    squeezed = false;
    ridden = false;
    if (!in_contact) return false;
    const Eigen::Vector2d t(std::cos(psi), std::sin(psi)), nr(-std::sin(psi), std::cos(psi));
    const Eigen::Vector2d p = -n;   // the tip pushes the wire away from itself
    // Where a trench holds the wire, its friction is anisotropic: f along the
    // trench, hold x f across it (G = a a^T + hold b b^T in the rod frame).
    // Within a sample's step (begin_step .. end_step: no trench is cut
    // meanwhile) the metric depends on the pose alone: a push that left the
    // rod where it was (static, as most of a sample's sweeps) keeps it.
    const bool same_pose = metric_valid_ && centre == metric_centre_ && psi == metric_psi_;
    bool held = same_pose && held_points > 0;
    if (trap && !same_pose) {
        held_points = 0;
        metric_valid_ = in_step_, metric_centre_ = centre, metric_psi_ = psi;
        metric_.assign(u.size(), Eigen::Matrix2d::Identity());
        for (std::size_t k = 0; k < u.size(); ++k) {
            Eigen::Vector2d along;
            double hold;
            if (!trap(centre + u[k] * t, d_nm, along, hold)) continue;
            const Eigen::Vector2d a(along.dot(t), along.dot(nr)), b(-a.y(), a.x());
            metric_[k] = a * a.transpose() + hold * b * b.transpose();
            held = true;
            ++held_points;
        }
    }
    // Uniform friction: exact (closed form, or Newton on the exact power for
    // an end cap's oblique push); a trench under part of it: the K points.
    const Eigen::Vector2d p_rod(p.dot(t), p.dot(nr));
    const double u_p = u_from_a - 0.5 * L_nm;
    if (held)
        last = rod_push_twist(u, f * L_nm / static_cast<double>(u.size()), u_p, p_rod, last, 1e-7, 60, &metric_);
    else if (numeric)   // independent of eq. 20 (sample.wire.solver: numeric)
        last = rod_push_twist(u, f * L_nm / static_cast<double>(u.size()), u_p, p_rod, last, 1e-7, 60);
    else
        last = rod_push_twist_uniform(L_nm, f, u_p, p_rod, last);
    // down_force: the push H presses the rod by H tan psi, spread over it as
    // its own load (eq. 29): D(H) = D0 (1 + mu H tan psi / (f L)), so H moves
    // it when H a > D0 with a = 1 - (D0 / f L) mu tan psi; a <= 0: squeezed.
    // A rod a trench holds is not pressed: the walls carry the cone's down
    // force (the firmware's model, fw_wire.h "Trenches", does the same).
    const double press = held ? 0.0 : mu * press_tan;
    const double a = press > 0 && f > 0 ? 1.0 - last.force_nN / (f * L_nm) * press : 1.0;
    squeezed = !(a > 0);
    // The tip lifts before the rod yields when the rod needs more than the
    // tip can push (squeezed: no push is enough) and the contact got there.
    const double D = squeezed ? std::numeric_limits<double>::infinity() : last.force_nN / a;
    ridden = D > ride_nN && F > ride_nN;
    if (squeezed || ridden) return false;
    if (F <= D) return false;   // inside the limit surface: static
    // Advance the contact point along p until the contact force is back on the
    // limit surface: (F - D) / k of travel.
    const double travel = (F - D) / k;
    // Rigid motion about the instantaneous centre, integrated exactly for a
    // constant twist over the step (rotation about the centre of rotation,
    // or translation when omega vanishes).
    const double dpsi = last.omega * travel;
    const Eigen::Vector2d v = travel * (last.vt * t + last.vn * nr);   // centre's displacement to first order
    Eigen::Vector2d c = centre + v;
    if (std::fabs(dpsi) > 1e-12) {
        const double s = std::sin(dpsi), cm = 1 - std::cos(dpsi);
        // Centre moves along the arc about the rotation centre: v (sin dpsi / dpsi) + perp(v) (1 - cos dpsi) / dpsi.
        const Eigen::Vector2d perp(-v.y(), v.x());
        c = centre + (s * v + cm * perp) / dpsi;
    }
    place(c, psi + dpsi);
    return true;
}


}  // namespace afm::sim
