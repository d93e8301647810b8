// Unity tests of the simulated nanowires (sim_afm/wire.*) against physics.md
// section 6, whose closed forms live here only: the simulator integrates the
// distributed friction and balances force and torque numerically.
//
// Closed forms (rod of length L from end A, friction density f, pushed
// perpendicular to its axis at distance l from A):
//   static point  s = l + sqrt((l - L/2)^2 + L^2/4)  for l < L/2   (eq. 20)
//                 s = l - sqrt((l - L/2)^2 + L^2/4)  for l > L/2
//   least push    F = f |L - 2 s| = f (2 sqrt((l - L/2)^2 + L^2/4) - |L - 2 l|)
//   F(0) = (sqrt2 - 1) f L = 0.414 f L; F(L/2) = f L, pure translation.
// (physics.md's printed eq. 22, f (2 sqrt(...) - L), drops the |L - 2 l| term:
// it is right only at the ends; at l = L/4 it gives 0.118 f L, against the
// 0.618 f L that both balances and the net friction |L - 2 s| f give.)
#include <unity.h>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "../scene_text.hpp"
#include "wire.hpp"
#include "world.hpp"

using afm::sim::FlexibleWire;
using afm::sim::RigidWire;
using afm::sim::RodTwist;
using afm::sim::World;

namespace {

double s_closed(double l, double L)
{
    const double r = std::sqrt((l - L / 2) * (l - L / 2) + L * L / 4);
    return l < L / 2 ? l + r : l - r;
}

double k_closed(double l, double L)   // F_min / (f L)
{
    return (2 * std::sqrt((l - L / 2) * (l - L / 2) + L * L / 4) - std::fabs(L - 2 * l)) / L;
}

const char *kWireScene = R"(name: wire-unit
seed: 5
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [bending_offset, adhesion EXTRA]
sample:
  substrate: glass
  field_nm: 8000
  tip_substrate: {mu: 0.1, adhesion_nN: 1.0}
  wire: {friction_nN_per_um: FRICTION, segments: SEGMENTS, friction_points: 64, relax_sweeps: SWEEPS}
objects:
  wires:
    - {id: 4, x0_nm: -HALF, y0_nm: 0, x1_nm: HALF, y1_nm: 0, diameter_nm: 100}
operator:
  load_nN: 5
  path_nm: [[0, -300]]
)";

afm::Scene wire_scene(double L, const std::string &extra = "", double friction = 20, int segments = 32, int sweeps = 8)
{
    std::string t = with(kWireScene, "SWEEPS", std::to_string(sweeps));
    t = with(t, "EXTRA", extra);
    t = with(t, "FRICTION", std::to_string(friction));
    t = with(t, "SEGMENTS", std::to_string(segments));
    t = with(t, "-HALF", std::to_string(-L / 2));
    t = with(t, "HALF", std::to_string(L / 2));
    return scene_from_text(t);
}

// Least-dissipation twist for a perpendicular push at l from end A, K points.
RodTwist solve(double l, double L, double f, int K)
{
    std::vector<double> u(K);
    for (int k = 0; k < K; ++k) u[k] = -L / 2 + (k + 0.5) * L / K;
    return afm::sim::rod_push_twist(u, f * L / K, l - L / 2, Eigen::Vector2d(0, 1), RodTwist{}, 1e-14, 5000);
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

// Pushes a 1 um rod lying along x with the tip moving along +y at x = l - L/2:
// returns the wire's rotation centre (from its motion) and the force the wire
// takes (lateral force on the tip less the tip's own friction) while sliding.
struct PushResult { double s_nm, force_nN, dpsi; };

PushResult push_world(double l, double L, const std::string &extra = "", int segments = 32, int sweeps = 8)
{
    const afm::Scene s = wire_scene(L, extra, 20, segments, sweeps);
    World w(s);
    const double cn_off = w.lever().normal_offset(s.op.load_nN).x();
    const double x = l - L / 2;
    // Quasi-static push: the scene's relaxation converges within a sample
    // (16 sweeps) and the piezo advances 0.05 nm per sample (1 um/s, an
    // operator's pace): the lag of the relaxation then costs < 0.5% of f L.
    w.set_relax_iterations(16);
    double y = -70;
    w.command(Eigen::Vector2d(x - cn_off, y), s.op.load_nN, true);
    for (int i = 0; i < 1000; ++i) w.step();
    auto axis_y = [&](double xq) {   // the axis's y at x = xq (small rotations)
        const auto &n = w.wires()[0]->nodes();
        const Eigen::Vector2d a = n.front(), b = n.back();
        return a.y() + (b.y() - a.y()) * (xq - a.x()) / (b.x() - a.x());
    };
    auto angle = [&]() {
        const auto &n = w.wires()[0]->nodes();
        return std::atan2(n.back().y() - n.front().y(), n.back().x() - n.front().x());
    };
    // Contact at y = -(r_t + d/2) = -60; the lever twists by about 12 nm
    // before the wire slides; samples 700 to 1300 see 30 nm of steady sliding.
    double fsum = 0;
    int nf = 0;
    double y0 = 0, psi0 = 0;
    for (int i = 0; i <= 1300; ++i) {
        y += 0.05;
        w.command(Eigen::Vector2d(x - cn_off, y), s.op.load_nN, true);
        w.step();
        if (i == 700) {
            y0 = axis_y(-L / 2);
            psi0 = angle();
        }
        if (i > 700) {
            fsum += w.tip_force().y();
            ++nf;
        }
    }
    const double friction = s.tip_substrate.mu * (s.op.load_nN + s.tip_substrate.adhesion_nN);
    const double dpsi = angle() - psi0;
    const double dyA = axis_y(-L / 2) - y0;
    // Normal displacement at distance s from end A: dyA + dpsi s; zero at s = -dyA / dpsi.
    return PushResult{std::fabs(dpsi) > 1e-12 ? -dyA / dpsi : INFINITY, -fsum / nf - friction, dpsi};
}

void test_pushed_rod_in_the_world_moves_as_section_6_says()
{
    // The whole chain (scanner, compliant lever, penalty contact, K = 64
    // friction points, quasi-static relaxation): force within 2% of f L
    // (measured 0.5%) and rotation centre within 2% of L (measured 0.8%; 1/K
    // quantisation plus the finite rotation over the 30 nm window), at l = 0,
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

void test_stiff_flexible_wire_moves_like_the_rigid_rod()
{
    // lambda = 10 silver wire as a 32-segment chain: it hardly bends, so an end
    // push needs the rigid rod's 0.414 f L (2%) and turns it about 0.707 L
    // (within 1/N = 3% plus 1%: the friction sits on the nodes, so the
    // rotation centre falls on one; measured 0.4163 and 0.7205).
    const double L = 1000, fL = 20.0 * L / 1000;
    const PushResult r = push_world(0.0, L, ", wire_flexibility", 32);
    std::printf("flexible (N = 32) end push: F = %.4f f L, s = %.4f L\n", r.force_nN / fL, r.s_nm / L);
    TEST_ASSERT_DOUBLE_WITHIN(0.02, std::sqrt(2.0) - 1, r.force_nN / fL);
    TEST_ASSERT_DOUBLE_WITHIN(1.0 / 32 + 0.01, 1 / std::sqrt(2.0), r.s_nm / L);
}

// The hard case: lambda = 60 (6 um x 100 nm, friction 200 nN/um) pushed by a
// tip that goes 160 nm past contact at x = x_push: the lever (1.6 nN/nm)
// cannot drag much of it, so it bends locally (a beam on a rigid-plastic bed:
// P = 2 f a + 24 EI delta / a^3 at its best a gives delta of a few nm). The
// shape: the axis's y at X = x - x_push, X in [-2500, 2500] nm, 1001 points.
struct LongPush {
    std::vector<double> y;
    double mid_nm, ends_nm, worst_strain;
    long unconverged;
};

LongPush push_long(int segments, double x_push, int sweeps = 8)
{
    const double L = 6000;
    const afm::Scene s = wire_scene(L, ", wire_flexibility", 200, segments, sweeps);
    World w(s);
    const double cn_off = w.lever().normal_offset(40).x();
    w.command(Eigen::Vector2d(x_push - cn_off, -100), 40, true);
    for (int i = 0; i < 2000; ++i) w.step();
    w.command(Eigen::Vector2d(x_push - cn_off, 100), 40, true);
    for (int i = 0; i < 8000; ++i) w.step();
    const auto &n = w.wires()[0]->nodes();
    LongPush r;
    for (int j = 0; j <= 1000; ++j) {
        const double X = x_push - 2500 + 5.0 * j;
        std::size_t k = 0;
        while (k + 2 < n.size() && n[k + 1].x() < X) ++k;
        const double t = (X - n[k].x()) / (n[k + 1].x() - n[k].x());
        r.y.push_back(n[k].y() + t * (n[k + 1].y() - n[k].y()));
    }
    r.mid_nm = r.y[500];
    r.ends_nm = 0.5 * (n.front().y() + n.back().y());
    r.worst_strain = 0;
    for (std::size_t i = 0; i + 1 < n.size(); ++i)
        r.worst_strain = std::max(r.worst_strain, std::fabs((n[i + 1] - n[i]).norm() / (L / segments) - 1));
    r.unconverged = dynamic_cast<const FlexibleWire &>(*w.wires()[0]).unconverged;
    return r;
}

double max_diff(const std::vector<double> &a, const std::vector<double> &b)
{
    double m = 0;
    for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
    return m;
}

void test_long_flexible_wire_bends_and_keeps_its_length()
{
    // N = 32: the middle moves a few nm, the ends not at all, and every
    // segment keeps its rest length to 1e-3 (stretch springs EA / ds). The
    // step solve has a convergence test (force residual 1e-5 c_i), so the
    // iteration cap only bounds the work: 8 and 128 give the same shape
    // (0.01 nm).
    const LongPush a = push_long(32, 0.0, 8), b = push_long(32, 0.0, 128);
    std::printf("long wire (N = 32): middle moved %.3f nm (cap 8) / %.3f nm (cap 128), ends %.3f nm, worst strain %.2e,"
                " unconverged pushes %ld / %ld\n", a.mid_nm, b.mid_nm, a.ends_nm, a.worst_strain, a.unconverged, b.unconverged);
    TEST_ASSERT_TRUE(a.mid_nm > 1.0 && a.mid_nm < 40.0);   // moved, never ahead of the tip
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, a.ends_nm);
    TEST_ASSERT_TRUE(a.worst_strain < 1e-3);
    TEST_ASSERT_DOUBLE_WITHIN(0.01, 0.0, max_diff(a.y, b.y));
}

void test_long_flexible_wire_shape_converges_with_N()
{
    // The hard case at N = 32, 64, 128 against N = 256, the tip on a node (x =
    // 0). The tip's force goes to the one point of the axis closest to it
    // (shared by that segment's two nodes), so the load does not grow with
    // the number of segments the apex overlaps. Errors decrease
    // monotonically, by at least 2x per doubling of N (observed order about 2:
    // 0.6, 0.1, 0.03 nm against a middle deflection of 4 nm) and the N = 128
    // shape is within 0.1 nm (2.5%) of N = 256.
    const LongPush ref = push_long(256, 0.0);
    double last = 1e300;
    for (int N : {32, 64, 128}) {
        const LongPush r = push_long(N, 0.0);
        const double e = max_diff(r.y, ref.y);
        std::printf("N = %3d: middle %.3f nm (N = 256: %.3f), max shape error %.4f nm\n", N, r.mid_nm, ref.mid_nm, e);
        TEST_ASSERT_TRUE(e < 0.5 * last);
        last = e;
    }
    TEST_ASSERT_DOUBLE_WITHIN(0.1, 0.0, last);
}

void test_long_flexible_wire_shape_does_not_depend_on_the_node_under_the_tip()
{
    // N = 64 (ds = 94 nm): the tip landing on a node (x = 0) and mid-segment
    // (x = ds / 2) give the same shape about the tip within 0.25 nm (6% of
    // the 4 nm deflection; the discretisation error at N = 64 is 0.1 nm).
    // Before the fix (every overlapped segment took the full contact force)
    // they gave 29.5 and 4.1 nm.
    const double ds = 6000.0 / 64;
    const LongPush on = push_long(64, 0.0), mid = push_long(64, 0.5 * ds);
    const double e = max_diff(on.y, mid.y);
    std::printf("N = 64: tip on a node: middle %.3f nm; mid-segment: %.3f nm; max shape difference %.4f nm\n", on.mid_nm,
                mid.mid_nm, e);
    TEST_ASSERT_DOUBLE_WITHIN(0.25, 0.0, e);
}

void test_scenes_build_only_the_wire_model_they_need()
{
    // No wire in the scene: no wire model, even with wire_flexibility listed.
    std::string text = with(with(with(with(kWireScene, "SWEEPS", "8"), "EXTRA", ", wire_flexibility"), "FRICTION", "20"), "SEGMENTS", "32");
    text = with(text, "objects:\n  wires:\n    - {id: 4, x0_nm: -HALF, y0_nm: 0, x1_nm: HALF, y1_nm: 0, diameter_nm: 100}\n", "");
    const afm::Scene none = scene_from_text(text);
    World a(none);
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(a.wires().size()));
    for (const auto &m : a.models_built()) TEST_ASSERT_TRUE_MESSAGE(m.find("wires") == std::string::npos, m.c_str());
    // Wires without wire_flexibility: rigid rods; with it: chains.
    World b(wire_scene(1000));
    TEST_ASSERT_TRUE(has(b.models_built(), "wires:rigid_rod"));
    World c(wire_scene(1000, ", wire_flexibility"));
    TEST_ASSERT_TRUE(has(c.models_built(), "wires:flexible_chain"));
    TEST_ASSERT_EQUAL_INT(33, static_cast<int>(c.wires()[0]->nodes().size()));
}

void test_down_force_raises_the_push_as_eq_29_and_squeezes_past_psi_max()
{
    // down_force: the cone (gamma 20 deg, the default; wire mu 0.3) presses
    // the rod by H tan psi. At the middle (k = 1) the push that moves it is
    // f L / (1 - mu tan psi), psi = gamma + theta_t (eq. 29's horizontal part).
    const double L = 1000, fL = 20.0 * L / 1000;
    const afm::Scene sc = wire_scene(L, ", down_force");
    const PushResult m = push_world(L / 2, L, ", down_force");
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

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_rod_static_point_and_least_push_match_section_6);
    RUN_TEST(test_rod_end_push_is_sqrt2_minus_1_not_2_minus_sqrt2);
    RUN_TEST(test_rod_middle_push_translates_at_f_L);
    RUN_TEST(test_rod_default_64_points_within_half_a_percent);
    RUN_TEST(test_rod_twist_balances_force_and_torque);
    RUN_TEST(test_pushed_rod_in_the_world_moves_as_section_6_says);
    RUN_TEST(test_stiff_flexible_wire_moves_like_the_rigid_rod);
    RUN_TEST(test_long_flexible_wire_bends_and_keeps_its_length);
    RUN_TEST(test_long_flexible_wire_shape_converges_with_N);
    RUN_TEST(test_long_flexible_wire_shape_does_not_depend_on_the_node_under_the_tip);
    RUN_TEST(test_scenes_build_only_the_wire_model_they_need);
    RUN_TEST(test_down_force_raises_the_push_as_eq_29_and_squeezes_past_psi_max);
    return UNITY_END();
}
