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
#include <cstdio>
#include <string>
#include <vector>

#include "sim_scene.hpp"
#include "wire.hpp"
#include "world.hpp"

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

bool has(const std::vector<std::string> &v, const std::string &x)
{
    for (const auto &e : v)
        if (e == x) return true;
    return false;
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

void test_long_flexible_wire_bends_and_keeps_its_length()
{
    // lambda = 60 (6 um x 100 nm, friction 200 nN/um) pushed in its middle by
    // a tip that goes 160 nm past contact: the lever (1.6 nN/nm) cannot drag
    // much of it, so it bends locally: the middle moves a few nm (a beam on a
    // rigid-plastic bed: P = 2 f a + 24 EI delta / a^3 at its best a gives
    // delta of a few nm for the 250 nN the lever reaches), the ends not at
    // all, and every segment keeps its rest length to 1e-3 (stretch springs
    // EA / ds). The step solver (stick/slip active set, reweighted slip) gives
    // the same shape with 8 and 128 iterations per step (5%).
    const double L = 6000;
    double mids[2];
    int k = 0;
    for (int sweeps : {8, 128}) {
        const afm::Scene s = wire_scene(L, ", wire_flexibility", 200, 32, sweeps);
        World w(s);
        const double cn_off = w.lever().normal_offset(40).x();
        w.command(Eigen::Vector2d(-cn_off, -100), 40, true);
        for (int i = 0; i < 2000; ++i) w.step();
        w.command(Eigen::Vector2d(-cn_off, 100), 40, true);
        for (int i = 0; i < 8000; ++i) w.step();
        const auto &n = w.wires()[0]->nodes();
        const double mid = n[n.size() / 2].y(), ends = 0.5 * (n.front().y() + n.back().y());
        double worst = 0;
        for (std::size_t i = 0; i + 1 < n.size(); ++i) worst = std::max(worst, std::fabs((n[i + 1] - n[i]).norm() / (L / 32) - 1));
        std::printf("long wire (%d iterations): middle moved %.3f nm, ends %.3f nm, worst strain %.2e\n", sweeps, mid, ends, worst);
        TEST_ASSERT_TRUE(mid > 1.0 && mid < 40.0);   // moved, never ahead of the tip
        TEST_ASSERT_TRUE(mid - ends > 1.0);
        TEST_ASSERT_TRUE(worst < 1e-3);
        mids[k++] = mid;
    }
    TEST_ASSERT_DOUBLE_WITHIN(0.05 * mids[1], mids[1], mids[0]);
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
    RUN_TEST(test_scenes_build_only_the_wire_model_they_need);
    return UNITY_END();
}
