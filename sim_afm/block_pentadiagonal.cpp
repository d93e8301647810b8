// The flexible wire's Newton system (wire.hpp: BlockPentadiagonal): a
// block LDL^T of a symmetric block-pentadiagonal matrix of 2 x 2 blocks.

#include "wire.hpp"

namespace afm::sim {

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


}  // namespace afm::sim
