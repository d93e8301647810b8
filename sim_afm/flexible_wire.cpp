// The flexible wire (wire.hpp: FlexibleWire): N segments with bending and
// stretching, Coulomb friction per node, relaxed by Newton steps each push.

#include "wire.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "wire_internal.hpp"

namespace afm::sim {

namespace {
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
// The contact's window (FlexibleWire::contact_window) reaches this beyond
// the reach and a segment (nm).
constexpr double kWindowMargin_nm = 20;
// One node's Coulomb law in evaluate(): its friction c_i and the inverse
// squares of its tolerance (kResidual c_i + kResidualFloor_nN), stuck (c_i
// + tol) and sliding (tol).
struct NodeLaw {
    double ci, stuck_inv2, slide_inv2;
    explicit NodeLaw(double c) : ci(c)
    {
        const double tol = kResidual * c + kResidualFloor_nN;
        stuck_inv2 = 1.0 / ((c + tol) * (c + tol));
        slide_inv2 = 1.0 / (tol * tol);
    }
};

// evaluate()'s worst node: see FlexibleWire::Eval's residual and imbalance_nN.
struct Balance {
    double worst = 0, slide2 = 0, stuck_excess = 0;
};

// One node's friction and balance in evaluate(): its Coulomb friction c_i
// |dx|, regularised as c_i (sqrt(|dx|^2 + eps^2) - eps). A node is in
// balance when stuck (within stuck_nm of its start) with an elastic and
// contact force of at most c_i (the Coulomb law itself), or sliding with
// that force and its (regularised) friction cancelling, both to its
// tolerance. Returns its friction energy; adds its friction force to gi;
// sets its friction stiffness w = c_i / s and direction dir = dx / s; keeps
// the worst imbalance in b. Static here, so that evaluate's loop inlines it.
inline double node_balance(const NodeLaw &law, const Eigen::Vector2d &dx, Eigen::Vector2d &gi, double &w,
                           Eigen::Vector2d &dir, Balance &b)
{
    constexpr double eps = kSlipRegularisation_nm;
    const double d2 = dx.squaredNorm();
    if (d2 < stuck_nm * stuck_nm) {
        const double f2 = gi.squaredNorm();
        b.worst = std::max(b.worst, f2 * law.stuck_inv2);
        if (f2 > law.ci * law.ci) b.stuck_excess = std::max(b.stuck_excess, std::sqrt(f2) - law.ci);
    }
    if (d2 == 0) {   // a node still at its start (most of a long chain's, on a first guess) needs no root
        w = law.ci * (1.0 / eps);
        dir.setZero();
        return 0;
    }
    const double sr = std::sqrt(d2 + eps * eps), inv = 1.0 / sr;
    w = law.ci * inv;
    dir = dx * inv;
    gi += w * dx;
    if (d2 >= stuck_nm * stuck_nm) {
        const double s2 = gi.squaredNorm();
        b.worst = std::max(b.worst, s2 * law.slide_inv2);
        b.slide2 = std::max(b.slide2, s2);
    }
    return law.ci * d2 / (sr + eps);   // c_i (sr - eps), without cancelling
}

}  // namespace

using detail::closest_segment;
using detail::kArmijo;
using detail::kMaxHalvings;

FlexibleWire::FlexibleWire(int id_, const Eigen::Vector2d &a, const Eigen::Vector2d &b, double d, double f_, double E_GPa,
                           int N, int iters)
    : f(f_), max_iterations(iters)
{
    id = id_;
    d_nm = d;
    L_nm = (b - a).norm();
    ds = N >= 1 ? L_nm / N : 0.0;
    if (!(ds > 0) || !std::isfinite(ds))   // EA / ds and EI / ds^3 would not be numbers
        throw std::invalid_argument("flexible wire " + std::to_string(id_) + ": segments must have a length, got " +
                                    std::to_string(N) + " segment(s) over " + std::to_string(L_nm) + " nm");
    for (int i = 0; i <= N; ++i) x.push_back(a + (b - a) * (static_cast<double>(i) / N));
    update_box();
    // 1 GPa = 1 nN/nm^2.
    EI = E_GPa * M_PI * std::pow(d, 4) / 64.0;
    ks = E_GPa * M_PI * d * d / 4.0 / ds;
    const std::size_t nn = x.size();
    for (auto *v : {&start_, &dx_, &e0_, &b0_, &base_, &dir_}) v->assign(nn, Eigen::Vector2d::Zero());
    len0_.assign(nn, 0.0);
    H_.resize(static_cast<int>(nn));
    for (Eval *ev : {&now_, &trial_}) {
        ev->g.assign(nn, Eigen::Vector2d::Zero());
        ev->seg_dir.assign(nn, Eigen::Vector2d::Zero());
        ev->node_dir.assign(nn, Eigen::Vector2d::Zero());
        ev->cg.assign(nn, Eigen::Vector2d::Zero());
        ev->node_w.assign(nn, 0.0);
        ev->feats.reserve(8);
    }
}

double FlexibleWire::closest(const Eigen::Vector2d &q, int &seg, double &t) const
{
    seg = static_cast<int>(closest_segment(x, q, t));
    return (q - (x[seg] + t * (x[seg + 1] - x[seg]))).norm();
}

void FlexibleWire::contact_window(Contact &c) const
{
    // Segments lo..hi: from the first to the last whose axis comes within
    // the reach (and the multiplier's shift) and a margin of the apex, the
    // closest one at least; the margin covers the wire's motion in a push.
    const double within = c.reach + (c.kc > 0 ? c.lam / c.kc : 0.0) + ds + kWindowMargin_nm;
    c.lo = c.hi = c.seg;
    for (int s = 0; s + 1 < static_cast<int>(x.size()); ++s) {
        const double t = segment_param(x[s], x[s + 1], c.q);
        if ((c.q - (x[s] + t * (x[s + 1] - x[s]))).squaredNorm() >= within * within) continue;
        c.lo = std::min(c.lo, s);
        c.hi = std::max(c.hi, s);
    }
}

double FlexibleWire::node_friction(int i) const
{
    const int last_node = static_cast<int>(x.size()) - 1;
    return f * ds * ((i == 0 || i == last_node) ? 0.5 : 1.0);
}

// The tip's contact over its features in segments c.lo..c.hi (wire.hpp,
// contact_features): its energy, nN nm, each feature's kc/2 pen^2 times its
// count, and their forces on the nodes (ev.cg, set on the features' nodes
// only; ev.feats).
double FlexibleWire::contact_energy(const Contact &c, const Eigen::Vector2d *xs, Eval &ev)
{
    ev.feats.clear();
    if (!(c.kc > 0)) return 0;
    const double reach = c.reach + c.lam / c.kc;
    contact_features(xs, c.lo, c.hi, c.q, reach, c.n0, ev.feats);
    double e = 0;
    for (const auto &f : ev.feats) {
        const double pen = reach - f.dist, push = f.sign * c.kc * pen;
        e += 0.5 * f.sign * c.kc * pen * pen;
        if (f.node) {
            ev.cg[f.a] += push * f.n;
        } else {
            ev.cg[f.a] += push * (1 - f.t) * f.n;
            ev.cg[f.a + 1] += push * f.t * f.n;
        }
    }
    return e;
}

void FlexibleWire::begin_increments()
{
    // The step's start: its segments e0_i = x_{i+1} - x_i, their lengths and
    // its bends b0_j = e0_j - e0_{j-1} (zero at the ends), taken once; the
    // increments from there, zero.
    const int nn = static_cast<int>(x.size());
    start_ = x;
    for (int i = 0; i + 1 < nn; ++i) e0_[i] = x[i + 1] - x[i], len0_[i] = e0_[i].norm();
    for (int j = 1; j + 1 < nn; ++j) b0_[j] = e0_[j] - e0_[j - 1];
    for (auto &d : dx_) d.setZero();
}

void FlexibleWire::place_nodes()
{
    for (std::size_t i = 0; i < x.size(); ++i) x[i] = start_[i] + dx_[i];
    update_box();
}

double FlexibleWire::evaluate(const Contact &c, Eval &ev)
{
    ++evaluations;
    // The step's energy from its start, nN nm; ev at start_ + dx_ (see
    // Eval). One pass over the nodes: node i's force gathers the springs of
    // segments i - 1 and i, the bending of the triples centred on i - 1, i
    // and i + 1 (zero where the triple does not exist), the tip's contact
    // and its friction (node_balance). In increments (begin_increments):
    // segment i is e0_i + (dx_{i+1} - dx_i), bend j is b0_j + (dx_{j-1} -
    // 2 dx_j + dx_{j+1}), and each term's energy is taken as its change, so
    // the forces round as the increments and bends do, not as the
    // coordinates (kb = EI / ds^3 times their rounding, 1e-12 nm on a 5 um
    // wire, is 3.5e-6 nN at N = 1024, past the tolerance), and the line
    // search compares the step's work, not the wire's whole energy.
    const int nn = static_cast<int>(x.size());
    const double kb = EI / (ds * ds * ds);
    for (int j = c.lo; j <= c.hi + 1 && j < nn; ++j) x[j] = start_[j] + dx_[j];   // the contact's nodes, placed
    const double e = contact_energy(c, x.data(), ev);
    const Eigen::Vector2d *d = dx_.data(), *e0 = e0_.data(), *b0 = b0_.data();
    Eigen::Vector2d *g = ev.g.data(), *seg_dir = ev.seg_dir.data(), *cg = ev.cg.data();
    const NodeLaw inner(f * ds), at_end(0.5 * f * ds);
    double *node_w = ev.node_w.data();
    Eigen::Vector2d *node_dir = ev.node_dir.data();
    double e_stretch = 0, e_bend = 0, e_friction = 0;
    Balance bal;
    Eigen::Vector2d fs_before = Eigen::Vector2d::Zero();   // spring force of segment i - 1 on node i
    Eigen::Vector2d b_before = Eigen::Vector2d::Zero();    // b_{i-1}
    Eigen::Vector2d b_here = Eigen::Vector2d::Zero();      // b_i
    for (int i = 0; i < nn; ++i) {
        Eigen::Vector2d fs = Eigen::Vector2d::Zero();
        if (i + 1 < nn) {   // segment i: ks / 2 (|e_i| - ds)^2
            const Eigen::Vector2d de = d[i + 1] - d[i], ed = e0[i] + de;
            const double len = ed.norm(), len0 = len0_[i];
            const double grow = (2 * e0[i].dot(de) + de.squaredNorm()) / (len + len0);   // len - len0
            e_stretch += grow * (len + len0 - 2 * ds);                                     // (len - ds)^2 - (len0 - ds)^2
            seg_dir[i] = ed * (1.0 / len);
            fs = (ks * ((len0 - ds) + grow)) * seg_dir[i];
        }
        Eigen::Vector2d b_after = Eigen::Vector2d::Zero();
        if (i + 2 < nn) {
            const Eigen::Vector2d db = d[i] - 2 * d[i + 1] + d[i + 2];
            e_bend += db.dot(2 * b0[i + 1] + db);   // |b|^2 - |b0|^2
            b_after = b0[i + 1] + db;
        }
        Eigen::Vector2d gi = fs_before - fs + kb * (b_before - 2 * b_here + b_after);
        if (i >= c.lo && i <= c.hi + 1) gi += cg[i], cg[i].setZero();   // the contact's window: its forces, cg zero again
        fs_before = fs;
        b_before = b_here;
        b_here = b_after;
        e_friction += node_balance((i == 0 || i == nn - 1) ? at_end : inner, d[i], gi, node_w[i], node_dir[i], bal);
        g[i] = gi;
    }
    ev.residual = bal.worst;
    ev.imbalance_nN = std::max(std::sqrt(bal.slide2), bal.stuck_excess);
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
    for (const auto &f : ev.feats) {   // Gauss-Newton: kc (n . d)^2 per feature, times its count
        const double a = f.n.dot(f.node ? d[f.a] : Eigen::Vector2d((1 - f.t) * d[f.a] + f.t * d[f.a + 1]));
        q += f.sign * c.kc * a * a;
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
    // The tip's contact: Gauss-Newton, kc n n^T per feature times its
    // count, a segment's shared as (1 - t, t). A bend's inside takes its
    // node's off (count -1): the sum is then one contact's kc n n^T near the
    // node, as the energy's; an H that does not factor gets its shift.
    for (const auto &f : ev.feats) {
        const Eigen::Matrix2d B = f.sign * c.kc * f.n * f.n.transpose();
        if (f.node) {
            H_.diag[f.a] += B;
            continue;
        }
        const int i = f.a;
        const double t = f.t;
        H_.diag[i] += (1 - t) * (1 - t) * B;
        H_.diag[i + 1] += t * t * B;
        H_.sub1[i + 1] += t * (1 - t) * B;
    }
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
    for (std::size_t i = 0; i < x.size(); ++i) dx_[i] = base_[i] + alpha * dir_[i];
    const double phi_t = evaluate(c, trial_);
    if (!(slope < 0) || !(phi_t <= phi + kArmijo * alpha * slope)) return false;
    phi = phi_t;
    std::swap(now_, trial_);
    return true;
}

void FlexibleWire::newton_step(const Contact &c, double &phi)
{
    ++newton_steps;
    assemble_hessian(c, now_);
    newton_direction();
    // Backtracking (Armijo) on the step's energy; when rounding hides the
    // decrease (at the solution's doorstep), the whole step.
    base_ = dx_;
    double alpha = 1;
    for (int ls = 0; ls < kMaxHalvings; ++ls, alpha *= 0.5)
        if (try_step(c, phi, alpha)) return;
    ++full_steps;
    for (std::size_t i = 0; i < x.size(); ++i) dx_[i] = base_[i] + dir_[i];
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
    base_ = dx_;
    if (!try_step(c, phi, 1.0)) dx_ = base_;
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
    for (int i = 0; i < nn; ++i) dx_[i] = a * d[i];
    const double phi_w = evaluate(c, trial_);
    if (phi_w < phi) {
        phi = phi_w;
        std::swap(now_, trial_);
    } else {
        for (auto &di : dx_) di.setZero();
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
    for (std::size_t i = 0; i < x.size(); ++i) dx_[i] = a * last_dx_[i];
    phi = evaluate(c, now_);
    return true;
}

void FlexibleWire::begin_step()
{
    if (open_) close_step();
    stepping_ = true;
}

void FlexibleWire::end_step()
{
    if (open_) close_step();
}

void FlexibleWire::close_step()
{
    ++solved;
    if (!last_converged) ++unconverged;
    open_ = false;
    // Stuck nodes go back to their start: no creep under a load below c_i,
    // however many steps.
    const std::size_t nn = x.size();
    last_dx_.resize(nn);
    for (std::size_t i = 0; i < nn; ++i) {
        if (dx_[i].squaredNorm() < stuck_nm * stuck_nm) dx_[i].setZero();
        last_dx_[i] = dx_[i];
    }
    place_nodes();
}

void FlexibleWire::first_guess(const Contact &c, double t_seg, bool resume, double &phi)
{
    if (resume) {   // the step's last answer, for the apex where it now is
        phi = evaluate(c, now_);
        return;
    }
    if (follow(c, t_seg, phi)) return;
    // A wire in balance where it is does not move: one evaluation decides.
    phi = evaluate(c, now_);
    if (now_.residual >= 1 && last_dx_.size() == start_.size()) warm_start(c, phi);
}

bool FlexibleWire::push(const Eigen::Vector2d &q, double r_tip, double kc, double ride_nN)
{
    const bool resume = open_;
    Contact c;
    c.q = q;
    c.reach = r_tip + 0.5 * d_nm;
    c.kc = kc;
    // The tip touches the features (contact_features) of the segments
    // within reach at the push's start, and a margin: their energy is
    // continuously differentiable in the nodes across a node (the distance
    // to the closest segment is not: a kink wherever the apex faces a node,
    // which would stall Newton and the world's sweeps).
    double t_seg;
    const double dist = closest(q, c.seg, t_seg);
    const double force = tip_push(q, r_tip, kc).force.norm();
    c.lam = lambda_nN;
    contact_window(c);
    in_contact = force > 0;
    // The contact force past what the tip can push: it rides over (the
    // chain's own friction is per node; the press is not modelled on it).
    ridden = in_contact && force > ride_nN;
    if (!in_contact || ridden) {
        // A step under way that lost its contact (the apex stepped back, or
        // rides over) still ends in balance without the tip's push.
        if (!resume || x == start_) return false;
        if (ridden) c.kc = 0, c.lam = 0;
    }
    const Eigen::Vector2d ab = x[c.seg + 1] - x[c.seg], dv = q - (x[c.seg] + t_seg * ab);
    c.n0 = dist > 1e-12 ? Eigen::Vector2d(dv / dist) : Eigen::Vector2d(-ab.y(), ab.x()).normalized();
    const int nn = static_cast<int>(x.size());
    if (!resume) {
        begin_increments();
        open_ = stepping_;
    }
    double phi = 0;
    first_guess(c, t_seg, resume, phi);
    last_q_ = q;
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
    last_converged = now_.residual < 1;
    last_imbalance_nN = now_.imbalance_nN;
    worst_iterations = std::max(worst_iterations, last_iterations);
    if (!stepping_) {
        close_step();
    } else {   // the step goes on: its increment so far, unsnapped (the next push resumes from it)
        last_dx_.resize(nn);
        for (int i = 0; i < nn; ++i) last_dx_[i] = dx_[i];
        place_nodes();
    }
    return true;
}

}  // namespace afm::sim
