// Unity tests of the flexible wire (sim_afm/flexible_wire.cpp): a stiff one
// moves as the rigid rod, a long one bends locally and converges with N,
// its contact search, its Newton steps without friction and in the world,
// its banded solver (sim_afm/block_pentadiagonal.cpp) against a dense one
// and on a near-singular chain of 1024 segments, a zero-length segment
// refused, and a chain of 1024 segments solved to its stated residual.
#include <unity.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <initializer_list>
#include <vector>

#include "wire_fixtures.hpp"

using afm::sim::FlexibleWire;
using afm::sim::World;

namespace {

// The hard case: lambda = 60 (6 um x 100 nm, friction 200 nN/um) pushed by a
// tip that goes 160 nm past contact at x = x_push: the lever (1.6 nN/nm)
// cannot drag much of it, so it bends locally (a beam on a rigid-plastic bed:
// P = 2 f a + 24 EI delta / a^3 at its best a gives delta of a few nm). The
// shape: the axis's y at X = x - x_push, X in [-2500, 2500] nm, 1001 points.
struct LongPush {
    std::vector<double> y;
    double mid_nm, ends_nm, worst_strain;
    long unconverged;          // the wire's steps left out of balance
    long solver_unconverged;   // the world's samples left at the solver's cap (physics.md 5.1)
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
    r.solver_unconverged = w.solver().unconverged;
    return r;
}

double max_diff(const std::vector<double> &a, const std::vector<double> &b)
{
    double m = 0;
    for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
    return m;
}

// A chain's Newton system: bending kb w w^T on every triple, stretch ks e
// e^T along x, and per node a friction block c / s (I - m m^T) + c eps^2 /
// s^3 m m^T (a node sliding by s along m: stiff across its slip, next to
// nothing along it), random slip directions; shift added to the diagonal.
afm::sim::BlockPentadiagonal chain_system(int n, double kb, double ks, double c, double slip, unsigned seed)
{
    afm::sim::BlockPentadiagonal H;
    H.resize(n);
    std::srand(seed);
    const Eigen::Matrix2d I = Eigen::Matrix2d::Identity(), E = Eigen::Vector2d(1, 0) * Eigen::RowVector2d(1, 0);
    for (int i = 1; i + 1 < n; ++i) {
        H.diag[i - 1] += kb * I;
        H.diag[i] += 4 * kb * I;
        H.diag[i + 1] += kb * I;
        H.sub1[i] -= 2 * kb * I;
        H.sub1[i + 1] -= 2 * kb * I;
        H.sub2[i + 1] += kb * I;
    }
    for (int i = 0; i + 1 < n; ++i) {
        H.diag[i] += ks * E;
        H.diag[i + 1] += ks * E;
        H.sub1[i + 1] -= ks * E;
    }
    const double eps = 1e-6;
    for (int i = 0; i < n; ++i) {
        const double a = 2 * M_PI * std::rand() / RAND_MAX;
        const Eigen::Vector2d m(std::cos(a), std::sin(a));
        const double s = std::sqrt(slip * slip + eps * eps);
        H.diag[i] += c / s * (I - m * m.transpose()) + c * eps * eps / (s * s * s) * m * m.transpose();
    }
    return H;
}

// max_i |(H x - r)_i| / (max |H block| max |x_i| + max |r_i|): the backward error.
double backward_error(const afm::sim::BlockPentadiagonal &H, const std::vector<Eigen::Vector2d> &x,
                      const std::vector<Eigen::Vector2d> &r)
{
    const int n = H.size();
    double res = 0, hn = 0, xn = 0, rn = 0;
    for (int i = 0; i < n; ++i) {
        Eigen::Vector2d hx = H.diag[i] * x[i];
        if (i >= 1) hx += H.sub1[i] * x[i - 1];
        if (i >= 2) hx += H.sub2[i] * x[i - 2];
        if (i + 1 < n) hx += H.sub1[i + 1].transpose() * x[i + 1];
        if (i + 2 < n) hx += H.sub2[i + 2].transpose() * x[i + 2];
        res = std::max(res, (hx - r[i]).norm());
        hn = std::max({hn, H.diag[i].norm(), H.sub1[i].norm()});
        xn = std::max(xn, x[i].norm());
        rn = std::max(rn, r[i].norm());
    }
    return res / (hn * xn + rn);
}

}  // namespace

void setUp() {}
void tearDown() {}

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
    // monotonically, by at least 2x per doubling of N (observed: 0.47, 0.15,
    // 0.012 nm against a middle deflection of 5 nm) and the N = 128 shape is
    // within 0.1 nm (2 %) of N = 256. Every sample converges: an apex step
    // that entered the wire's contact without its stiffness threw the tip
    // 55 nm into the wire at N = 64, which then dragged it along (middle
    // 128 nm, every later sample at the cap).
    const LongPush ref = push_long(256, 0.0);
    TEST_ASSERT_EQUAL_INT(0, ref.solver_unconverged);
    double last = 1e300;
    for (int N : {32, 64, 128}) {
        const LongPush r = push_long(N, 0.0);
        const double e = max_diff(r.y, ref.y);
        std::printf("N = %3d: middle %.3f nm (N = 256: %.3f), max shape error %.4f nm, samples unconverged %ld\n", N, r.mid_nm,
                    ref.mid_nm, e, r.solver_unconverged);
        TEST_ASSERT_EQUAL_INT(0, r.solver_unconverged);
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

void test_contact_finds_the_closest_segment_like_the_brute_force()
{
    // The division-free search for the closest segment gives the distance
    // the brute force does (axis_distance), on a bent chain, for points all
    // around it, including on it and past its ends.
    afm::sim::FlexibleWire w(1, Eigen::Vector2d(-500, 0), Eigen::Vector2d(500, 0), 100, 0.02, 83, 16, 8);
    for (int i = 0; i < 400; ++i) w.push(Eigen::Vector2d(-120, -60 + 0.25 * i), 10, 20);   // bend it
    int n = 0;
    for (double X = -700; X <= 700; X += 7.3)
        for (double Y = -150; Y <= 250; Y += 6.1) {
            double pen, u;
            Eigen::Vector2d nrm;
            const Eigen::Vector2d q(X, Y);
            w.contact(q, 10, pen, nrm, u);
            TEST_ASSERT_DOUBLE_WITHIN(1e-9 * (1 + w.axis_distance(q)), w.axis_distance(q), 60 - pen);
            ++n;
        }
    TEST_ASSERT_TRUE(n > 10000);
    TEST_ASSERT_TRUE(w.nodes()[8].y() > 10);   // the chain was bent
}

void test_flexible_wire_without_friction_is_pushed_off_through_a_singular_system()
{
    // No friction: the chain's rigid motions cost nothing and its Hessian
    // is singular; the step is solved with a Levenberg shift. The tip 5 nm
    // inside its reach pushes it out of contact (any place out of contact
    // is a minimum: it must not be flung away either), it keeps its length,
    // and nothing is NaN. With friction, the same push (a translation of the
    // whole chain, so that turning about the contact costs next to nothing)
    // converges too.
    for (double f : {0.0, 0.02}) {
        afm::sim::FlexibleWire w(1, Eigen::Vector2d(-500, 0), Eigen::Vector2d(500, 0), 100, f, 83, 32, 64);
        const Eigen::Vector2d q(-200, -55);
        TEST_ASSERT_TRUE(w.push(q, 10, 20));
        double worst_strain = 0;
        for (std::size_t i = 0; i + 1 < w.nodes().size(); ++i) {
            TEST_ASSERT_TRUE(std::isfinite(w.nodes()[i].x()) && std::isfinite(w.nodes()[i].y()));
            worst_strain = std::max(worst_strain, std::fabs((w.nodes()[i + 1] - w.nodes()[i]).norm() / w.ds - 1));
        }
        std::printf("f = %.2f: distance to the apex %.6f nm (reach 60), worst strain %.1e, shifted solves %ld,"
                    " converged %d in %d iterations\n", f, w.axis_distance(q), worst_strain, w.regularised, w.last_converged,
                    w.last_iterations);
        TEST_ASSERT_TRUE(w.last_converged);
        TEST_ASSERT_TRUE(worst_strain < 1e-6);
        if (f == 0) {
            TEST_ASSERT_TRUE(w.regularised > 0);
            TEST_ASSERT_TRUE(w.axis_distance(q) >= 60.0 - 1e-6 && w.axis_distance(q) < 61.0);   // pushed off, not away
        }
    }
}

void test_flexible_wire_steps_stay_regular_and_converge_in_the_world()
{
    // The stiff wire's end push (test_stiff_flexible_wire_moves_like_the_rigid_rod's
    // scene): every Newton system is regular, and nearly every push
    // reaches the force tolerance within the iteration cap (the rest
    // resume on the next push).
    const afm::Scene s = wire_scene(1000, ", wire_flexibility", 20, 32, 8);
    World w(s);
    const double cn_off = w.lever().normal_offset(s.op.load_nN).x();
    w.command(Eigen::Vector2d(-500 - cn_off, -100), s.op.load_nN, true);
    for (int i = 0; i < 1000; ++i) w.step();
    long contact = 0;
    for (int i = 0; i < 3000; ++i) {
        w.command(Eigen::Vector2d(-500 - cn_off, -100 + 0.1 * i), s.op.load_nN, true);
        w.step();
        contact += w.wires()[0]->in_contact;
    }
    const auto &fw = dynamic_cast<const FlexibleWire &>(*w.wires()[0]);
    std::printf("end push: %ld samples in contact, %ld pushes unconverged, %ld shifted solves\n", contact, fw.unconverged,
                fw.regularised);
    TEST_ASSERT_TRUE(contact > 2000);
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(fw.regularised));
    TEST_ASSERT_TRUE(fw.unconverged < 0.05 * 4 * contact);   // 4 relax sweeps a sample, one push each
    // the world's account of its solver (sim_report.json's wire_solver) is the wire's own
    const World::WireSolver ws = w.wire_solver();
    TEST_ASSERT_EQUAL_INT(1, ws.flexible);
    TEST_ASSERT_TRUE(ws.solved >= contact);
    TEST_ASSERT_EQUAL_INT(static_cast<int>(fw.unconverged), static_cast<int>(ws.unconverged));
    TEST_ASSERT_EQUAL_INT(static_cast<int>(fw.regularised), static_cast<int>(ws.regularised));
    TEST_ASSERT_TRUE(ws.worst_iterations >= 1 && ws.worst_iterations <= ws.max_iterations);
    TEST_ASSERT_EQUAL_INT(8, ws.max_iterations);
    TEST_ASSERT_EQUAL_INT(0, World(wire_scene(1000)).wire_solver().flexible);   // a rigid rod: nothing counted
}

void test_banded_solver_is_backward_stable_on_sliding_chains()
{
    // Chains of 33 to 257 nodes whose every node slides (its friction block
    // holds it 1e9 times more across its slip than along it): the solve's
    // backward error stays at rounding (pivots kept with both off-diagonal
    // entries, as rounding leaves them, let the asymmetry grow along the
    // chain until it swamped the solve), and the solution agrees with
    // Eigen's dense LDL^T.
    for (int n : {33, 129, 257}) {
        const double ds = 5000.0 / (n - 1);
        const double kb = 4.07e8 / (ds * ds * ds), ks = 83 * M_PI * 1e4 / 4 / ds, c = 0.02 * ds;
        afm::sim::BlockPentadiagonal H = chain_system(n, kb, ks, c, 0.03, 7u + n);
        TEST_ASSERT_TRUE(H.factor(0.0));
        std::vector<Eigen::Vector2d> r(n), x;
        for (int i = 0; i < n; ++i) r[i] = Eigen::Vector2d(std::sin(0.7 * i), std::cos(1.3 * i));
        x = r;
        H.solve(x);
        const double be = backward_error(H, x, r);
        // Dense reference.
        Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2 * n, 2 * n);
        Eigen::VectorXd b(2 * n);
        for (int i = 0; i < n; ++i) {
            A.block<2, 2>(2 * i, 2 * i) = H.diag[i];
            if (i >= 1) {
                A.block<2, 2>(2 * i, 2 * i - 2) = H.sub1[i];
                A.block<2, 2>(2 * i - 2, 2 * i) = H.sub1[i].transpose();
            }
            if (i >= 2) {
                A.block<2, 2>(2 * i, 2 * i - 4) = H.sub2[i];
                A.block<2, 2>(2 * i - 4, 2 * i) = H.sub2[i].transpose();
            }
            b.segment<2>(2 * i) = r[i];
        }
        const Eigen::VectorXd xd = A.ldlt().solve(b);
        double diff = 0, size = 0;
        for (int i = 0; i < n; ++i) {
            diff = std::max(diff, (x[i] - xd.segment<2>(2 * i)).norm());
            size = std::max(size, x[i].norm());
        }
        std::printf("%d nodes: backward error %.1e, against dense LDL^T %.1e of the solution\n", n, be, diff / size);
        TEST_ASSERT_TRUE(be < 1e-14);
        TEST_ASSERT_TRUE(diff / size < 1e-6);
    }
}

void test_banded_solver_refuses_a_singular_system_and_solves_it_shifted()
{
    // Without friction a free chain's rigid motions (two translations, a
    // turn) cost nothing: H is singular, factor() says so; with a small
    // shift it factors, and the solution is finite and solves H + shift I.
    const int n = 33;
    afm::sim::BlockPentadiagonal H = chain_system(n, 6000, 16000, 0.0, 0.03, 3u);
    TEST_ASSERT_FALSE(H.factor(0.0));
    double biggest = 0;
    for (const auto &b : H.diag) biggest = std::max(biggest, b.trace());
    const double shift = 1e-9 * biggest;
    TEST_ASSERT_TRUE(H.factor(shift));
    std::vector<Eigen::Vector2d> r(n, Eigen::Vector2d(0, 1)), x = r;
    H.solve(x);
    for (auto &d : H.diag) d += shift * Eigen::Matrix2d::Identity();
    for (const auto &v : x) TEST_ASSERT_TRUE(std::isfinite(v.x()) && std::isfinite(v.y()));
    TEST_ASSERT_TRUE(backward_error(H, x, r) < 1e-12);
}

void test_long_chain_pushed_as_table_4_follows_the_tip()
{
    // bench_sim's table 4 case at N = 256 (a 5 um chain pushed at L/4):
    // with unsymmetric pivots its Newton steps went wrong and the tip pushed
    // through the wire. The apex must stay in contact, within its reach of
    // the axis.
    afm::Scene s = wire_scene(5000, ", wire_flexibility", 20, 256, 8);
    World w(s);
    double y = -120;
    w.command(Eigen::Vector2d(-1250, y), 5, true);
    for (int i = 0; i < 200; ++i) w.step();
    for (int i = 0; i < 2000; ++i) {
        y += 0.1;
        w.command(Eigen::Vector2d(-1250, y), 5, true);
        w.step();
    }
    const double d = w.wires()[0]->axis_distance(w.apex() - w.drift());
    std::printf("N = 256, 200 nm of push: apex %.2f nm from the axis (reach 60)\n", d);
    TEST_ASSERT_TRUE(d > 50 && d < 61);
}

void test_banded_solver_holds_on_a_near_singular_chain_of_1024_segments()
{
    // The hard case: 1025 nodes of a 5 um chain (N = 1024: kb = EI / ds^3
    // is 3.5e6 nN/nm, 1e8 times the friction blocks), whose nodes are held
    // by friction 1e-9 times as stiff as on a real substrate (the system is
    // singular to 1e-15 of its trace: the rigid motions nearly free). It
    // factors without a shift, and the solve's backward error stays at
    // rounding.
    const int n = 1025;
    const double ds = 5000.0 / (n - 1);
    const double kb = 4.07e8 / (ds * ds * ds), ks = 83 * M_PI * 1e4 / 4 / ds, c = 1e-9 * 0.02 * ds;
    afm::sim::BlockPentadiagonal H = chain_system(n, kb, ks, c, 0.03, 11u);
    TEST_ASSERT_TRUE(H.factor(0.0));
    std::vector<Eigen::Vector2d> r(n), x;
    for (int i = 0; i < n; ++i) r[i] = Eigen::Vector2d(std::sin(0.7 * i), std::cos(1.3 * i));
    x = r;
    H.solve(x);
    const double be = backward_error(H, x, r);
    std::printf("%d nodes, friction 1e-9: backward error %.1e\n", n, be);
    for (const auto &v : x) TEST_ASSERT_TRUE(std::isfinite(v.x()) && std::isfinite(v.y()));
    TEST_ASSERT_TRUE(be < 1e-13);
}

void test_flexible_wire_refuses_a_zero_length_segment()
{
    // A wire whose ends coincide (or with no segment) has segments of no
    // length: its stretch stiffness EA / ds and bending EI / ds^3 are not
    // numbers. The constructor refuses it, naming the wire and the value.
    const Eigen::Vector2d a(10, 20);
    for (int N : {32, 0}) {
        bool refused = false;
        try {
            FlexibleWire w(7, a, N == 0 ? Eigen::Vector2d(500, 20) : a, 100, 0.02, 83, N, 8);
        } catch (const std::invalid_argument &e) {
            refused = true;
            std::printf("refused: %s\n", e.what());
            TEST_ASSERT_NOT_NULL(std::strstr(e.what(), "wire 7"));
        }
        TEST_ASSERT_TRUE(refused);
    }
}

void test_chain_of_1024_segments_converges_at_its_stated_residual()
{
    // Table 4's 5 um chain at N = 1024 pushed 50 nm at L/4, about 30 nm of
    // it in contact (the apex first touches the wire near y = -22): kb = EI / ds^3
    // times the coordinates' rounding is past the step's tolerance (1e-5
    // c_i), so each step is solved in increments from its start
    // (flexible_wire.cpp, evaluate). Solved from the coordinates, 556 of
    // 560 steps of table 4's push ended short of it; in increments most
    // steps reach it (fewer than a quarter left at the Newton cap, to
    // resume), no world sample is left at the solver's cap, and the apex
    // stays on the wire.
    afm::Scene s = wire_scene(5000, ", wire_flexibility", 20, 1024, 8);
    World w(s);
    double y = -40;
    w.command(Eigen::Vector2d(-1250, y), 5, true);
    for (int i = 0; i < 1500; ++i) w.step();   // the scanner's 1 nm a sample from the scene's start, (0, -300)
    for (int i = 0; i < 500; ++i) {
        y += 0.1;
        w.command(Eigen::Vector2d(-1250, y), 5, true);
        w.step();
    }
    const auto &fw = dynamic_cast<const FlexibleWire &>(*w.wires()[0]);
    const double d = w.wires()[0]->axis_distance(w.apex() - w.drift());
    std::printf("N = 1024, 50 nm of push: %ld steps, %ld unconverged, world unconverged %ld, apex %.2f nm from the axis\n",
                fw.solved, fw.unconverged, w.solver().unconverged, d);
    TEST_ASSERT_TRUE(fw.solved > 200);
    TEST_ASSERT_TRUE(fw.unconverged < fw.solved / 4);
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(w.solver().unconverged));
    TEST_ASSERT_TRUE(d > 50 && d < 61);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_stiff_flexible_wire_moves_like_the_rigid_rod);
    RUN_TEST(test_long_flexible_wire_bends_and_keeps_its_length);
    RUN_TEST(test_long_flexible_wire_shape_converges_with_N);
    RUN_TEST(test_long_flexible_wire_shape_does_not_depend_on_the_node_under_the_tip);
    RUN_TEST(test_contact_finds_the_closest_segment_like_the_brute_force);
    RUN_TEST(test_flexible_wire_without_friction_is_pushed_off_through_a_singular_system);
    RUN_TEST(test_flexible_wire_steps_stay_regular_and_converge_in_the_world);
    RUN_TEST(test_banded_solver_is_backward_stable_on_sliding_chains);
    RUN_TEST(test_banded_solver_refuses_a_singular_system_and_solves_it_shifted);
    RUN_TEST(test_long_chain_pushed_as_table_4_follows_the_tip);
    RUN_TEST(test_banded_solver_holds_on_a_near_singular_chain_of_1024_segments);
    RUN_TEST(test_flexible_wire_refuses_a_zero_length_segment);
    RUN_TEST(test_chain_of_1024_segments_converges_at_its_stated_residual);
    return UNITY_END();
}
