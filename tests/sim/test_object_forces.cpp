// Unity tests of the forces between objects (sim_afm/object_forces.hpp):
// Hamaker's sphere-sphere force against its own energy's derivative and its
// two limits (Derjaguin near contact, London far apart), the sphere-rod
// Derjaguin force against the sphere-plane limit, Coulomb against the point
// and infinite-line laws and a brute-force sum, the cut-off, Newton's third
// law, and refusals. Each tolerance is stated with its reason.
#include <unity.h>

#include <cmath>
#include <cstring>
#include <string>

#include "object_forces.hpp"
#include "process.hpp"

namespace of = afm::sim::objforce;
using Eigen::Vector3d;

namespace {

constexpr double kA = 0.1;   // 1e-19 J in aJ: the lab level

of::Body sphere(const Vector3d &c, double r, double q = 0)
{
    of::Body b;
    b.kind = of::Body::Kind::sphere;
    b.a_nm = b.b_nm = c;
    b.radius_nm = r;
    b.charge_e = q;
    return b;
}

of::Body rod(const Vector3d &a, const Vector3d &b, double r, double q = 0)
{
    of::Body o;
    o.kind = of::Body::Kind::rod;
    o.a_nm = a;
    o.b_nm = b;
    o.radius_nm = r;
    o.charge_e = q;
    return o;
}

void assert_rel(double want, double got, double rel, const char *what)
{
    char msg[200];
    std::snprintf(msg, sizeof msg, "%s: want %.9g got %.9g (rel %.3g > %.3g)", what, want, got, std::abs(got / want - 1), rel);
    TEST_ASSERT_TRUE_MESSAGE(std::abs(got / want - 1) <= rel, msg);
}

}  // namespace

void setUp(void) {}
void tearDown(void) {}

// The force is -dU/dr of Hamaker's energy: central differences, h = 1e-4
// nm, agree to 1e-6 (the difference's own error is about h^2 U''' / 6).
static void test_force_is_the_energys_derivative(void)
{
    const double R1 = 50, R2 = 30;
    for (const double D : {0.3, 1.0, 5.0, 40.0, 300.0}) {
        const double r = R1 + R2 + D, h = 1e-4;
        const double numeric = -(of::vdw_sphere_sphere_energy(kA, R1, R2, r + h) - of::vdw_sphere_sphere_energy(kA, R1, R2, r - h)) / (2 * h);
        assert_rel(numeric, of::vdw_sphere_sphere_force(kA, R1, R2, r), 1e-6, "dU/dr");
    }
}

// Near contact Derjaguin's -A R1 R2 / (6 (R1 + R2) D^2): at D = 0.2 nm on
// 50 nm spheres the exact force differs by O(D / R) = 0.4 %: within 1 %.
static void test_near_contact_is_derjaguin(void)
{
    const double R = 50, D = 0.2;
    const double want = -kA * R * R / (6 * (2 * R) * D * D);
    assert_rel(want, of::vdw_sphere_sphere_force(kA, R, R, 2 * R + D), 0.01, "Derjaguin");
}

// Far apart London's -16 A R1^3 R2^3 / (9 r^6): at r = 20 R the next term
// is O((R / r)^2) = 0.25 % of it times a small factor: within 2 %.
static void test_far_apart_is_london(void)
{
    const double R1 = 50, R2 = 20, r = 20 * R1;
    const double want = -16 * kA * std::pow(R1, 3) * std::pow(R2, 3) / (9 * std::pow(r, 6));
    assert_rel(want, of::vdw_sphere_sphere_energy(kA, R1, R2, r), 0.02, "London");
}

// Below the cut-off the force is held at D0 (finite at overlap, never NaN).
static void test_cutoff_holds_the_force(void)
{
    const double R = 50, at_d0 = of::vdw_sphere_sphere_force(kA, R, R, 2 * R + of::kContactCutoffNm);
    TEST_ASSERT_EQUAL_DOUBLE(at_d0, of::vdw_sphere_sphere_force(kA, R, R, 2 * R + 0.01));
    TEST_ASSERT_EQUAL_DOUBLE(at_d0, of::vdw_sphere_sphere_force(kA, R, R, 2 * R - 5));
    TEST_ASSERT_TRUE(std::isfinite(at_d0) && at_d0 < 0);
}

// Two spheres attract along their line of centres, each with the other's
// force reversed (Newton's third law, exactly).
static void test_spheres_attract_along_centres(void)
{
    of::Settings s;
    s.hamaker_aJ = kA;
    const of::Body a = sphere({0, 0, 50}, 50), b = sphere({80, 80, 50}, 50);
    const of::PairForce ab = of::between(a, b, s), ba = of::between(b, a, s);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, std::sqrt(2.0) * 80 - 100, ab.gap_nm);
    TEST_ASSERT_TRUE(ab.on_second_nN.x() < 0 && ab.on_second_nN.y() < 0);   // b pulled towards a
    TEST_ASSERT_DOUBLE_WITHIN(1e-15, ab.on_second_nN.x(), ab.on_second_nN.y());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, (ab.on_second_nN + ba.on_second_nN).norm());
}

// A sphere near a rod of huge radius: the sphere-plane limit -A R / (6 D^2)
// within 1e-5 (the rod's curvature 1/Rc = 1e-7 of the sphere's); towards the axis.
static void test_sphere_rod_tends_to_the_plane(void)
{
    of::Settings s;
    s.hamaker_aJ = kA;
    const double R = 50, Rc = 5e8, D = 2;
    const of::Body r = rod({-1e4, 0, -Rc}, {1e4, 0, -Rc}, Rc), p = sphere({0, 0, R + D}, R);
    const of::PairForce f = of::between(r, p, s);
    assert_rel(-kA * R / (6 * D * D), f.on_second_nN.z(), 1e-5, "sphere-plane");
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, f.on_second_nN.head<2>().norm());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, (f.on_second_nN + of::between(p, r, s).on_second_nN).norm());   // the rod feels the reverse
}

// Beyond range_nm no van der Waals force.
static void test_beyond_range_no_force(void)
{
    of::Settings s;
    s.hamaker_aJ = kA;
    s.range_nm = 10;
    TEST_ASSERT_EQUAL_DOUBLE(0.0, of::between(sphere({0, 0, 0}, 50), sphere({111, 0, 0}, 50), s).on_second_nN.norm());
    TEST_ASSERT_TRUE(of::between(sphere({0, 0, 0}, 50), sphere({109, 0, 0}, 50), s).on_second_nN.norm() > 0);
}

// Coulomb between spheres: k q1 q2 / (eps_r r^2), exactly; signs; eps_r.
static void test_coulomb_spheres(void)
{
    of::Settings s;
    s.eps_r = 2;
    const double r = 300;
    const of::PairForce like = of::between(sphere({0, 0, 0}, 50, 100), sphere({r, 0, 0}, 50, 50), s);
    assert_rel(of::kCoulomb_nN_nm2 * 100 * 50 / (2 * r * r), like.on_second_nN.x(), 1e-14, "like charges");
    const of::PairForce unlike = of::between(sphere({0, 0, 0}, 50, 100), sphere({r, 0, 0}, 50, -50), s);
    TEST_ASSERT_EQUAL_DOUBLE(-like.on_second_nN.x(), unlike.on_second_nN.x());
}

// A rod's line charge: far from a short rod the point law (0.1 % at r = 50 L:
// the quadrupole's (L / r)^2 / 4 is 1e-4); beside a long rod's middle the
// infinite line's 2 k lambda q / rho (within its ends' rho / (L/2) ... 0.1 %).
static void test_coulomb_rod_limits(void)
{
    of::Settings s;
    const double L = 100, q = 1000;
    const of::Body short_rod = rod({-L / 2, 0, 0}, {L / 2, 0, 0}, 5, q);
    const double r = 50 * L;
    assert_rel(of::kCoulomb_nN_nm2 * q * 10 / (r * r), of::between(short_rod, sphere({0, r, 0}, 5, 10), s).on_second_nN.y(), 1e-3, "point law");
    const double Ll = 1e5, rho = 20;
    const of::Body long_rod = rod({-Ll / 2, 0, 0}, {Ll / 2, 0, 0}, 5, q);
    assert_rel(2 * of::kCoulomb_nN_nm2 * (q / Ll) * 10 / rho, of::between(long_rod, sphere({0, rho, 0}, 5, 10), s).on_second_nN.y(), 1e-3, "line law");
}

// Two charged rods against a brute-force sum of 2000 x 2000 point charges
// (the sum's own error, of the midpoint rule, is O((L / 2000 / d)^2) ~ 3e-6):
// within 0.1 %, the 16-point quadrature's bound at a gap of half a length.
static void test_coulomb_rods_brute_force(void)
{
    of::Settings s;
    const of::Body a = rod({0, 0, 0}, {400, 0, 0}, 10, 300), b = rod({100, 200, 0}, {300, 350, 0}, 10, -200);
    const int n = 2000;
    Vector3d want = Vector3d::Zero();
    for (int i = 0; i < n; ++i) {
        const Vector3d pa = a.a_nm + (i + 0.5) / n * (a.b_nm - a.a_nm);
        for (int j = 0; j < n; ++j) {
            const Vector3d pb = b.a_nm + (j + 0.5) / n * (b.b_nm - b.a_nm);
            const Vector3d d = pb - pa;
            want += of::kCoulomb_nN_nm2 * (300.0 / n) * (-200.0 / n) * d / std::pow(d.norm(), 3);
        }
    }
    const Vector3d got = of::between(a, b, s).on_second_nN;
    char msg[160];
    std::snprintf(msg, sizeof msg, "want (%.6g, %.6g) got (%.6g, %.6g)", want.x(), want.y(), got.x(), got.y());
    TEST_ASSERT_TRUE_MESSAGE((got - want).norm() <= 1e-3 * want.norm(), msg);
}

// Two rods' gap is their axes' least distance less the radii, exact for
// skew rods whose closest points lie inside both (here 10 nm apart in z,
// crossing in plan at x = 65; a point of the second's middle projected once
// gives 10.95) and for rods whose closest points are their ends.
static void test_rod_rod_gap(void)
{
    of::Settings s;
    const of::Body a = rod({0, 0, 0}, {100, 0, 0}, 2);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 10.0 - 4, of::between(a, rod({40, -50, 10}, {100, 70, 10}, 2), s).gap_nm);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, std::sqrt(100.0 * 100 + 50 * 50 + 30 * 30) - 4,
                              of::between(a, rod({200, 50, 30}, {300, 150, 30}, 2), s).gap_nm);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 7.0 - 4, of::between(a, rod({20, 7, 0}, {80, 7, 0}, 2), s).gap_nm);   // parallel
}

// Coincident centres: no direction, no force, no NaN.
static void test_coincident_bodies(void)
{
    of::Settings s;
    s.hamaker_aJ = kA;
    const of::PairForce f = of::between(sphere({1, 2, 3}, 50, 10), sphere({1, 2, 3}, 20, 10), s);
    TEST_ASSERT_TRUE(f.on_second_nN.allFinite());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, f.on_second_nN.norm());
}

static void expect_refusal(const of::Body &a, const of::Body &b, const of::Settings &s, const char *names)
{
    try {
        of::between(a, b, s);
    } catch (const afm::InputError &e) {
        TEST_ASSERT_NOT_NULL_MESSAGE(std::strstr(e.what(), names), e.what());
        return;
    }
    TEST_FAIL_MESSAGE(names);
}

static void test_refusals(void)
{
    of::Settings s;
    const of::Body ok = sphere({0, 0, 0}, 50);
    expect_refusal(sphere({0, 0, 0}, -1), ok, s, "first.radius_nm");
    expect_refusal(ok, sphere({NAN, 0, 0}, 5), s, "second.position_nm");
    expect_refusal(ok, sphere({100, 0, 0}, 5, 2e9), s, "second.charge_e");
    s.hamaker_aJ = 1e3;
    expect_refusal(ok, ok, s, "hamaker_aJ");
    s.hamaker_aJ = kA;
    expect_refusal(rod({0, 0, 0}, {10, 0, 0}, 5), rod({0, 20, 0}, {10, 20, 0}, 5), s, "between two rods");
    s.eps_r = 0.5;
    expect_refusal(ok, ok, s, "eps_r");
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_force_is_the_energys_derivative);
    RUN_TEST(test_near_contact_is_derjaguin);
    RUN_TEST(test_far_apart_is_london);
    RUN_TEST(test_cutoff_holds_the_force);
    RUN_TEST(test_spheres_attract_along_centres);
    RUN_TEST(test_sphere_rod_tends_to_the_plane);
    RUN_TEST(test_beyond_range_no_force);
    RUN_TEST(test_coulomb_spheres);
    RUN_TEST(test_coulomb_rod_limits);
    RUN_TEST(test_coulomb_rods_brute_force);
    RUN_TEST(test_rod_rod_gap);
    RUN_TEST(test_coincident_bodies);
    RUN_TEST(test_refusals);
    return UNITY_END();
}
