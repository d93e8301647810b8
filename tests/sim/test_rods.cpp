// Unity tests of the rigid rod (sim_afm/rod.cpp) against physics.md section
// 6, whose closed forms are wire_fixtures.hpp's: the lumped solver's static
// point and least push, a rod pushed through the whole world (the closed-form
// and numeric solvers), the down force (eq. 29) and the tip riding over a
// rod below eq. 30's load.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <vector>

#include "wire_fixtures.hpp"

using afm::sim::RigidWire;
using afm::sim::RodTwist;
using afm::sim::World;

namespace {

// The rod's travel (nm, its middle's, along the push) when the tip, at
// load_nN and cone half angle gamma, sweeps 65 nm across its middle
// (down_force), and the samples the tip rode over it.
std::pair<double, long> ride_sweep(double gamma_deg, double load_nN)
{
    const double L = 1000;
    const afm::Scene s = wire_scene(L, ", down_force", 20, 32, 8, load_nN, gamma_deg);
    World w(s);
    const double cn_off = w.lever().normal_offset(load_nN).x();
    double y = -70;
    w.command(Eigen::Vector2d(-cn_off, y), load_nN, true);
    for (int i = 0; i < 1000; ++i) w.step();
    const double y0 = w.wires()[0]->nodes().front().y() + w.wires()[0]->nodes().back().y();
    for (int i = 0; i <= 1300; ++i) {
        y += 0.05;
        w.command(Eigen::Vector2d(-cn_off, y), load_nN, true);
        w.step();
    }
    const double y1 = w.wires()[0]->nodes().front().y() + w.wires()[0]->nodes().back().y();
    return {0.5 * (y1 - y0), w.ridden_samples()};
}

// Eq. 30's least load for a push at the middle of the rod of ride_sweep
// (k = 1, f L = 20 nN, wire mu 0.3, tip adhesion 1 nN): H = f L / (1 - mu
// tan psi), psi = gamma + theta_t(H), dF = H tan psi - F_a,ts. The model
// under test (a reference for the loads), not the simulator's rule.
double eq30_least_load(double gamma_deg)
{
    const afm::Scene s = wire_scene(1000, ", down_force", 20, 32, 8, 5.0, gamma_deg);
    World w(s);
    const double fL = 20.0, mu = s.wire_model.mu;
    double psi = gamma_deg * M_PI / 180.0, H = fL;
    for (int i = 0; i < 50; ++i) {
        H = fL / (1.0 - mu * std::tan(psi));
        psi = gamma_deg * M_PI / 180.0 + std::fabs(w.lever().twist(H));
    }
    return H * std::tan(psi) - s.tip_substrate.adhesion_nN;
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_rod_static_point_and_least_push_match_section_6()
{
    // K = 4096 friction points: the midpoint rule's error in F is O(1/K^2),
    // about 1e-7 f L here; tolerance 1e-5 f L on F. The lumped friction puts
    // the rotation centre on a friction point (D is piecewise linear in the
    // centre's position, with its kinks there), so s is good to half a
    // spacing: tolerance 1/K of L.
    const double L = 1000, f = 0.02;
    const double ls[] = {0.0, L / 8, L / 4, 0.4 * L, 0.6 * L, 3 * L / 4, L};
    for (double l : ls) {
        const RodTwist t = solve(l, L, f, 4096);
        const double s = -t.vn / t.omega + L / 2;   // zero normal velocity on the axis
        std::printf("l = %6.1f nm: F = %.7f f L (closed %.7f), s = %.4f L (closed %.4f), %d iterations\n", l,
                    t.force_nN / (f * L), k_closed(l, L), s / L, s_closed(l, L) / L, t.iterations);
        TEST_ASSERT_DOUBLE_WITHIN(1e-5, k_closed(l, L), t.force_nN / (f * L));
        TEST_ASSERT_DOUBLE_WITHIN(1.0 / 4096, s_closed(l, L) / L, s / L);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.0, t.vt);   // no sliding along the axis
    }
}

void test_rod_end_push_is_sqrt2_minus_1_not_2_minus_sqrt2()
{
    // The seed's 0.586 f L is wrong; torque and force balance give 0.414 f L.
    const double L = 1300, f = 0.03;
    const RodTwist t = solve(0.0, L, f, 4096);
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, std::sqrt(2.0) - 1, t.force_nN / (f * L));
    TEST_ASSERT_TRUE(std::fabs(t.force_nN / (f * L) - (2 - std::sqrt(2.0))) > 0.1);
}

void test_rod_middle_push_translates_at_f_L()
{
    // At l = L/2 the symmetric solution is pure translation: omega = 0 to
    // rounding, F = f L to the quadrature's rounding (1e-12).
    const double L = 1000, f = 0.02;
    const RodTwist t = solve(L / 2, L, f, 64);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, t.omega);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 1.0, t.force_nN / (f * L));
}

void test_rod_default_64_points_within_half_a_percent()
{
    // The simulator's default K = 64: F within 0.5% of f L (measured about
    // 1e-4) and s within 1/K of L (the quantisation above) at l = 0 and L/4.
    const double L = 1000, f = 0.02;
    for (double l : {0.0, L / 4}) {
        const RodTwist t = solve(l, L, f, 64);
        TEST_ASSERT_DOUBLE_WITHIN(5e-3, k_closed(l, L), t.force_nN / (f * L));
        TEST_ASSERT_DOUBLE_WITHIN(1.0 / 64, s_closed(l, L) / L, (-t.vn / t.omega + L / 2) / L);
    }
}

void test_rod_twist_balances_force_and_torque()
{
    // The solver's result, checked directly: the friction of the K points
    // (each f dL against its own velocity) plus the push F p sums to zero force
    // and zero torque about the centre, to 1e-6 f L (IRLS tolerance).
    const double L = 1000, f = 0.02;
    const int K = 512;
    std::vector<double> u(K);
    for (int k = 0; k < K; ++k) u[k] = -L / 2 + (k + 0.5) * L / K;
    const Eigen::Vector2d p = Eigen::Vector2d(0.3, 1.0).normalized();   // oblique push at an end cap
    const double up = -L / 2;
    const RodTwist t = afm::sim::rod_push_twist(u, f * L / K, up, p, RodTwist{}, 1e-15, 20000);
    Eigen::Vector2d F = t.force_nN * p;
    double M = up * F.y();
    for (double uk : u) {
        const Eigen::Vector2d v(t.vt, t.vn + t.omega * uk);
        const Eigen::Vector2d fr = -f * L / K * v.normalized();
        F += fr;
        M += uk * fr.y();
    }
    std::printf("oblique push: F = %.6f f L, residual force %.2e, torque %.2e f L^2\n", t.force_nN / (f * L),
                F.norm() / (f * L), M / (f * L * L));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, F.norm() / (f * L));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, M / (f * L * L));
}

void test_the_numeric_rod_solver_agrees_with_the_closed_form()
{
    // sample.wire.solver numeric: the friction lumped on 64 points and the
    // balance iterated, independent of eq. 20 (the card's model). The same
    // pushes through the whole world: force within 2 % of f L and static
    // point within 2 % of L of the closed-form path's, at three push points.
    const double L = 1000, fL = 20.0 * L / 1000;
    for (double l : {0.03 * L, L / 4, 0.45 * L}) {
        const PushResult c = push_world(l, L), n = push_world(l, L, "", 32, 8, 5, "numeric");
        std::printf("push at l = %.0f: F closed %.4f numeric %.4f f L; s closed %.4f numeric %.4f L\n", l, c.force_nN / fL,
                    n.force_nN / fL, c.s_nm / L, n.s_nm / L);
        TEST_ASSERT_DOUBLE_WITHIN(0.02, c.force_nN / fL, n.force_nN / fL);
        TEST_ASSERT_DOUBLE_WITHIN(0.02, c.s_nm / L, n.s_nm / L);
    }
    World w(wire_scene(L, "", 20, 32, 8, 5, 20, "numeric"));
    TEST_ASSERT_TRUE(has(w.models_built(), "wires:rigid_rod_numeric"));
}

void test_pushed_rod_in_the_world_moves_as_section_6_says()
{
    // The whole chain (scanner, compliant lever, penalty contact, the rod's
    // friction integrated exactly, quasi-static relaxation): force within 2%
    // of f L and rotation centre within 2% of L (the relaxation's lag and
    // the finite rotation over the 30 nm window; it prints both), at l = 0,
    // L/4 and L/2.
    const double L = 1000, fL = 20.0 * L / 1000;
    for (double l : {0.0, L / 4}) {
        const PushResult r = push_world(l, L);
        std::printf("world push at l = %.0f: F = %.4f f L (closed %.4f), s = %.4f L (closed %.4f)\n", l, r.force_nN / fL,
                    k_closed(l, L), r.s_nm / L, s_closed(l, L) / L);
        TEST_ASSERT_DOUBLE_WITHIN(0.02, k_closed(l, L), r.force_nN / fL);
        TEST_ASSERT_DOUBLE_WITHIN(0.02, s_closed(l, L) / L, r.s_nm / L);
    }
    const PushResult m = push_world(L / 2, L);
    std::printf("world push at l = L/2: F = %.4f f L, rotation %.3e rad\n", m.force_nN / fL, m.dpsi);
    TEST_ASSERT_DOUBLE_WITHIN(0.02, 1.0, m.force_nN / fL);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.0, m.dpsi);   // pure translation
}

void test_down_force_raises_the_push_as_eq_29_and_squeezes_past_psi_max()
{
    // down_force: the cone (gamma 20 deg, the default; wire mu 0.3) presses
    // the rod by H tan psi. At the middle (k = 1) the push that moves it is
    // f L / (1 - mu tan psi), psi = gamma + theta_t (eq. 29's horizontal part).
    // The load (20 nN) holds the tip down against it (eq. 30's least load is
    // about 8 nN here; at the other tests' 5 nN the tip rides over).
    const double L = 1000, fL = 20.0 * L / 1000;
    const afm::Scene sc = wire_scene(L, ", down_force", 20, 32, 8, 20.0);
    const PushResult m = push_world(L / 2, L, ", down_force", 32, 8, 20.0);
    World w(sc);
    const double psi = 20.0 * M_PI / 180.0 + std::fabs(w.lever().twist(m.force_nN));
    const double expect = 1.0 / (1.0 - sc.wire_model.mu * std::tan(psi));
    std::printf("down_force push at l = L/2: F = %.4f f L (eq. 29: %.4f, without the down force 1)\n", m.force_nN / fL, expect);
    TEST_ASSERT_DOUBLE_WITHIN(0.02 * expect, expect, m.force_nN / fL);
    // A rod alone: k mu tan psi at 1 - 1e-3 moves under a push past D0 / a;
    // at 1 + 1e-3 no push moves it (squeezed), however deep the contact.
    RigidWire r(1, Eigen::Vector2d(-L / 2, 0), Eigen::Vector2d(L / 2, 0), 100, 0.02, 64);
    r.mu = 1.0;
    const Eigen::Vector2d q(0, -59);   // 1 nm into the reach 10 + 50 at the middle
    r.press_tan = 1.0 + 1e-3;
    TEST_ASSERT_FALSE(r.push(q, 10, 1e6));   // 10^6 nN against f L = 20 nN
    TEST_ASSERT_TRUE(r.squeezed);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, r.centre.y());
    r.press_tan = 1.0 - 1e-3;                  // the push needed: 20 / 1e-3 = 20000 nN
    TEST_ASSERT_FALSE(r.push(q, 10, 1e3));     // 1000 nN: static
    TEST_ASSERT_FALSE(r.squeezed);
    r.press_tan = 1.0 - 0.5;                   // 40 nN: 1000 nN moves it
    TEST_ASSERT_TRUE(r.push(q, 10, 1e3));
    TEST_ASSERT_TRUE(r.centre.y() > 0);
    // Zero friction: nothing to raise, nothing divides by zero.
    RigidWire z(2, Eigen::Vector2d(-L / 2, 0), Eigen::Vector2d(L / 2, 0), 100, 0.0, 64);
    z.mu = 1.0;
    z.press_tan = 10.0;
    TEST_ASSERT_TRUE(z.push(q, 10, 1e6));
    TEST_ASSERT_FALSE(z.squeezed);
}

void test_the_tip_rides_over_a_sliding_rod_below_eq_30s_load_and_pushes_it_above()
{
    // The simulator finds lift-off from the tip's own balance (World::
    // ride_push_nN against the wire's own friction), not from eq. 30; eq. 30 only picks the loads here. At
    // 0.9 of its least load the rod moves less than 2 nm and the tip rides
    // over it; at 1.1 the rod is pushed (tens of nm) and the tip stays
    // down. Two cone angles, both below psi_max (no squeeze).
    for (double gamma : {20.0, 35.0}) {
        const double dF = eq30_least_load(gamma);
        const auto low = ride_sweep(gamma, 0.9 * dF), high = ride_sweep(gamma, 1.1 * dF);
        std::printf("gamma %.0f deg: eq. 30 least load %.2f nN; at 0.9x the rod moved %.3f nm (ridden %ld samples), "
                    "at 1.1x %.2f nm (ridden %ld)\n", gamma, dF, low.first, low.second, high.first, high.second);
        TEST_ASSERT_TRUE(std::fabs(low.first) < 2.0);
        TEST_ASSERT_TRUE(low.second > 100);
        TEST_ASSERT_TRUE(high.first > 20.0);
        TEST_ASSERT_EQUAL(0, high.second);
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_rod_static_point_and_least_push_match_section_6);
    RUN_TEST(test_rod_end_push_is_sqrt2_minus_1_not_2_minus_sqrt2);
    RUN_TEST(test_rod_middle_push_translates_at_f_L);
    RUN_TEST(test_rod_default_64_points_within_half_a_percent);
    RUN_TEST(test_rod_twist_balances_force_and_torque);
    RUN_TEST(test_the_numeric_rod_solver_agrees_with_the_closed_form);
    RUN_TEST(test_pushed_rod_in_the_world_moves_as_section_6_says);
    RUN_TEST(test_down_force_raises_the_push_as_eq_29_and_squeezes_past_psi_max);
    RUN_TEST(test_the_tip_rides_over_a_sliding_rod_below_eq_30s_load_and_pushes_it_above);
    return UNITY_END();
}
