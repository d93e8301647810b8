// The tip's dilation of a height map over a lattice (dilation.hpp).

#include "dilation.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>

namespace afm::sim {

namespace {

constexpr double kNone = -std::numeric_limits<double>::infinity();
int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

}  // namespace

double TipShape::profile(double u) const
{
    const double rt = radius_nm, u0 = rt * std::cos(half_angle_rad);
    if (u <= u0) return rt - std::sqrt(std::max(0.0, rt * rt - u * u));
    return rt - rt * std::sin(half_angle_rad) + (u - u0) / std::tan(half_angle_rad);
}

double TipShape::reach(double z) const
{
    const double rt = radius_nm, z0 = rt - rt * std::sin(half_angle_rad);
    if (z <= z0) return std::sqrt(std::max(0.0, rt * rt - (rt - z) * (rt - z)));
    return rt * std::cos(half_angle_rad) + (z - z0) * std::tan(half_angle_rad);
}

double TipShape::bump(double rho, double r) const
{
    // The touching point lies in the vertical plane through the tip's axis
    // and the centre; along it the gap s(w) - t(|rho - w|) is concave.
    if (profile(std::max(0.0, rho - r)) >= 2 * r) return 0.0;   // the flank clears the top
    auto gap = [&](double w) { return r + std::sqrt(std::max(0.0, r * r - w * w)) - profile(std::fabs(rho - w)); };
    double a = -r, b = r;
    const double phi = (std::sqrt(5.0) - 1) / 2;
    double c = b - phi * (b - a), d = a + phi * (b - a);
    double fc = gap(c), fd = gap(d);
    for (int i = 0; i < 60 && b - a > 1e-6; ++i) {
        if (fc > fd) { b = d; d = c; fd = fc; c = b - phi * (b - a); fc = gap(c); }
        else { a = c; c = d; fc = fd; d = a + phi * (b - a); fd = gap(d); }
    }
    return std::max(0.0, gap(0.5 * (a + b)));
}

double TipShape::pillar(double d, double height_nm) const { return d <= 0 ? height_nm : height_nm - profile(d); }

DilatedField::DilatedField(const TipShape &tip, double x0_nm, double y0_nm, double h_nm, double relief_nm, double slope, MapFill fill)
    : tip_(tip), x0_(x0_nm), y0_(y0_nm), h_(h_nm), fill_(std::move(fill))
{
    if (!(h_nm > 0) || !std::isfinite(x0_nm) || !std::isfinite(y0_nm) || !(tip.radius_nm >= 0) || !(tip.half_angle_rad > 0) ||
        !(tip.half_angle_rad < M_PI / 2) || !(relief_nm >= 0) || !(slope >= 0))
        throw std::invalid_argument("dilation: a lattice needs a pitch > 0, a finite origin, a tip radius >= 0, a half angle in (0, 90) deg, "
                                    "a relief >= 0 and a slope >= 0; pitch " + std::to_string(h_nm));
    // The footprint: where t(u) stays below the relief plus the slope's rise
    // over u (t grows by cot(gamma) a nm on the flank: a slope as steep as
    // the cone has no such bound, and the footprint is the largest).
    // On the flank t(u) = cot(gamma) u + c0, so u >= (relief - c0) / (cot(gamma) - slope) suffices.
    const double cot = 1 / std::tan(tip.half_angle_rad), rt = tip.radius_nm;
    const double c0 = rt - rt * std::sin(tip.half_angle_rad) - cot * rt * std::cos(tip.half_angle_rad);
    const double rho = slope < cot ? std::max(tip.reach(relief_nm), (relief_nm - c0) / (cot - slope)) : kMaxReach * h_nm;
    reach_ = std::min(kMaxReach, static_cast<int>(std::ceil(rho / h_)) + 1);
    for (int dj = -reach_; dj <= reach_; ++dj)
        for (int di = -reach_; di <= reach_; ++di)
            if (di * di + dj * dj <= reach_ * reach_) offsets_.push_back({di, dj, tip.profile(h_ * std::hypot(di, dj))});
    std::stable_sort(offsets_.begin(), offsets_.end(), [](const Offset &a, const Offset &b) { return a.t < b.t; });
}

const DilatedField::Map &DilatedField::map(int64_t ti, int64_t tj) const
{
    const int64_t k = key(ti, tj);
    if (last_map_ && last_map_key_ == k) return *last_map_;
    auto it = maps_.find(k);
    if (it == maps_.end()) {
        Map m;
        const std::size_t n = kTile * kTile, nb = (kTile / kBlock) * (kTile / kBlock);
        m.b.resize(n);
        m.g.resize(n);
        m.o.resize(n);
        m.max_b.assign(nb, kNone);
        m.max_o.assign(nb, kNone);
        for (int r = 0; r < kTile; ++r)
            fill_(x0_ + static_cast<double>(ti * kTile) * h_, y0_ + static_cast<double>(tj * kTile + r) * h_, kTile, h_, &m.b[r * kTile],
                  &m.g[r * kTile], &m.o[r * kTile]);
        for (int r = 0; r < kTile; ++r)
            for (int c = 0; c < kTile; ++c) {
                const std::size_t blk = static_cast<std::size_t>((r / kBlock) * (kTile / kBlock) + c / kBlock);
                m.max_b[blk] = std::max(m.max_b[blk], m.b[r * kTile + c]);
                m.max_o[blk] = std::max(m.max_o[blk], m.o[r * kTile + c]);
            }
        it = maps_.emplace(k, std::move(m)).first;
    }
    last_map_ = &it->second;
    last_map_key_ = k;
    return it->second;
}

void DilatedField::map_at(int64_t i, int64_t j, double *b, double *o) const
{
    const int64_t ti = floor_div(i, kTile), tj = floor_div(j, kTile);
    const Map &m = map(ti, tj);
    const std::size_t at = static_cast<std::size_t>((j - tj * kTile) * kTile + (i - ti * kTile));
    *b = m.b[at];
    *o = m.o[at];
}

void DilatedField::bound(int64_t bi, int64_t bj, double *mb, double *mo) const
{
    *mb = *mo = kNone;
    const int64_t lo_i = floor_div(bi * kBlock - reach_, kBlock), hi_i = floor_div(bi * kBlock + kBlock - 1 + reach_, kBlock);
    const int64_t lo_j = floor_div(bj * kBlock - reach_, kBlock), hi_j = floor_div(bj * kBlock + kBlock - 1 + reach_, kBlock);
    constexpr int64_t per = kTile / kBlock;
    for (int64_t cj = lo_j; cj <= hi_j; ++cj)
        for (int64_t ci = lo_i; ci <= hi_i; ++ci) {
            const int64_t ti = floor_div(ci, per), tj = floor_div(cj, per);
            const Map &m = map(ti, tj);
            const std::size_t blk = static_cast<std::size_t>((cj - tj * per) * per + (ci - ti * per));
            *mb = std::max(*mb, m.max_b[blk]);
            *mo = std::max(*mo, m.max_o[blk]);
        }
}

void DilatedField::dilate_tile(int64_t ti, int64_t tj, std::vector<double> &out) const
{
    // The map over the tile and its footprint's margin, in one window.
    const int side = kTile + 2 * reach_;
    std::vector<double> wb(static_cast<std::size_t>(side) * side), wo(wb.size());
    const int64_t i0 = ti * kTile - reach_, j0 = tj * kTile - reach_;
    for (int r = 0; r < side; ++r)
        for (int c = 0; c < side; ++c) map_at(i0 + c, j0 + r, &wb[static_cast<std::size_t>(r) * side + c], &wo[static_cast<std::size_t>(r) * side + c]);
    const Map &own = map(ti, tj);
    out.assign(kTile * kTile, 0.0);
    constexpr int per = kTile / kBlock;
    for (int bj = 0; bj < per; ++bj)
        for (int bi = 0; bi < per; ++bi) {
            double mb, mo;
            bound(ti * per + bi, tj * per + bj, &mb, &mo);
            for (int r = bj * kBlock; r < (bj + 1) * kBlock; ++r)
                for (int c = bi * kBlock; c < (bi + 1) * kBlock; ++c) {
                    const double g = own.g[static_cast<std::size_t>(r) * kTile + c];
                    const std::size_t w = static_cast<std::size_t>(r + reach_) * side + (c + reach_);
                    double best = std::max(wb[w] - g, wo[w]);
                    const double top = std::max(mb - g, mo);   // the most any offset can give, before its t
                    for (std::size_t k = 1; k < offsets_.size(); ++k) {
                        const Offset &f = offsets_[k];
                        if (f.t >= top - best) break;
                        const std::size_t at = static_cast<std::size_t>(static_cast<int64_t>(w) + static_cast<int64_t>(f.dj) * side + f.di);
                        best = std::max(best, std::max(wb[at] - g, wo[at]) - f.t);
                    }
                    out[static_cast<std::size_t>(r) * kTile + c] = best;
                }
        }
}

void DilatedField::drop_below(int64_t tj) const
{
    auto row = [](int64_t k) { return static_cast<int64_t>(static_cast<int32_t>(k & 0xffffffffLL)); };
    for (auto it = maps_.begin(); it != maps_.end();) it = row(it->first) < tj ? maps_.erase(it) : std::next(it);
    for (auto it = images_.begin(); it != images_.end();) it = row(it->first) < tj ? images_.erase(it) : std::next(it);
    last_map_ = nullptr;
}

const std::vector<double> &DilatedField::image(int64_t ti, int64_t tj) const
{
    const int64_t k = key(ti, tj);
    auto it = images_.find(k);
    if (it != images_.end()) return it->second;
    // a tile's map reaches reach_ nodes (a tile row or more) below it; one row more kept
    if (maps_.size() > kKeepTiles) drop_below(tj - 2 - reach_ / kTile);
    std::vector<double> out;
    dilate_tile(ti, tj, out);
    return images_.emplace(k, std::move(out)).first->second;
}

double DilatedField::node(int64_t i, int64_t j) const
{
    const int64_t ti = floor_div(i, kTile), tj = floor_div(j, kTile);
    return image(ti, tj)[static_cast<std::size_t>((j - tj * kTile) * kTile + (i - ti * kTile))];
}

double DilatedField::height(double x, double y, Eigen::Vector2d *grad) const
{
    const double fx = (x - x0_) / h_, fy = (y - y0_) / h_;
    const double fi = std::floor(fx), fj = std::floor(fy);
    const int64_t i = static_cast<int64_t>(fi), j = static_cast<int64_t>(fj);
    const double t = fx - fi, u = fy - fj;
    const double w[4] = {(1 - t) * (1 - u), t * (1 - u), (1 - t) * u, t * u};
    const int64_t ni[4] = {i, i + 1, i, i + 1}, nj[4] = {j, j, j + 1, j + 1};
    double z = 0;
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (int k = 0; k < 4; ++k) {
        if (w[k] == 0) continue;   // a point on a node's row or column reads no further
        z += w[k] * node(ni[k], nj[k]);
        if (grad)
            g += w[k] * Eigen::Vector2d(node(ni[k] + 1, nj[k]) - node(ni[k] - 1, nj[k]), node(ni[k], nj[k] + 1) - node(ni[k], nj[k] - 1)) / (2 * h_);
    }
    if (grad) *grad = g;
    return z;
}

}  // namespace afm::sim
