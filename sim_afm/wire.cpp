// A wire's shared geometry (wire.hpp, Wire): its box, its axis distance and
// the tip's contact with its polyline. The models: rod.cpp (rigid),
// flexible_wire.cpp (segments), block_pentadiagonal.cpp (their solve).

#include "wire.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "wire_internal.hpp"

namespace afm::sim {

double segment_param(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &q)
{
    const Eigen::Vector2d ab = b - a;
    const double l2 = ab.squaredNorm();
    if (l2 <= 0) return 0.0;
    return std::clamp((q - a).dot(ab) / l2, 0.0, 1.0);
}

namespace detail {

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

}  // namespace detail

using detail::closest_segment;

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

void contact_features(const Eigen::Vector2d *xs, int lo, int hi, const Eigen::Vector2d &q, double reach,
                      const Eigen::Vector2d &n0, std::vector<ContactFeature> &out)
{
    // One pass over the nodes lo..hi + 1: node j's count gathers segment
    // j - 1 ending at it and segment j starting at it (their closest point
    // clamped to it), less one where both are in the window.
    bool prev_end = false;   // segment j - 1's closest point is node j
    for (int j = lo; j <= hi + 1; ++j) {
        int m = prev_end ? 1 : 0;
        prev_end = false;
        if (j <= hi) {   // segment j
            const Eigen::Vector2d ab = xs[j + 1] - xs[j], qa = q - xs[j];
            const double l2 = ab.squaredNorm(), t = l2 > 0 ? qa.dot(ab) / l2 : 0.0;
            if (t <= 0) {
                ++m;
            } else if (t >= 1) {
                prev_end = true;
            } else {
                const Eigen::Vector2d d = qa - t * ab;
                const double dn = d.norm();
                if (dn < reach) {
                    ContactFeature f;
                    f.a = j, f.t = t, f.dist = dn;
                    f.n = dn > 1e-12 ? Eigen::Vector2d(d / dn) : Eigen::Vector2d(Eigen::Vector2d(-ab.y(), ab.x()).normalized());
                    out.push_back(f);
                }
            }
        }
        if (j > lo && j <= hi) --m;   // an inner node of the window: both its segments counted it
        if (m == 0) continue;
        const Eigen::Vector2d d = q - xs[j];
        const double dn = d.norm();
        if (!(dn < reach)) continue;
        ContactFeature f;
        f.a = j, f.node = true, f.sign = m, f.dist = dn;
        f.n = dn > 1e-12 ? Eigen::Vector2d(d / dn) : n0;
        out.push_back(f);
    }
}

TipPush Wire::tip_push(const Eigen::Vector2d &q, double r_tip, double k) const
{
    TipPush r;
    if (!(k > 0)) return r;
    const double reach = r_tip + 0.5 * d_nm + lambda_nN / k;
    features_.clear();
    const Eigen::Vector2d ab = x[1] - x[0];
    contact_features(x.data(), 0, static_cast<int>(x.size()) - 2, q, reach, Eigen::Vector2d(-ab.y(), ab.x()).normalized(), features_);
    const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
    for (const auto &f : features_) {
        const double push = k * (reach - f.dist);   // max(0, lambda + k pen): the feature is within reach
        r.force += f.sign * push * f.n;
        Eigen::Matrix2d s = k * f.n * f.n.transpose();
        if (f.node && f.dist > 1e-12) s -= push / f.dist * (I - f.n * f.n.transpose());   // the node's normal turns with q
        r.stiffness += f.sign * s;
    }
    return r;
}

}  // namespace afm::sim
