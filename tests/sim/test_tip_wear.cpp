// Unity tests of the tip's wear (sim_afm/tip_wear.hpp): the blunt tip's
// missing volume c(gamma) R^3 against the volume between two tips measured
// through tip_geometry's own exact surface (an independent route), Archard's
// law, wear only under a pressing load, additivity, and refusals.
#include <unity.h>

#include <cmath>
#include <cstring>

#include "process.hpp"
#include "tip_geometry.hpp"
#include "tip_wear.hpp"

namespace w = afm::sim::wear;
using afm::sim::TipGeometry;
using afm::sim::TipPose;
using Eigen::Vector3d;

namespace {

constexpr double kGamma = 20.0 * M_PI / 180;

// The height of an upright tip's surface at radius rho, its cone's virtual
// apex at the origin (so tips of any radius share the flank): bisection on
// the sign of tip_geometry's signed distance along the vertical, to 1e-12 nm.
double surface_z(double R, double rho)
{
    TipPose p;
    p.apex_nm = Vector3d(0, 0, R * (1 - std::sin(kGamma)) / std::sin(kGamma));
    const TipGeometry tip(R, kGamma, p);
    double lo = -1, hi = 1e4;   // below the tip / inside it
    for (int i = 0; i < 200 && hi - lo > 1e-12; ++i) {
        const double mid = 0.5 * (lo + hi);
        (tip.nearest(Vector3d(rho, 0, mid)).sd_nm < 0 ? hi : lo) = mid;
    }
    return 0.5 * (lo + hi);
}

}  // namespace

void setUp(void) {}
void tearDown(void) {}

// The volume between tips of radius 10 and 20 nm (Simpson over rho, 2,000
// intervals, of 2 pi rho (z_20 - z_10); the integrand's kink at the smaller
// tip's tangent circle costs O(h^2)): c (20^3 - 10^3) within 1e-4.
static void test_blunt_volume_against_the_geometry(void)
{
    const double R0 = 10, R1 = 20, top = R1 * std::cos(kGamma);
    const int n = 2000;
    double sum = 0;
    for (int i = 0; i <= n; ++i) {
        const double rho = top * i / n;
        const double f = 2 * M_PI * rho * (surface_z(R1, rho) - surface_z(R0, rho));
        sum += f * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
    }
    const double numeric = sum * top / n / 3;
    const double want = w::blunt_volume_nm3(R1, kGamma) - w::blunt_volume_nm3(R0, kGamma);
    char msg[120];
    std::snprintf(msg, sizeof msg, "closed form %.6f nm^3, geometry %.6f nm^3", want, numeric);
    TEST_ASSERT_TRUE_MESSAGE(std::abs(numeric / want - 1) < 1e-4, msg);
}

// Archard: V = k N s / H, and the radius from it.
static void test_archard(void)
{
    w::TipWear t(10, kGamma, {1e-4, 10});
    t.slide(10, 1e6);   // 10 nN over 1 mm
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 100.0, t.worn_nm3());
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, std::cbrt(1000 + 100 / w::blunt_coefficient(kGamma)), t.radius_nm());
    TEST_ASSERT_EQUAL_DOUBLE(1e6, t.slid_nm());
}

// Only a pressing load wears; the distance counts all the same.
static void test_no_load_no_wear(void)
{
    w::TipWear t(10, kGamma, {1e-3, 10});
    t.slide(0, 5e5);
    t.slide(-3, 5e5);
    TEST_ASSERT_EQUAL_DOUBLE(10.0, t.radius_nm());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, t.worn_nm3());
    TEST_ASSERT_EQUAL_DOUBLE(1e6, t.slid_nm());
}

// Sliding in steps wears as one slide (to rounding), and the radius grows.
static void test_steps_add(void)
{
    w::TipWear one(10, kGamma, {1e-3, 10}), many(10, kGamma, {1e-3, 10});
    one.slide(5, 1e6);
    double last = many.radius_nm();
    for (int i = 0; i < 1000; ++i) {
        many.slide(5, 1e3);
        TEST_ASSERT_TRUE(many.radius_nm() >= last);
        last = many.radius_nm();
    }
    TEST_ASSERT_DOUBLE_WITHIN(1e-9 * one.radius_nm(), one.radius_nm(), many.radius_nm());
    TEST_ASSERT_TRUE(one.radius_nm() > 10);
}

// A sharp tip (R0 = 0) blunts to (V / c)^(1/3).
static void test_sharp_tip_blunts(void)
{
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, std::cbrt(50 / w::blunt_coefficient(kGamma)), w::radius_after(0, kGamma, 50));
}

static void expect_refusal(void (*f)(), const char *names)
{
    try {
        f();
    } catch (const afm::InputError &e) {
        TEST_ASSERT_NOT_NULL_MESSAGE(std::strstr(e.what(), names), e.what());
        return;
    }
    TEST_FAIL_MESSAGE(names);
}

static void test_refusals(void)
{
    expect_refusal([] { w::TipWear(-1, kGamma, {}); }, "radius_nm");
    expect_refusal([] { w::TipWear(10, 0, {}); }, "half angle");
    expect_refusal([] { w::TipWear(10, kGamma, {2, 10}); }, "wear coefficient");
    expect_refusal([] { w::TipWear(10, kGamma, {1e-4, 0}); }, "hardness_GPa");
    expect_refusal([] { w::TipWear(10, kGamma, {}).slide(NAN, 1); }, "load_nN");
    expect_refusal([] { w::TipWear(10, kGamma, {}).slide(1, -1); }, "distance_nm");
    expect_refusal([] { w::radius_after(10, kGamma, -1); }, "worn_nm3");
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_blunt_volume_against_the_geometry);
    RUN_TEST(test_archard);
    RUN_TEST(test_no_load_no_wear);
    RUN_TEST(test_steps_add);
    RUN_TEST(test_sharp_tip_blunts);
    RUN_TEST(test_refusals);
    return UNITY_END();
}
