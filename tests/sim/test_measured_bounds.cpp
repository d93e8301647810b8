// Unity tests of the measured substrate's own guard (sim_afm/world.hpp
// MeasuredSurface): a grid with a pitch that is not finite and positive, or
// values that do not fill it, is refused as an input error (read_gsf's
// kGsfRanges keep such a grid out; this holds for a grid made any other
// way); and no point, NaN or far outside, reads outside the map (a NaN cell
// index from XReal = 1e300 made height() read out of bounds: sim_afm 139).
#include <unity.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "world.hpp"

using afm::sim::MeasuredSurface;

namespace {

// 3 x 3 pixels over [0, 3] um in x and y; row 0 at the top; heights k nm, k = 0..8.
afm::GsfGrid grid()
{
    afm::GsfGrid g;
    g.xres = g.yres = 3;
    g.xreal_m = g.yreal_m = 3e-6;
    for (int k = 0; k < 9; ++k) g.values.push_back(static_cast<float>(k * 1e-9));
    return g;
}

bool refused(const afm::GsfGrid &g)
{
    try {
        MeasuredSurface m(g);
    } catch (const afm::InputError &) {
        return true;
    }
    return false;
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_a_grid_without_a_finite_positive_pitch_is_refused()
{
    TEST_ASSERT_FALSE(refused(grid()));
    const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
    for (const double bad : {1e300, inf, nan, 0.0, -1e-6}) {
        afm::GsfGrid g = grid();
        g.xreal_m = bad;
        TEST_ASSERT_TRUE(refused(g));
        g = grid();
        g.yoff_m = bad == 0.0 || bad == -1e-6 ? inf : bad;   // a corner that is not finite
        TEST_ASSERT_TRUE(refused(g));
    }
    afm::GsfGrid g = grid();
    g.values.pop_back();
    TEST_ASSERT_TRUE(refused(g));
    g = grid();
    g.xres = 1;
    TEST_ASSERT_TRUE(refused(g));
}

void test_no_point_reads_outside_the_map()
{
    const MeasuredSurface m(grid());
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    // the top-left pixel (height 0 nm) for NaN, the nearest edge far away
    TEST_ASSERT_EQUAL_DOUBLE(0.0, m.height({nan, nan}));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, m.height({-inf, inf}));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 8.0, m.height({1e300, -1e300}));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 4.0, m.height({1500, 1500}));   // the centre pixel
    for (const double x : {nan, -inf, inf, 1e300}) {
        const Eigen::Vector2d gr = m.gradient({x, 1500});
        TEST_ASSERT_TRUE(std::isfinite(gr.x()) && std::isfinite(gr.y()));
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_a_grid_without_a_finite_positive_pitch_is_refused);
    RUN_TEST(test_no_point_reads_outside_the_map);
    return UNITY_END();
}
