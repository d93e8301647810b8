#include "wire.hpp"

#include <algorithm>
#include <cmath>

namespace afm::sim {

namespace {
// Velocity floor of the reweighting (per unit push travel): keeps a friction
// point that sits on the rotation centre from getting an infinite weight.
constexpr double kVelocityFloor = 1e-9;
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
    squeezed = false;
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
    // down_force: the push H presses the rod by H tan psi, spread over it as
    // its own load (eq. 29): D(H) = D0 (1 + mu H tan psi / (f L)), so H moves
    // it when H a > D0 with a = 1 - (D0 / f L) mu tan psi; a <= 0: squeezed.
    // A rod a trench holds is not pressed: the walls carry the cone's down
    // force (the firmware's model, fw_wire.h "Trenches", does the same).
    const double press = held ? 0.0 : mu * press_tan;
    const double a = press > 0 && f > 0 ? 1.0 - last.force_nN / (f * L_nm) * press : 1.0;
    squeezed = !(a > 0);
    if (squeezed) return false;
    const double D = last.force_nN / a;
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

double FlexibleWire::closest(const Eigen::Vector2d &q, int &seg, double &t) const
{
    const int nn = static_cast<int>(x.size());
    double best = 1e300;
    seg = 0;
    t = 0;
    for (int i = 0; i + 1 < nn; ++i) {
        const double ti = segment_param(x[i], x[i + 1], q);
        const double dn = (q - (x[i] + ti * (x[i + 1] - x[i]))).norm();
        if (dn < best) {
            best = dn;
            seg = i;
            t = ti;
        }
    }
    return best;
}

double FlexibleWire::energy(const std::vector<Eigen::Vector2d> &start, const Eigen::Vector2d &q, int seg, double reach,
                            double kc) const
{
    const int nn = static_cast<int>(x.size());
    const double kb = EI / (ds * ds * ds);
    double e = 0;
    for (int i = 0; i + 1 < nn; ++i) {
        const double dl = (x[i + 1] - x[i]).norm() - ds;
        e += 0.5 * ks * dl * dl;
    }
    for (int i = 1; i + 1 < nn; ++i) e += 0.5 * kb * (x[i - 1] - 2 * x[i] + x[i + 1]).squaredNorm();
    const double t = segment_param(x[seg], x[seg + 1], q);
    const double pen = reach - (q - (x[seg] + t * (x[seg + 1] - x[seg]))).norm();
    if (pen > 0) e += 0.5 * kc * pen * pen;
    for (int i = 0; i < nn; ++i) {
        const double ci = f * ds * ((i == 0 || i == nn - 1) ? 0.5 : 1.0);
        e += ci * (std::hypot((x[i] - start[i]).norm(), kSlipRegularisation_nm) - kSlipRegularisation_nm);
    }
    return e;
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
    const double reach = r_tip + 0.5 * d_nm;
    const std::vector<Eigen::Vector2d> start = x;
    const double kb = EI / (ds * ds * ds);
    const double eps = kSlipRegularisation_nm;
    std::vector<double> A(static_cast<std::size_t>(n) * (b + 1)), g(n), d(n);
    // The tip touches the segment closest to it at the start of the step,
    // and only it, for the whole step: the distance to one segment is
    // continuously differentiable in the nodes, the minimum over segments is
    // not (a kink wherever the apex faces a node), which would stall Newton.
    int seg;
    double t_seg;
    closest(q, seg, t_seg);
    // Lower-band accumulation of a 2 x 2 block for nodes (i, j), i >= j.
    auto add_block = [&](int i, int j, const Eigen::Matrix2d &B) {
        for (int r = 0; r < 2; ++r)
            for (int c = 0; c < 2; ++c) {
                const int I = 2 * i + r, J = 2 * j + c;
                if (I >= J) A[I * (b + 1) + (I - J)] += B(r, c);
            }
    };
    // Warm start: a steady push moves the wire alike from step to step, so
    // the last step's increment is tried first; kept only if it lowers the
    // step's energy.
    double phi = energy(start, q, seg, reach, kc);
    if (last_dx_.size() == start.size()) {
        for (int i = 0; i < nn; ++i) x[i] = start[i] + last_dx_[i];
        const double phi_w = energy(start, q, seg, reach, kc);
        if (phi_w < phi) phi = phi_w;
        else x = start;
    }
    last_iterations = 0;
    last_converged = false;
    for (int it = 0; it < max_iterations; ++it) {
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
        // Tip contact: kc / 2 pen^2 at the point of that segment closest to
        // the apex, shared by its two nodes as (1 - t, t): one contact
        // whatever the mesh (Gauss-Newton Hessian kc n n^T).
        {
            const int i = seg;
            const double t = segment_param(x[i], x[i + 1], q);
            const Eigen::Vector2d dv = q - (x[i] + t * (x[i + 1] - x[i]));
            const double dn = dv.norm();
            const double pen = reach - dn;
            if (pen > 0) {
                const Eigen::Vector2d nh = dn > 1e-12 ? Eigen::Vector2d(dv / dn) : n0;
                grad(i) += kc * pen * (1 - t) * nh;
                grad(i + 1) += kc * pen * t * nh;
                const Eigen::Matrix2d B = kc * nh * nh.transpose();
                add_block(i, i, (1 - t) * (1 - t) * B);
                add_block(i + 1, i + 1, t * t * B);
                add_block(i + 1, i, t * (1 - t) * B);
            }
        }
        // Coulomb friction c_i |dx_i| (c_i = f ds, half at the ends),
        // regularised as c_i (sqrt(|dx_i|^2 + eps^2) - eps): exact gradient
        // and Hessian. A node whose force is below c_i stays within about
        // eps of its start (a stiffness c_i / eps pins it); past c_i it slides
        // against its own motion. Converged when every node is in balance:
        // a stuck node (within stuck_nm of its start) when its elastic and
        // contact force is at most c_i (the Coulomb law itself), a sliding
        // one when that force and its (regularised) friction cancel, both to
        // kResidual c_i.
        double residual = 0;
        for (int i = 0; i < nn; ++i) {
            const double ci = f * ds * ((i == 0 || i == nn - 1) ? 0.5 : 1.0);
            const Eigen::Vector2d dx = x[i] - start[i];
            const double sr = std::hypot(dx.norm(), eps);
            const double tol = kResidual * ci + kResidualFloor_nN;
            if (dx.norm() < stuck_nm) residual = std::max(residual, (grad(i).norm() - ci) / tol);
            grad(i) += ci / sr * dx;
            add_block(i, i, ci / sr * (Eigen::Matrix2d::Identity() - dx * dx.transpose() / (sr * sr)));
            if (dx.norm() >= stuck_nm) residual = std::max(residual, grad(i).norm() / tol);
        }
        last_iterations = it + 1;
        if (residual < 1) {
            last_converged = true;
            break;
        }
        for (int k = 0; k < n; ++k) d[k] = -g[k];
        solve_banded(A, d);
        double slope = 0;
        for (int k = 0; k < n; ++k) slope += g[k] * d[k];
        // Backtracking (Armijo) on the step's energy; when rounding hides
        // the decrease (at the solution's doorstep), the whole step.
        const std::vector<Eigen::Vector2d> base = x;
        double alpha = 1;
        bool accepted = false;
        for (int ls = 0; ls < kMaxHalvings && !accepted; ++ls) {
            for (int i = 0; i < nn; ++i) x[i] = base[i] + alpha * Eigen::Vector2d(d[2 * i], d[2 * i + 1]);
            accepted = energy(start, q, seg, reach, kc) <= phi + 1e-4 * alpha * slope;
            if (!accepted) alpha *= 0.5;
        }
        if (!accepted)
            for (int i = 0; i < nn; ++i) x[i] = base[i] + Eigen::Vector2d(d[2 * i], d[2 * i + 1]);
        phi = energy(start, q, seg, reach, kc);
    }
    if (!last_converged) ++unconverged;
    // Stuck nodes go back to their start: no creep under a load below c_i,
    // however many steps.
    last_dx_.resize(nn);
    for (int i = 0; i < nn; ++i) {
        if ((x[i] - start[i]).norm() < stuck_nm) x[i] = start[i];
        last_dx_[i] = x[i] - start[i];
    }
    update_box();
    return true;
}

}  // namespace afm::sim
