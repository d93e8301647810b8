// Unity tests of the rod's push solvers (sim_afm/rod.cpp): the uniform rod's
// exact solver (rod_push_twist_uniform) against eq. 20 and its hard cases
// (the middle, oblique pushes, nothing resisting), and the K-point solver
// where a trench holds part of the rod.
#include <unity.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <vector>

#include "wire_fixtures.hpp"

using afm::sim::RigidWire;
using afm::sim::RodTwist;

namespace {

// Friction force (rod frame, nN) and torque about the middle (nN nm) of a rod
// with uniform friction density f moving with twist t: midpoint rule, M points.
Eigen::Vector3d friction_wrench(double L, double f, const RodTwist &t, int M)
{
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    for (int k = 0; k < M; ++k) {
        const double u = -L / 2 + (k + 0.5) * L / M;
        const Eigen::Vector2d v(t.vt, t.vn + t.omega * u);
        if (v.norm() == 0) continue;
        const Eigen::Vector2d fr = -f * L / M * v.normalized();
        w += Eigen::Vector3d(fr.x(), fr.y(), u * fr.y());
    }
    return w;
}

// Force and torque left over when the push F p at axial position up meets
// that friction, relative to f L (force) and f L^2 (torque).
double imbalance(double L, double f, double up, const Eigen::Vector2d &p, const RodTwist &t, int M)
{
    const Eigen::Vector3d w = friction_wrench(L, f, t, M) + t.force_nN * Eigen::Vector3d(p.x(), p.y(), up * p.y());
    return std::max(w.head<2>().norm() / (f * L), std::fabs(w[2]) / (f * L * L));
}

// The static point of a side push on a rod lying along a trench over part of
// it, by search: the lumped friction (K points, weight w, hold h_k across)
// turns about a friction point or translates, the least of
// sum_k w h_k |u_k - a| / |u_p - a| over a = u_k, and sum_k w h_k.
double static_point_by_search(const std::vector<double> &u, const std::vector<double> &hold, double up, double &F)
{
    double best = 0, a_best = INFINITY;
    for (double h : hold) best += h;
    for (double a : u) {
        if (a == up) continue;
        double s = 0;
        for (std::size_t k = 0; k < u.size(); ++k) s += hold[k] * std::fabs(u[k] - a);
        if (s / std::fabs(up - a) < best) {
            best = s / std::fabs(up - a);
            a_best = a;
        }
    }
    F = best;
    return a_best;
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_uniform_rod_side_push_is_eq_20_in_closed_form()
{
    // A side push: eq. 20 itself, no iteration, to rounding, at both ends
    // (the tip exactly at a rod end: l = 0 and l = L) and inside.
    const double L = 1300, f = 0.02;
    for (double l : {0.0, L / 8, L / 4, 0.4 * L, 0.6 * L, 3 * L / 4, L}) {
        const RodTwist t = afm::sim::rod_push_twist_uniform(L, f, l - L / 2, Eigen::Vector2d(0, 1), RodTwist{});
        const double s = -t.vn / t.omega + L / 2;
        TEST_ASSERT_EQUAL_INT(0, t.iterations);
        TEST_ASSERT_DOUBLE_WITHIN(1e-12, k_closed(l, L), t.force_nN / (f * L));
        TEST_ASSERT_DOUBLE_WITHIN(1e-12, s_closed(l, L) / L, s / L);
        TEST_ASSERT_DOUBLE_WITHIN(1e-15, 0.0, t.vt);
        TEST_ASSERT_DOUBLE_WITHIN(1e-12, 1.0, t.vn + t.omega * (l - L / 2));   // the contact point advances by one
    }
    // Pushed from the other side (p = -n): the same static point, mirrored motion.
    const RodTwist m = afm::sim::rod_push_twist_uniform(L, f, -L / 2, Eigen::Vector2d(0, -1), RodTwist{});
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, std::sqrt(2.0) - 1, m.force_nN / (f * L));
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 1 / std::sqrt(2.0), (-m.vn / m.omega + L / 2) / L);
}

void test_uniform_rod_middle_push_translates_and_off_middle_turns_about_the_far_end()
{
    // At the middle, and within the contact point's rounding of it
    // (kRodMiddle L), pure translation at f L; a push 1e-6 L off the middle
    // turns the rod about (nearly) its far end, at (nearly) f L: eq. 20's
    // bifurcation, no division by a vanishing l - s.
    const double L = 1000, f = 0.02;
    for (double up : {0.0, 1e-10 * L, -1e-10 * L}) {
        const RodTwist t = afm::sim::rod_push_twist_uniform(L, f, up, Eigen::Vector2d(0, 1), RodTwist{});
        TEST_ASSERT_EQUAL_DOUBLE(0.0, t.omega);
        TEST_ASSERT_DOUBLE_WITHIN(1e-15, 1.0, t.force_nN / (f * L));
    }
    const RodTwist r = afm::sim::rod_push_twist_uniform(L, f, 1e-6 * L, Eigen::Vector2d(0, 1), RodTwist{});
    const double a = -r.vn / r.omega;   // the static point, from the middle
    std::printf("push 1e-6 L off the middle: static point at %.9f L from the middle, F = %.9f f L\n", a / L,
                r.force_nN / (f * L));
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, -0.5, a / L);
    TEST_ASSERT_TRUE(r.force_nN < f * L);
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, 1.0, r.force_nN / (f * L));
}

void test_uniform_rod_oblique_push_balances_and_matches_4096_points()
{
    // An end cap's contact pushes obliquely: Newton on the exact friction
    // power. Against the K = 4096 lumped solver (its force is good to about
    // 1e-7 f L, its rotation centre to 1/K) and against force and torque
    // balance by a 200000-point quadrature of the distributed friction.
    const double L = 1300, f = 0.02;
    const int K = 4096;
    std::vector<double> u(K);
    for (int k = 0; k < K; ++k) u[k] = -L / 2 + (k + 0.5) * L / K;
    for (double th : {0.01, 0.1, 0.5, 1.2, 1.5}) {
        for (double up : {-L / 2, -L / 4, L / 2}) {
            const Eigen::Vector2d p(std::sin(th), std::cos(th));
            const RodTwist t = afm::sim::rod_push_twist_uniform(L, f, up, p, RodTwist{});
            const RodTwist ref = afm::sim::rod_push_twist(u, f * L / K, up, p, RodTwist{}, 1e-13, 20000);
            const double bal = imbalance(L, f, up, p, t, 200000);
            std::printf("oblique %.2f rad at u = %6.1f: F = %.8f f L (K = 4096: %.8f), %d Newton steps, imbalance %.1e\n", th,
                        up, t.force_nN / (f * L), ref.force_nN / (f * L), t.iterations, bal);
            TEST_ASSERT_DOUBLE_WITHIN(1e-6, ref.force_nN / (f * L), t.force_nN / (f * L));
            TEST_ASSERT_DOUBLE_WITHIN(2.0 / K, ref.vt, t.vt);
            TEST_ASSERT_DOUBLE_WITHIN(2.0 / K, ref.vn, t.vn);
            TEST_ASSERT_DOUBLE_WITHIN(2.0 / K, ref.omega * L, t.omega * L);
            TEST_ASSERT_TRUE(bal < 1e-6);
            TEST_ASSERT_TRUE(t.iterations < 50);
        }
    }
}

void test_uniform_rod_oblique_push_tends_to_the_side_push()
{
    // Continuity where the solver switches from Newton to eq. 20: as the
    // contact normal turns perpendicular (the tip slides from the end cap
    // onto the side), the oblique twist tends to the side push's. Cold and
    // warm starts agree.
    const double L = 1300, f = 0.02, up = -L / 2;
    const RodTwist side = afm::sim::rod_push_twist_uniform(L, f, up, Eigen::Vector2d(0, 1), RodTwist{});
    double last = 1e300;
    for (double th : {1e-2, 1e-4, 1e-6, 1e-8}) {
        const Eigen::Vector2d p(std::sin(th), std::cos(th));
        const RodTwist cold = afm::sim::rod_push_twist_uniform(L, f, up, p, RodTwist{});
        const RodTwist warm = afm::sim::rod_push_twist_uniform(L, f, up, p, side);
        const double d = std::max({std::fabs(cold.vt - side.vt), std::fabs(cold.vn - side.vn),
                                   std::fabs(cold.omega - side.omega) * L, std::fabs(cold.force_nN - side.force_nN) / (f * L)});
        std::printf("normal %.0e rad off perpendicular: twist and force within %.2e of the side push's\n", th, d);
        TEST_ASSERT_TRUE(d < 10 * th);
        TEST_ASSERT_TRUE(d < last);
        last = d;
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, cold.force_nN / (f * L), warm.force_nN / (f * L));
        TEST_ASSERT_DOUBLE_WITHIN(1e-6, cold.omega * L, warm.omega * L);
    }
}

void test_rod_without_friction_or_length_translates_along_the_push()
{
    // Nothing resists: the motion is the translation along the push, force 0,
    // whichever solver (and nothing divides by zero).
    const Eigen::Vector2d p = Eigen::Vector2d(0.6, 0.8);
    for (const RodTwist &t : {afm::sim::rod_push_twist_uniform(1000, 0.0, 100, p, RodTwist{}),
                              afm::sim::rod_push_twist_uniform(0.0, 0.02, 0, p, RodTwist{}),
                              afm::sim::rod_push_twist(std::vector<double>(8, 0.0), 0.0, 0, p, RodTwist{})}) {
        TEST_ASSERT_DOUBLE_WITHIN(1e-15, 0.6, t.vt);
        TEST_ASSERT_DOUBLE_WITHIN(1e-15, 0.8, t.vn);
        TEST_ASSERT_DOUBLE_WITHIN(1e-15, 0.0, t.omega);
        TEST_ASSERT_DOUBLE_WITHIN(1e-15, 0.0, t.force_nN);
    }
    // A rod of zero length, pushed by a tip 1 nm inside its reach, is pushed
    // out of contact and stays finite.
    RigidWire r(1, Eigen::Vector2d(0, 0), Eigen::Vector2d(0, 0), 100, 0.02, 64);
    TEST_ASSERT_TRUE(r.push(Eigen::Vector2d(0, -59), 10, 100));
    TEST_ASSERT_TRUE(std::isfinite(r.centre.x()) && std::isfinite(r.centre.y()) && std::isfinite(r.psi));
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 1.0, r.centre.y());
    TEST_ASSERT_FALSE(r.push(Eigen::Vector2d(0, -59), 10, 100));   // now just touching: nothing left to push
}

void test_rod_held_with_no_friction_difference_moves_as_the_uniform_rod()
{
    // A trench whose hold is 1 (friction across it as along it: no
    // difference) under half of the rod: the K-point solver takes over, and
    // must agree with the exact uniform one to its quadrature (1/K of L for
    // the static point, 1e-3 f L for the force).
    const double L = 1000, f = 0.02;
    const int K = 64;
    std::vector<double> u(K);
    for (int k = 0; k < K; ++k) u[k] = -L / 2 + (k + 0.5) * L / K;
    std::vector<Eigen::Matrix2d> metric(K, Eigen::Matrix2d::Identity());
    for (int k = K / 2; k < K; ++k) metric[k] = Eigen::Vector2d(1, 0) * Eigen::RowVector2d(1, 0) +
                                                 (1 + 1e-12) * Eigen::Vector2d(0, 1) * Eigen::RowVector2d(0, 1);
    for (double l : {0.0, L / 4, 0.9 * L}) {
        const Eigen::Vector2d p(0, 1);
        const RodTwist held = afm::sim::rod_push_twist(u, f * L / K, l - L / 2, p, RodTwist{}, 1e-10, 5000, &metric);
        const RodTwist exact = afm::sim::rod_push_twist_uniform(L, f, l - L / 2, p, RodTwist{});
        TEST_ASSERT_DOUBLE_WITHIN(1e-3, exact.force_nN / (f * L), held.force_nN / (f * L));
        TEST_ASSERT_DOUBLE_WITHIN(1.0 / K, -exact.vn / exact.omega / L, -held.vn / held.omega / L);
    }
    // The same in a rod: a trap that holds its right half with hold 1.
    RigidWire plain(1, Eigen::Vector2d(-L / 2, 0), Eigen::Vector2d(L / 2, 0), 100, f, K);
    RigidWire trapped(2, Eigen::Vector2d(-L / 2, 0), Eigen::Vector2d(L / 2, 0), 100, f, K);
    trapped.trap = [](const Eigen::Vector2d &q, double, Eigen::Vector2d &along, double &hold) {
        along = Eigen::Vector2d(1, 0);
        hold = 1.0;
        return q.x() > 0;
    };
    for (int i = 0; i < 200; ++i) {   // the tip 0.5 nm into the end A's reach (50 nN), again and again
        plain.push(Eigen::Vector2d(-L / 2, plain.nodes()[0].y() - 59.5), 10, 100);
        trapped.push(Eigen::Vector2d(-L / 2, trapped.nodes()[0].y() - 59.5), 10, 100);
    }
    TEST_ASSERT_EQUAL_INT(K / 2, trapped.held_points);
    TEST_ASSERT_EQUAL_INT(0, plain.held_points);
    std::printf("end pushes, hold 1 on half of the rod: rotation %.6e rad (uniform %.6e), centre moved %.6f nm (uniform %.6f)\n",
                trapped.psi, plain.psi, trapped.centre.y(), plain.centre.y());
    TEST_ASSERT_DOUBLE_WITHIN(0.02 * std::fabs(plain.psi), plain.psi, trapped.psi);
    TEST_ASSERT_DOUBLE_WITHIN(0.02 * std::fabs(plain.centre.y()), plain.centre.y(), trapped.centre.y());
}

void test_rod_held_from_its_static_point_on_balances_and_matches_the_search()
{
    // The hard case of the K-point solver: a trench holds the rod (along it,
    // across-friction h = 5) from exactly the uniform rod's static point to
    // its end B, and the rod is pushed at end A. The static point moves into
    // the held part's edge region; force and torque balance and the static
    // point agrees with a search over the friction points (to 2/K of L), for
    // the boundary on the static point and one friction point either side
    // (continuity).
    const double L = 1000, f = 0.02, up = -L / 2, h = 5;
    const int K = 1024;
    std::vector<double> u(K);
    for (int k = 0; k < K; ++k) u[k] = -L / 2 + (k + 0.5) * L / K;
    const RodTwist uniform = afm::sim::rod_push_twist_uniform(L, f, up, Eigen::Vector2d(0, 1), RodTwist{});
    const double a_star = -uniform.vn / uniform.omega;   // 0.2071 L from the middle
    double last_a = 0;
    bool first = true;
    for (double shift : {-L / K, 0.0, L / K}) {
        std::vector<Eigen::Matrix2d> metric(K, Eigen::Matrix2d::Identity());
        std::vector<double> hold(K, 1.0);
        for (int k = 0; k < K; ++k)
            if (u[k] >= a_star + shift) {
                metric[k](1, 1) = h;
                hold[k] = h;
            }
        const RodTwist t = afm::sim::rod_push_twist(u, f * L / K, up, Eigen::Vector2d(0, 1), uniform, 1e-12, 20000, &metric);
        double F_search;
        const double a_search = static_point_by_search(u, hold, up, F_search);
        const double a = -t.vn / t.omega;
        // Balance of the lumped friction with its metric (force normal to
        // the rod, torque about the static point): every point but the one
        // the rod turns about (its velocity is zero to rounding, so its
        // friction may take any value up to its capacity) pushes back
        // against its own velocity; the pivot's share is what is left, and
        // must lie within that capacity.
        int pivot = 0;
        for (int k = 1; k < K; ++k)
            if (std::fabs(t.vn + t.omega * u[k]) < std::fabs(t.vn + t.omega * u[pivot])) pivot = k;
        double Fn = t.force_nN, M = (up - a) * t.force_nN;
        for (int k = 0; k < K; ++k) {
            if (k == pivot) continue;
            const Eigen::Vector2d v(t.vt, t.vn + t.omega * u[k]);
            const Eigen::Vector2d Gv = metric[k] * v;
            const Eigen::Vector2d fr = -f * L / K * (metric[k].transpose() * Gv) / Gv.norm();
            Fn += fr.y();
            M += (u[k] - a) * fr.y();
        }
        std::printf("held from %+.4f L: static point %.5f L (search %.5f L, uniform %.5f L), F = %.6f f L (search %.6f),"
                    " pivot's share %.3f of its capacity, torque left %.1e f L^2\n", (a_star + shift) / L, a / L,
                    a_search / L, a_star / L, t.force_nN / (f * L), F_search / K, std::fabs(Fn) / (f * L / K * hold[pivot]),
                    std::fabs(M) / (f * L * L));
        TEST_ASSERT_TRUE(std::isfinite(a) && std::isfinite(t.force_nN));
        TEST_ASSERT_DOUBLE_WITHIN(2.0 / K, a_search / L, a / L);
        TEST_ASSERT_DOUBLE_WITHIN(1e-6, F_search / K, t.force_nN / (f * L));
        TEST_ASSERT_TRUE(std::fabs(Fn) <= f * L / K * hold[pivot] * (1 + 1e-6));
        TEST_ASSERT_TRUE(std::fabs(M) < 1e-6 * f * L * L);
        TEST_ASSERT_TRUE(t.force_nN >= uniform.force_nN * (1 - 1e-9));   // holding never lowers the push
        if (!first) TEST_ASSERT_DOUBLE_WITHIN(3.0 / K, last_a / L, a / L);
        last_a = a;
        first = false;
    }
}

void test_rigid_rod_without_a_trench_does_not_depend_on_K()
{
    // Uniform friction is integrated exactly: K (friction_points) no longer
    // matters unless a trench holds part of the rod.
    RigidWire a(1, Eigen::Vector2d(-500, 0), Eigen::Vector2d(500, 0), 100, 0.02, 4);
    RigidWire b(2, Eigen::Vector2d(-500, 0), Eigen::Vector2d(500, 0), 100, 0.02, 64);
    for (int i = 0; i < 300; ++i) {
        const Eigen::Vector2d q(-400 - 0.5 * i, -59.5 + 0.1 * i);   // drifting onto the end cap: side, then oblique
        a.push(q, 10, 10);
        b.push(q, 10, 10);
    }
    TEST_ASSERT_EQUAL_DOUBLE(a.psi, b.psi);
    TEST_ASSERT_EQUAL_DOUBLE(a.centre.x(), b.centre.x());
    TEST_ASSERT_EQUAL_DOUBLE(a.centre.y(), b.centre.y());
    TEST_ASSERT_TRUE(std::fabs(a.psi) > 1e-3);   // it did turn
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_uniform_rod_side_push_is_eq_20_in_closed_form);
    RUN_TEST(test_uniform_rod_middle_push_translates_and_off_middle_turns_about_the_far_end);
    RUN_TEST(test_uniform_rod_oblique_push_balances_and_matches_4096_points);
    RUN_TEST(test_uniform_rod_oblique_push_tends_to_the_side_push);
    RUN_TEST(test_rod_without_friction_or_length_translates_along_the_push);
    RUN_TEST(test_rod_held_with_no_friction_difference_moves_as_the_uniform_rod);
    RUN_TEST(test_rod_held_from_its_static_point_on_balances_and_matches_the_search);
    RUN_TEST(test_rigid_rod_without_a_trench_does_not_depend_on_K);
    return UNITY_END();
}
