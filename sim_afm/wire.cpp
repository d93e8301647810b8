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


}  // namespace afm::sim
