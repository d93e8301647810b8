#include "wire.hpp"

#include <algorithm>
#include <cmath>

namespace afm::sim {

namespace {
// Velocity floor of the reweighting (per unit push travel): keeps a friction
// point that sits on the rotation centre from getting an infinite weight.
constexpr double kVelocityFloor = 1e-9;
// Displacement floor (nm) of the flexible wire's reweighted friction, and the
// Newton step (nm) below which its incremental solve has converged.
constexpr double kStepFloor_nm = 1e-8;
constexpr double kConverged_nm = 1e-7;
constexpr double kRelativeFloor = 1e-3;
}  // namespace

RodTwist rod_push_twist(const std::vector<double> &u, double w, double up, const Eigen::Vector2d &p,
                        const RodTwist &warm, double tol, int max_iter, const std::vector<Eigen::Matrix2d> *metric)
{
    // Unknowns x = (vt, vn, omega); the contact point's velocity is
    // (vt, vn + omega up) and the constraint c . x = 1 makes it advance by one
    // unit along p. Friction power D(x) = sum_k w |G_k (vt, vn + omega u_k)|
    // (G_k = I on a plain substrate; anisotropic where a trench holds the
    // wire).
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
    auto power = [&](const Eigen::Vector3d &v) {
        double d = 0;
        for (std::size_t k = 0; k < u.size(); ++k) d += w * vel(v, k).norm();
        return d;
    };
    double D = power(x);
    RodTwist out;
    int it = 0;
    for (; it < max_iter; ++it) {
        // Minimise sum_k a_k |G_k A_k x|^2 subject to c . x = 1, a_k = w / |G_k A_k x|:
        // x = M^-1 c / (c . M^-1 c).
        Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
        if (!metric) {
            double sa = 0, sau = 0, sau2 = 0;
            for (double uk : u) {
                const double a = w / std::max(std::hypot(x[0], x[1] + x[2] * uk), kVelocityFloor);
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
        const double Dn = power(xn);
        const bool done = (xn - x).norm() <= tol * xn.norm();
        x = xn;
        D = Dn;
        if (done) break;
    }
    out.vt = x[0];
    out.vn = x[1];
    out.omega = x[2];
    out.force_nN = D;
    out.iterations = it + 1;
    return out;
}

double segment_param(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &q)
{
    const Eigen::Vector2d ab = b - a;
    const double l2 = ab.squaredNorm();
    if (l2 <= 0) return 0.0;
    return std::clamp((q - a).dot(ab) / l2, 0.0, 1.0);
}

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
    double best = 1e300, arc = 0, best_u = 0;
    Eigen::Vector2d best_n(0, 1);
    for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
        const Eigen::Vector2d ab = xs[i + 1] - xs[i];
        const double t = segment_param(xs[i], xs[i + 1], q);
        const Eigen::Vector2d d = q - (xs[i] + t * ab);
        const double dn = d.norm();
        if (dn < best) {
            best = dn;
            best_u = arc + t * ab.norm();
            best_n = dn > 1e-12 ? Eigen::Vector2d(d / dn) : Eigen::Vector2d(-ab.y(), ab.x()).normalized();
        }
        arc += ab.norm();
    }
    pen = r_tip + 0.5 * d_nm - best;
    n_out = best_n;
    u_out = best_u;
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

bool RigidWire::push(const Eigen::Vector2d &q, double r_tip, double k)
{
    double pen, u_from_a;
    Eigen::Vector2d n;
    in_contact = contact(q, r_tip, pen, n, u_from_a);
    if (!in_contact) return false;
    const Eigen::Vector2d t(std::cos(psi), std::sin(psi)), nr(-std::sin(psi), std::cos(psi));
    const Eigen::Vector2d p = -n;   // the tip pushes the wire away from itself
    // Where a trench holds the wire, its friction is anisotropic: f along the
    // trench, hold x f across it (G = a a^T + hold b b^T in the rod frame).
    bool held = false;
    if (trap) {
        metric_.assign(u.size(), Eigen::Matrix2d::Identity());
        for (std::size_t k = 0; k < u.size(); ++k) {
            Eigen::Vector2d along;
            double hold;
            if (!trap(centre + u[k] * t, d_nm, along, hold)) continue;
            const Eigen::Vector2d a(along.dot(t), along.dot(nr)), b(-a.y(), a.x());
            metric_[k] = a * a.transpose() + hold * b * b.transpose();
            held = true;
        }
    }
    last = rod_push_twist(u, f * L_nm / static_cast<double>(u.size()), u_from_a - 0.5 * L_nm,
                          Eigen::Vector2d(p.dot(t), p.dot(nr)), last, 1e-7, 60, held ? &metric_ : nullptr);
    const double F = k * pen;
    if (F <= last.force_nN) return false;   // inside the limit surface: static
    // Advance the contact point along p until the contact force is back on the
    // limit surface: (F - D) / k of travel.
    const double travel = (F - last.force_nN) / k;
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
    : f(f_), iterations(iters)
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
}

void FlexibleWire::solve_banded(std::vector<double> &A, std::vector<double> &r) const
{
    // Cholesky of a symmetric positive definite band matrix, lower band
    // stored as A[i * (b + 1) + k] = H(i, i - k); solves in place into r.
    const int n = static_cast<int>(r.size());
    constexpr int b = 5;
    auto L = [&](int i, int j) -> double & { return A[i * (b + 1) + (i - j)]; };
    for (int i = 0; i < n; ++i) {
        const int j0 = std::max(0, i - b);
        for (int j = j0; j < i; ++j) {
            double s = L(i, j);
            for (int m = std::max(j0, j - b); m < j; ++m) s -= L(i, m) * L(j, m);
            L(i, j) = s / L(j, j);
        }
        double s = L(i, i);
        for (int m = j0; m < i; ++m) s -= L(i, m) * L(i, m);
        L(i, i) = std::sqrt(std::max(s, 1e-300));
    }
    for (int i = 0; i < n; ++i) {
        double s = r[i];
        for (int j = std::max(0, i - b); j < i; ++j) s -= L(i, j) * r[j];
        r[i] = s / L(i, i);
    }
    for (int i = n - 1; i >= 0; --i) {
        double s = r[i];
        for (int j = i + 1; j <= std::min(n - 1, i + b); ++j) s -= L(j, i) * r[j];
        r[i] = s / L(i, i);
    }
}

bool FlexibleWire::push(const Eigen::Vector2d &q, double r_tip, double kc)
{
    double pen0, u0;
    Eigen::Vector2d n0;
    in_contact = contact(q, r_tip, pen0, n0, u0);
    if (!in_contact) return false;
    const int nn = static_cast<int>(x.size());
    const int n = 2 * nn;
    constexpr int b = 5;
    const std::vector<Eigen::Vector2d> start = x;
    const double kb = EI / (ds * ds * ds);
    stuck_.assign(nn, 1);
    std::vector<double> A(static_cast<std::size_t>(n) * (b + 1)), g(n);
    // Lower-band accumulation of a 2 x 2 block for nodes (i, j), i >= j.
    auto add_block = [&](int i, int j, const Eigen::Matrix2d &B) {
        for (int r = 0; r < 2; ++r)
            for (int c = 0; c < 2; ++c) {
                const int I = 2 * i + r, J = 2 * j + c;
                if (I >= J) A[I * (b + 1) + (I - J)] += B(r, c);
            }
    };
    bool moved = false;
    for (int it = 0; it < iterations; ++it) {
        std::fill(A.begin(), A.end(), 0.0);
        std::fill(g.begin(), g.end(), 0.0);
        auto grad = [&](int i) { return Eigen::Map<Eigen::Vector2d>(&g[2 * i]); };
        // Stretch (Gauss-Newton Hessian ks e e^T).
        for (int i = 0; i + 1 < nn; ++i) {
            const Eigen::Vector2d e = x[i + 1] - x[i];
            const double len = e.norm();
            const Eigen::Vector2d eh = e / len;
            const Eigen::Vector2d fs = ks * (len - ds) * eh;
            grad(i) -= fs;
            grad(i + 1) += fs;
            const Eigen::Matrix2d B = ks * eh * eh.transpose();
            add_block(i, i, B);
            add_block(i + 1, i + 1, B);
            add_block(i + 1, i, -B);
        }
        // Bending: kb / 2 |x_{i-1} - 2 x_i + x_{i+1}|^2 (quadratic: exact Hessian).
        for (int i = 1; i + 1 < nn; ++i) {
            const Eigen::Vector2d bv = x[i - 1] - 2 * x[i] + x[i + 1];
            grad(i - 1) += kb * bv;
            grad(i) -= 2 * kb * bv;
            grad(i + 1) += kb * bv;
            const double w[3] = {1, -2, 1};
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c <= r; ++c) add_block(i - 1 + r, i - 1 + c, kb * w[r] * w[c] * Eigen::Matrix2d::Identity());
        }
        // Tip contact: kc / 2 pen^2 on every segment the apex overlaps.
        for (int i = 0; i + 1 < nn; ++i) {
            const double t = segment_param(x[i], x[i + 1], q);
            const Eigen::Vector2d pt = x[i] + t * (x[i + 1] - x[i]);
            const Eigen::Vector2d d = q - pt;
            const double dn = d.norm();
            const double pen = r_tip + 0.5 * d_nm - dn;
            if (pen <= 0) continue;
            const Eigen::Vector2d nh = dn > 1e-12 ? Eigen::Vector2d(d / dn) : n0;
            // d pen / d x_i = (1 - t) nh, d pen / d x_{i+1} = t nh.
            grad(i) += kc * pen * (1 - t) * nh;
            grad(i + 1) += kc * pen * t * nh;
            const Eigen::Matrix2d B = kc * nh * nh.transpose();
            add_block(i, i, (1 - t) * (1 - t) * B);
            add_block(i + 1, i + 1, t * t * B);
            add_block(i + 1, i, t * (1 - t) * B);
        }
        // Friction by stick and slip (an active set), updated from the
        // elastic and contact forces at the current iterate: a stuck node
        // stays put (held by a stiff spring to its start) while the force on
        // it stays within c_i; past it, it slides. A sliding node's friction
        // is reweighted: c_i |dx_i| ~ c_i |dx_i|^2 / (2 rho_i); it sticks
        // again when it barely moves and its force is within c_i. The first
        // pass takes the sliding set and weights from the last push (a steady
        // push moves the nodes alike from sample to sample).
        double biggest_dx = 0;
        for (int i = 0; i < nn; ++i) biggest_dx = std::max(biggest_dx, (x[i] - start[i]).norm());
        const double floor_nm = std::max(kRelativeFloor * biggest_dx, kStepFloor_nm);
        const double k_node = 2 * ks + 16 * kb + kc;   // a node's own stiffness, about
        const double k_hold = 1e3 * k_node;
        bool changed = false;
        for (int i = 0; i < nn; ++i) {
            const double ci = f * ds * ((i == 0 || i == nn - 1) ? 0.5 : 1.0);
            const Eigen::Vector2d dx = x[i] - start[i];
            const double r = grad(i).norm();   // elastic + contact force on the node
            double rho = std::max(dx.norm(), floor_nm);
            if (it == 0) {
                stuck_[i] = !(have_last_ && last_step_[i] > kRelativeFloor * last_max_);
                if (!stuck_[i]) rho = std::max(last_step_[i] * pen0 / last_scale_, kStepFloor_nm);
            }
            if (stuck_[i] && r > ci) {
                stuck_[i] = false;
                changed = true;
                rho = std::max((r - ci) / k_node, floor_nm);
            } else if (!stuck_[i] && it > 0 && dx.norm() <= floor_nm && r <= ci) {
                stuck_[i] = true;
                changed = true;
            }
            const double w = stuck_[i] ? k_hold : ci / rho;
            grad(i) += w * dx;
            add_block(i, i, w * Eigen::Matrix2d::Identity());
        }
        for (double &v : g) v = -v;
        solve_banded(A, g);
        double step = 0;
        for (int i = 0; i < nn; ++i) {
            const Eigen::Vector2d dxi(g[2 * i], g[2 * i + 1]);
            x[i] += dxi;
            step = std::max(step, dxi.norm());
        }
        moved = true;
        if (step < kConverged_nm && !changed) break;
    }
    // Remember the pattern of this push (relative to its penetration).
    last_step_.resize(nn);
    double biggest = 0;
    for (int i = 0; i < nn; ++i) biggest = std::max(biggest, last_step_[i] = (x[i] - start[i]).norm());
    have_last_ = biggest > kStepFloor_nm;
    last_max_ = biggest;
    last_scale_ = pen0;
    update_box();
    return moved;
}

}  // namespace afm::sim
