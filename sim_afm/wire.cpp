#include "wire.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
// Armijo's sufficient decrease (both line searches), as a fraction of the
// first-order decrease.
constexpr double kArmijo = 1e-4;
// The flexible wire's step: regularisation length of the nodes' Coulomb
// friction (nm); a node that ends within stuck_nm of its start sticks (nm);
// the solve stops when every node's force residual is
// below kResidual of its friction c_i (plus kResidualFloor_nN).
constexpr double kSlipRegularisation_nm = 1e-6;
// Stuck: the regularised friction c_i |dx| / sqrt(|dx|^2 + eps^2) is below
// 0.999 c_i, |dx| < 22.3 eps.
constexpr double stuck_nm = 22.3 * kSlipRegularisation_nm;
constexpr double kResidual = 1e-5;
constexpr double kResidualFloor_nN = 1e-7;
constexpr int kMaxHalvings = 30;
// When the flexible wire's Newton system does not factor
// (BlockPentadiagonal::kPivot: singular, as a wire without friction, whose
// rigid motions cost nothing) the step is solved with H + shift I, shift =
// kShift times the largest block trace, raised 1000-fold up to kMaxShifts
// times.
constexpr double kShift = 1e-12;
constexpr int kMaxShifts = 6;
// FlexibleWire::follow scales the last increment only when the contact
// point moved by more than this in it (nm): below, the ratio means nothing.
constexpr double kFollowFloor_nm = 1e-9;
}  // namespace

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

double segment_param(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &q)
{
    const Eigen::Vector2d ab = b - a;
    const double l2 = ab.squaredNorm();
    if (l2 <= 0) return 0.0;
    return std::clamp((q - a).dot(ab) / l2, 0.0, 1.0);
}

namespace {

// The segment of the polyline xs (at least two points) closest to q, the
// first of equals, and its parameter t in [0, 1]. The search compares
// squared distances as fractions num / den against the best so far without
// dividing (the divider bounds such loops); t follows for the winner only.
std::size_t closest_segment(const std::vector<Eigen::Vector2d> &xs, const Eigen::Vector2d &q, double &t)
{
    double best2 = std::numeric_limits<double>::infinity();
    std::size_t best = 0;
    for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
        const Eigen::Vector2d ab = xs[i + 1] - xs[i], qa = q - xs[i];
        const double dot = qa.dot(ab), l2 = ab.squaredNorm();
        double num, den = 1;
        if (dot <= 0) {
            num = qa.squaredNorm();
        } else if (dot >= l2) {
            num = (q - xs[i + 1]).squaredNorm();
        } else {   // |qa|^2 - dot^2 / l2, kept as a fraction
            num = qa.squaredNorm() * l2 - dot * dot;
            den = l2;
        }
        if (num < best2 * den) {
            best2 = num / den;
            best = i;
        }
    }
    t = segment_param(xs[best], xs[best + 1], q);
    return best;
}

}  // namespace

void Wire::update_box()
{
    lo = hi = x.front();
    for (const auto &p : x) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
}

double Wire::axis_distance(const Eigen::Vector2d &q) const
{
    const auto &xs = x;
    double best = 1e300;
    for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
        const double t = segment_param(xs[i], xs[i + 1], q);
        best = std::min(best, (q - (xs[i] + t * (xs[i + 1] - xs[i]))).norm());
    }
    return best;
}

bool Wire::contact(const Eigen::Vector2d &q, double r_tip, double &pen, Eigen::Vector2d &n_out, double &u_out) const
{
    const auto &xs = x;
    double t;
    const std::size_t best = closest_segment(xs, q, t);
    double arc = 0;
    for (std::size_t i = 0; i < best; ++i) arc += (xs[i + 1] - xs[i]).norm();
    const Eigen::Vector2d ab = xs[best + 1] - xs[best];
    const Eigen::Vector2d d = q - (xs[best] + t * ab);
    const double dn = d.norm();
    pen = r_tip + 0.5 * d_nm - dn;
    n_out = dn > 1e-12 ? Eigen::Vector2d(d / dn) : Eigen::Vector2d(-ab.y(), ab.x()).normalized();
    u_out = arc + t * ab.norm();
    return pen > 0;
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
    in_contact = contact(q, r_tip, pen, n, u_from_a);
    squeezed = false;
    ridden = false;
    if (!in_contact) return false;
    const Eigen::Vector2d t(std::cos(psi), std::sin(psi)), nr(-std::sin(psi), std::cos(psi));
    const Eigen::Vector2d p = -n;   // the tip pushes the wire away from itself
    // Where a trench holds the wire, its friction is anisotropic: f along the
    // trench, hold x f across it (G = a a^T + hold b b^T in the rod frame).
    bool held = false;
    held_points = 0;
    if (trap) {
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
    const double F = k * pen;
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

FlexibleWire::FlexibleWire(int id_, const Eigen::Vector2d &a, const Eigen::Vector2d &b, double d, double f_, double E_GPa,
                           int N, int iters)
    : f(f_), max_iterations(iters)
{
    id = id_;
    d_nm = d;
    L_nm = (b - a).norm();
    ds = L_nm / N;
    for (int i = 0; i <= N; ++i) x.push_back(a + (b - a) * (static_cast<double>(i) / N));
    update_box();
    // 1 GPa = 1 nN/nm^2.
    EI = E_GPa * M_PI * std::pow(d, 4) / 64.0;
    ks = E_GPa * M_PI * d * d / 4.0 / ds;
    const std::size_t nn = x.size();
    for (auto *v : {&start_, &base_, &dir_}) v->assign(nn, Eigen::Vector2d::Zero());
    H_.resize(static_cast<int>(nn));
    for (Eval *ev : {&now_, &trial_}) {
        ev->g.assign(nn, Eigen::Vector2d::Zero());
        ev->seg_dir.assign(nn, Eigen::Vector2d::Zero());
        ev->node_dir.assign(nn, Eigen::Vector2d::Zero());
        ev->node_w.assign(nn, 0.0);
    }
}

double FlexibleWire::closest(const Eigen::Vector2d &q, int &seg, double &t) const
{
    seg = static_cast<int>(closest_segment(x, q, t));
    return (q - (x[seg] + t * (x[seg + 1] - x[seg]))).norm();
}

double FlexibleWire::node_friction(int i) const
{
    const int last_node = static_cast<int>(x.size()) - 1;
    return f * ds * ((i == 0 || i == last_node) ? 0.5 : 1.0);
}

// The tip's contact at the point of segment c.seg closest to the apex: its
// energy, nN nm, and the forces *fa, *fb on that segment's nodes (ev's
// contact fields set).
double FlexibleWire::contact_energy(const Contact &c, const Eigen::Vector2d *xs, Eval &ev, Eigen::Vector2d *fa, Eigen::Vector2d *fb)
{
    const int i = c.seg;
    ev.contact_t = segment_param(xs[i], xs[i + 1], c.q);
    const Eigen::Vector2d dv = c.q - (xs[i] + ev.contact_t * (xs[i + 1] - xs[i]));
    const double dn = dv.norm(), pen = c.reach - dn;
    ev.touching = pen > 0;
    if (!ev.touching) return 0;
    ev.contact_n = dn > 1e-12 ? Eigen::Vector2d(dv / dn) : c.n0;
    *fa = c.kc * pen * (1 - ev.contact_t) * ev.contact_n;
    *fb = c.kc * pen * ev.contact_t * ev.contact_n;
    return 0.5 * c.kc * pen * pen;
}

double FlexibleWire::evaluate(const Contact &c, Eval &ev, bool at_start) const
{
    // Energy, nN nm; ev at x (see Eval). One pass over the nodes: node i's
    // force gathers the springs of segments i - 1 and i, the bending of the
    // triples centred on i - 1, i and i + 1 (b_j = x_{j-1} - 2 x_j + x_{j+1},
    // zero where the triple does not exist), the tip's contact and its
    // friction. Plain pointers: the arrays do not alias, and the compiler
    // cannot know it through ev. at_start: x is start_ (every increment is
    // zero), which spares the friction's roots.
    const int nn = static_cast<int>(x.size());
    const double kb = EI / (ds * ds * ds);
    const double eps = kSlipRegularisation_nm;
    const Eigen::Vector2d *xs = x.data(), *x0 = start_.data();
    Eigen::Vector2d *g = ev.g.data(), *seg_dir = ev.seg_dir.data(), *node_dir = ev.node_dir.data();
    double *node_w = ev.node_w.data();
    Eigen::Vector2d fa = Eigen::Vector2d::Zero(), fb = Eigen::Vector2d::Zero();
    const double e = contact_energy(c, xs, ev, &fa, &fb);
    // Coulomb friction c_i |dx_i|, regularised as c_i (sqrt(|dx_i|^2 +
    // eps^2) - eps). A node is in balance when stuck (within stuck_nm of its
    // start) with an elastic and contact force of at most c_i (the Coulomb
    // law itself), or sliding with that force and its (regularised)
    // friction cancelling, both to its tolerance kResidual c_i (+ floor).
    // ev.residual: the worst node's imbalance as a ratio of squares, below 1
    // exactly when every node is in balance.
    const double c_in = f * ds, c_end = 0.5 * f * ds;
    const double tol_in = kResidual * c_in + kResidualFloor_nN, tol_end = kResidual * c_end + kResidualFloor_nN;
    auto inv_sq = [](double v) { return 1.0 / (v * v); };
    const double stuck_in = inv_sq(c_in + tol_in), stuck_end = inv_sq(c_end + tol_end);
    const double slide_in = inv_sq(tol_in), slide_end = inv_sq(tol_end);
    const double eps_root = std::sqrt(eps * eps), inv_eps_root = 1.0 / eps_root;
    double e_stretch = 0, e_bend = 0, e_friction = 0, worst = 0;
    Eigen::Vector2d fs_before = Eigen::Vector2d::Zero();   // spring force of segment i - 1 on node i
    Eigen::Vector2d b_before = Eigen::Vector2d::Zero();    // b_{i-1}
    Eigen::Vector2d b_here = Eigen::Vector2d::Zero();      // b_i
    for (int i = 0; i < nn; ++i) {
        Eigen::Vector2d fs = Eigen::Vector2d::Zero();
        if (i + 1 < nn) {   // segment i: ks / 2 (|x_{i+1} - x_i| - ds)^2
            const Eigen::Vector2d ed = xs[i + 1] - xs[i];
            const double len = ed.norm(), dl = len - ds;
            e_stretch += dl * dl;
            seg_dir[i] = ed * (1.0 / len);
            fs = (ks * dl) * seg_dir[i];
        }
        const Eigen::Vector2d b_after = i + 2 < nn ? Eigen::Vector2d(xs[i] - 2 * xs[i + 1] + xs[i + 2]) : Eigen::Vector2d::Zero();
        e_bend += b_after.squaredNorm();
        Eigen::Vector2d gi = fs_before - fs + kb * (b_before - 2 * b_here + b_after);
        if (i == c.seg) gi += fa;
        if (i == c.seg + 1) gi += fb;
        fs_before = fs;
        b_before = b_here;
        b_here = b_after;
        const bool end = i == 0 || i == nn - 1;
        const double ci = end ? c_end : c_in;
        if (at_start) {   // |dx| = 0: s = eps, no friction force, every node stuck
            node_w[i] = ci / eps;
            node_dir[i].setZero();
            worst = std::max(worst, gi.squaredNorm() * (end ? stuck_end : stuck_in));
            g[i] = gi;
            continue;
        }
        const Eigen::Vector2d dx = xs[i] - x0[i];
        const double d2 = dx.squaredNorm();
        // A node still at its start (most of a long chain's, on a first
        // guess) needs no root.
        const double sr = d2 == 0 ? eps_root : std::sqrt(d2 + eps * eps), inv = d2 == 0 ? inv_eps_root : 1.0 / sr;
        e_friction += ci * (sr - eps);
        node_w[i] = ci * inv;
        node_dir[i] = dx * inv;
        const bool stuck = d2 < stuck_nm * stuck_nm;
        if (stuck) worst = std::max(worst, gi.squaredNorm() * (end ? stuck_end : stuck_in));
        gi += node_w[i] * dx;
        if (!stuck) worst = std::max(worst, gi.squaredNorm() * (end ? slide_end : slide_in));
        g[i] = gi;
    }
    ev.residual = worst;
    return e + 0.5 * ks * e_stretch + 0.5 * kb * e_bend + e_friction;
}

double FlexibleWire::elastic_curvature(const Contact &c, const Eval &ev, const std::vector<Eigen::Vector2d> &d) const
{
    // d^T H d for the elastic and contact parts of H at the point ev was
    // evaluated at (nN nm per nm^2 of d).
    const int nn = static_cast<int>(x.size());
    const double kb = EI / (ds * ds * ds);
    double q = 0;
    for (int i = 1; i + 1 < nn; ++i) q += kb * (d[i - 1] - 2 * d[i] + d[i + 1]).squaredNorm();
    for (int i = 0; i + 1 < nn; ++i) {
        const double a = ev.seg_dir[i].dot(d[i + 1] - d[i]);
        q += ks * a * a;
    }
    if (ev.touching) {
        const double a = ev.contact_n.dot((1 - ev.contact_t) * d[c.seg] + ev.contact_t * d[c.seg + 1]);
        q += c.kc * a * a;
    }
    return q;
}

void FlexibleWire::assemble_hessian(const Contact &c, const Eval &ev)
{
    // Blocks of H (nN/nm) at the point ev was evaluated at: H_.diag[i] = H(i,
    // i), H_.sub1[i] = H(i, i - 1), H_.sub2[i] = H(i, i - 2). One
    // pass over the nodes: bending kb w w^T on each triple (i-1, i, i+1), w =
    // (1, -2, 1) (exact: its weights per block counted below), stretch ks e
    // e^T of the segments either side (Gauss-Newton), friction c_i / s (I -
    // dx dx^T / s^2) (exact); then the tip's contact.
    const int nn = static_cast<int>(x.size());
    const double kb = EI / (ds * ds * ds);
    const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
    Eigen::Matrix2d before = Eigen::Matrix2d::Zero();   // the stretch block of segment i - 1
    for (int i = 0; i < nn; ++i) {
        // Triples holding node i as a side, as the middle, and the pairs
        // (i, i-1) and (i, i-2) they couple.
        const double sides = (i >= 2) + (i + 2 < nn), middle = (i >= 1 && i + 1 < nn);
        const double pairs1 = (i >= 1 && i + 1 < nn) + (i >= 2);
        const Eigen::Vector2d u = i + 1 < nn ? ev.seg_dir[i] : Eigen::Vector2d::Zero();
        const Eigen::Matrix2d after = ks * u * u.transpose();
        H_.diag[i] = (kb * (sides + 4 * middle)) * I + before + after +
                     ev.node_w[i] * (I - ev.node_dir[i] * ev.node_dir[i].transpose());
        H_.sub1[i] = (-2 * kb * pairs1) * I - before;
        H_.sub2[i] = (i >= 2 ? kb : 0.0) * I;
        before = after;
    }
    if (ev.touching) {   // tip contact (Gauss-Newton: kc n n^T, shared as (1 - t, t))
        const int i = c.seg;
        const double t = ev.contact_t;
        const Eigen::Matrix2d B = c.kc * ev.contact_n * ev.contact_n.transpose();
        H_.diag[i] += (1 - t) * (1 - t) * B;
        H_.diag[i + 1] += t * t * B;
        H_.sub1[i + 1] += t * (1 - t) * B;
    }
}

namespace {

using Pivot = BlockPentadiagonal::Pivot;

// Products with the inverse of a pivot D = [a b; b c], from (a, b, 1/a,
// 1/det): D^-1 = [1/a 0; 0 0] + (1/(a det)) [-b; a] [-b a], so every product
// goes through the difference a v1 - b v0 (v's part along D's weakest
// direction), formed before anything is divided.

// o D^-1 (o: 2 x 2): the second column first, from a o1 - b o0.
inline Eigen::Matrix2d times_inverse(const Eigen::Matrix2d &o, const Pivot &p)
{
    Eigen::Matrix2d r;
    r.col(1) = (p.a * o.col(1) - p.b * o.col(0)) * p.inv_det;
    r.col(0) = (o.col(0) - p.b * r.col(1)) * p.inv_a;
    return r;
}

// o D^-1 o^T = w0 w0^T / a + w1 w1^T / (a det), w0 = o e0, w1 = a o e1 - b o e0.
inline Eigen::Matrix2d quadratic(const Eigen::Matrix2d &o, const Pivot &p)
{
    const Eigen::Vector2d w0 = o.col(0), w1 = p.a * o.col(1) - p.b * o.col(0);
    return (w0 * w0.transpose()) * p.inv_a + (w1 * w1.transpose()) * (p.inv_a * p.inv_det);
}

// D^-1 y.
inline Eigen::Vector2d inverse_times(const Pivot &p, const Eigen::Vector2d &y)
{
    const double z1 = (p.a * y.y() - p.b * y.x()) * p.inv_det;
    return Eigen::Vector2d((y.x() - p.b * z1) * p.inv_a, z1);
}

}  // namespace

void BlockPentadiagonal::resize(int n)
{
    for (auto *m : {&diag, &sub1, &sub2, &l1_, &l2_}) m->assign(static_cast<std::size_t>(n), Eigen::Matrix2d::Zero());
    piv_.assign(static_cast<std::size_t>(n), Pivot{});
}

bool BlockPentadiagonal::factor(double shift)
{
    // H(i, i-2) = L(i, i-2) D_{i-2}; H(i, i-1) = L(i, i-1) D_{i-1} + L(i, i-2)
    // D_{i-2} L(i-1, i-2)^T, hence L(i, i-1) D_{i-1} = H(i, i-1) - H(i, i-2)
    // L(i-1, i-2)^T; D_i = H(i, i) - the two rows' products.
    const int n = size();
    for (int i = 0; i < n; ++i) {
        Eigen::Matrix2d d = diag[i];
        d(0, 0) += shift;
        d(1, 1) += shift;
        const double scale = d(0, 0) + d(1, 1);
        if (i >= 2) {
            l2_[i] = times_inverse(sub2[i], piv_[i - 2]);
            d -= quadratic(sub2[i], piv_[i - 2]);
        }
        if (i >= 1) {
            Eigen::Matrix2d o = sub1[i];
            if (i >= 2) o.noalias() -= sub2[i] * l1_[i - 1].transpose();
            l1_[i] = times_inverse(o, piv_[i - 1]);
            d -= quadratic(o, piv_[i - 1]);
        }
        Pivot &p = piv_[i];
        p.a = d(0, 0);
        p.b = 0.5 * (d(0, 1) + d(1, 0));
        const double det = p.a * d(1, 1) - p.b * p.b;
        if (!(p.a > kPivot * scale) || !(det > kPivot * scale * p.a)) return false;
        p.inv_a = 1.0 / p.a;
        p.inv_det = 1.0 / det;
    }
    return true;
}

void BlockPentadiagonal::solve(std::vector<Eigen::Vector2d> &r) const
{
    // L y = r, D z = y, L^T x = z. Each row's older neighbour first: the
    // chain from row to row is then one 2 x 2 product long.
    const int n = size();
    Eigen::Vector2d *v = r.data();
    const Eigen::Matrix2d *L1 = l1_.data(), *L2 = l2_.data();
    if (n >= 2) v[1] -= L1[1] * v[0];
    for (int i = 2; i < n; ++i) v[i] -= L2[i] * v[i - 2] + L1[i] * v[i - 1];
    for (int i = 0; i < n; ++i) v[i] = inverse_times(piv_[i], v[i]);
    if (n >= 2) v[n - 2] -= L1[n - 1].transpose() * v[n - 1];
    for (int i = n - 3; i >= 0; --i) v[i] -= L2[i + 2].transpose() * v[i + 2] + L1[i + 1].transpose() * v[i + 1];
}

void FlexibleWire::newton_direction()
{
    double shift = 0, biggest = 0;
    for (const auto &b : H_.diag) biggest = std::max(biggest, b.trace());
    factored_ = H_.factor(0.0);
    for (int k = 0; !factored_ && k < kMaxShifts; ++k) {
        shift = shift == 0 ? kShift * biggest : 1e3 * shift;
        factored_ = H_.factor(shift);
    }
    if (shift > 0) ++regularised;
    for (std::size_t i = 0; i < dir_.size(); ++i) dir_[i] = -now_.g[i];
    if (factored_) H_.solve(dir_);
    else   // not even H + shift I factors (no stiffness at all): a gradient step
        for (auto &di : dir_) di /= std::max(biggest, 1.0);
}

bool FlexibleWire::try_step(const Contact &c, double &phi, double alpha)
{
    double slope = 0;
    for (std::size_t i = 0; i < x.size(); ++i) slope += now_.g[i].dot(dir_[i]);
    for (std::size_t i = 0; i < x.size(); ++i) x[i] = base_[i] + alpha * dir_[i];
    const double phi_t = evaluate(c, trial_);
    if (!(slope < 0) || !(phi_t <= phi + kArmijo * alpha * slope)) return false;
    phi = phi_t;
    std::swap(now_, trial_);
    return true;
}

void FlexibleWire::newton_step(const Contact &c, double &phi)
{
    assemble_hessian(c, now_);
    newton_direction();
    // Backtracking (Armijo) on the step's energy; when rounding hides the
    // decrease (at the solution's doorstep), the whole step.
    base_ = x;
    double alpha = 1;
    for (int ls = 0; ls < kMaxHalvings; ++ls, alpha *= 0.5)
        if (try_step(c, phi, alpha)) return;
    for (std::size_t i = 0; i < x.size(); ++i) x[i] = base_[i] + dir_[i];
    phi = evaluate(c, now_);
}

void FlexibleWire::chord_step(const Contact &c, double &phi)
{
    // The last factorisation (an earlier step's H) stands in for this
    // point's: a steady push changes H little from step to step. The whole
    // step, kept only if it passes Armijo's test; otherwise x is unchanged.
    if (!factored_) return;
    for (std::size_t i = 0; i < dir_.size(); ++i) dir_[i] = -now_.g[i];
    H_.solve(dir_);
    base_ = x;
    if (!try_step(c, phi, 1.0)) x = base_;
}

void FlexibleWire::warm_start(const Contact &c, double &phi)
{
    // The last step's increment d, scaled: a steady push moves the wire alike
    // from step to step, but by different amounts. Along start + a d the
    // energy's slope is g0 . d + sum_i c_i |d_i| (the friction of the nodes d
    // slides, once past the regularisation) and its curvature the elastic and
    // contact d^T H d: its minimum is at a = -slope / curvature. Kept only if
    // it lowers the step's energy.
    const int nn = static_cast<int>(x.size());
    const auto &d = last_dx_;
    double slope = 0;
    for (int i = 0; i < nn; ++i) slope += now_.g[i].dot(d[i]) + node_friction(i) * d[i].norm();
    const double curvature = elastic_curvature(c, now_, d);
    if (!(slope < 0) || !(curvature > 0)) return;
    const double a = -slope / curvature;
    for (int i = 0; i < nn; ++i) x[i] = start_[i] + a * d[i];
    const double phi_w = evaluate(c, trial_);
    if (phi_w < phi) {
        phi = phi_w;
        std::swap(now_, trial_);
    } else {
        x = start_;
    }
}

bool FlexibleWire::follow(const Contact &c, double t_seg, double &phi)
{
    // A wire that slid on the last push and reached balance, pushed further
    // along the contact's normal: it slides again, and a steady slide keeps
    // the contact force, so its contact point advances as far as the apex
    // did. The last increment scaled to that advance is the first guess; no
    // balance test at the start is needed (the step's Newton iteration has
    // the last word either way).
    if (!last_converged || last_dx_.size() != x.size()) return false;   // sized by a push that set last_q_
    const Eigen::Vector2d moved = (1 - t_seg) * last_dx_[c.seg] + t_seg * last_dx_[c.seg + 1];
    const double wire_advance = -moved.dot(c.n0), apex_advance = -(c.q - last_q_).dot(c.n0);
    if (!(wire_advance > kFollowFloor_nm) || !(apex_advance > 0)) return false;
    const double a = apex_advance / wire_advance;
    for (std::size_t i = 0; i < x.size(); ++i) x[i] = start_[i] + a * last_dx_[i];
    phi = evaluate(c, now_);
    return true;
}

bool FlexibleWire::push(const Eigen::Vector2d &q, double r_tip, double kc, double ride_nN)
{
    Contact c;
    c.q = q;
    c.reach = r_tip + 0.5 * d_nm;
    c.kc = kc;
    // The tip touches the segment closest to it at the start of the step,
    // and only it, for the whole step: the distance to one segment is
    // continuously differentiable in the nodes, the minimum over segments is
    // not (a kink wherever the apex faces a node), which would stall Newton.
    double t_seg;
    const double dist = closest(q, c.seg, t_seg);
    in_contact = c.reach - dist > 0;
    // The contact force past what the tip can push: it rides over (the
    // chain's own friction is per node; the press is not modelled on it).
    ridden = in_contact && kc * (c.reach - dist) > ride_nN;
    if (!in_contact || ridden) return false;
    const Eigen::Vector2d ab = x[c.seg + 1] - x[c.seg], dv = q - (x[c.seg] + t_seg * ab);
    c.n0 = dist > 1e-12 ? Eigen::Vector2d(dv / dist) : Eigen::Vector2d(-ab.y(), ab.x()).normalized();
    const int nn = static_cast<int>(x.size());
    start_ = x;
    double phi = 0;
    const bool followed = follow(c, t_seg, phi);
    last_q_ = q;
    if (!followed) {   // a wire in balance where it is does not move: one evaluation decides
        phi = evaluate(c, now_, true);
        if (now_.residual >= 1 && last_dx_.size() == start_.size()) warm_start(c, phi);
    }
    last_iterations = 1;
    last_converged = now_.residual < 1;
    if (!last_converged) chord_step(c, phi);
    for (int it = 0; it < max_iterations && !last_converged; ++it) {
        last_iterations = it + 1;
        if (now_.residual < 1) {
            last_converged = true;
            break;
        }
        newton_step(c, phi);
    }
    if (!last_converged) ++unconverged;
    // Stuck nodes go back to their start: no creep under a load below c_i,
    // however many steps.
    last_dx_.resize(nn);
    for (int i = 0; i < nn; ++i) {
        if ((x[i] - start_[i]).squaredNorm() < stuck_nm * stuck_nm) x[i] = start_[i];
        last_dx_[i] = x[i] - start_[i];
    }
    update_box();
    return true;
}

}  // namespace afm::sim
