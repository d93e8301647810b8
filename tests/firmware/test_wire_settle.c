/* test_wire_settle.c - a rod settling into a groove (fw_wire_settle): its
 * slide and turn onto the path, either way, its seat against the geometry
 * in double over widths, the groove it needs (half the rod over one wide
 * enough), and empty, null and far inputs. */
#include "unity.h"
#include "fw_wire.h"
#include "fw_math.h"
#include "test_util.h"
#include "trench_util.h"

void setUp(void) {}
void tearDown(void) {}

/* ---- a rod settles into a groove (fw_wire_settle) ------------------------ */

/* The seat in double: the axis at (R - h cos gamma) / sin gamma. */
static double ref_seat_pm(double r, double h, double gamma_deg)
{
    double g = gamma_deg * 3.14159265358979323846 / 180.0;
    return (r - h * cos(g)) / sin(g);
}

static void test_settle_a_tilted_offset_rod_slides_and_turns_onto_the_path(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    /* 40 nm off the path, turned by 2 deg: its ends 40 -/+ 22.7 nm off */
    w.y_pm = 40000;
    w.x_pm = 5000;
    w.psi = fw_math_bam_from_mdeg(2000);
    TEST_ASSERT_TRUE(fw_wire_settle(&w, &tip, p, n));
    TEST_ASSERT_INT32_WITHIN(500, 0, w.y_pm);                                  /* onto the path */
    TEST_ASSERT_INT32_WITHIN(24000, 0, (int32_t)w.psi);                        /* along it: within 2 mdeg */
    TEST_ASSERT_INT32_WITHIN(500, 5000, w.x_pm);                               /* not along the groove */
    TEST_ASSERT_INT32_WITHIN(50, (int32_t)ref_seat_pm(D_PM / 2, 120000, 20.0), w.axis_z_pm);
    TEST_ASSERT_TRUE(w.axis_z_pm < -150000);                                   /* below the surface */
    /* settled: a second call moves it by no more than its rounding */
    {
        int32_t y = w.y_pm;
        TEST_ASSERT_TRUE(fw_wire_settle(&w, &tip, p, n));
        TEST_ASSERT_INT32_WITHIN(2, y, w.y_pm);
    }
}

static void test_settle_turns_the_other_way_too(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    w.y_pm = -30000;
    w.psi = fw_math_bam_from_mdeg(-3000);
    TEST_ASSERT_TRUE(fw_wire_settle(&w, &tip, p, n));
    TEST_ASSERT_INT32_WITHIN(500, 0, w.y_pm);
    TEST_ASSERT_INT32_WITHIN(24000, 0, (int32_t)w.psi);
}

static void test_settle_seat_matches_double_over_widths(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t width, n;
    for (width = D_PM; width <= 600000; width += 25000) {
        n = straight_trench(p, 200, -1400000, 1400000, 0, width);
        rod_and_tip(&w, &tip);
        TEST_ASSERT_TRUE(fw_wire_settle(&w, &tip, p, n));
        TEST_ASSERT_INT32_WITHIN(50, (int32_t)ref_seat_pm(D_PM / 2, width / 2, 20.0), w.axis_z_pm);
    }
    /* as wide as the rod: it rests a little above the surface, R tan(gamma / 2) */
    n = straight_trench(p, 200, -1400000, 1400000, 0, D_PM);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_TRUE(fw_wire_settle(&w, &tip, p, n));
    TEST_ASSERT_INT32_WITHIN(50, (int32_t)(D_PM / 2 * tan(10.0 * 3.14159265358979323846 / 180.0)), w.axis_z_pm);
}

static void test_settle_needs_half_the_rod_over_a_groove_wide_enough(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n;
    /* narrower than the rod: nothing; the axis stays at d/2 */
    n = straight_trench(p, 200, -1400000, 1400000, 0, D_PM - 1);
    rod_and_tip(&w, &tip);
    w.y_pm = 10000;
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_INT32(10000, w.y_pm);
    TEST_ASSERT_EQUAL_INT32(D_PM / 2, w.axis_z_pm);
    /* across the groove (psi = 90 deg): one point of 17 over it */
    n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    w.psi = fw_math_bam_from_mdeg(90000);
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_INT32(D_PM / 2, w.axis_z_pm);
    /* the groove under end B's third (6 points of 17): it stays */
    n = straight_trench(p, 200, 220000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, n));
    /* settled, then pushed out of the groove's reach: d/2 again */
    n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_TRUE(fw_wire_settle(&w, &tip, p, n));
    TEST_ASSERT_TRUE(w.axis_z_pm < 0);
    w.y_pm = 200000;
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_INT32(D_PM / 2, w.axis_z_pm);
}

static void test_settle_empty_null_and_far_inputs(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_FALSE(fw_wire_settle(NULL, &tip, p, n));
    TEST_ASSERT_FALSE(fw_wire_settle(&w, NULL, p, n));
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, NULL, n));
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, 1));
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, -5));
    TEST_ASSERT_EQUAL_INT32(D_PM / 2, w.axis_z_pm);
    /* a rod at the far corner of int32 and a groove at the other: skipped, no overflow (UBSan build) */
    w.x_pm = INT32_MAX - L_PM;
    w.y_pm = INT32_MIN + 1;
    TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, n));
    /* every stroke one point long: no piece */
    {
        int32_t i;
        for (i = 0; i < n; i++) p[i].flags = FW_LITHO_STROKE_START;
        rod_and_tip(&w, &tip);
        TEST_ASSERT_FALSE(fw_wire_settle(&w, &tip, p, n));
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_settle_a_tilted_offset_rod_slides_and_turns_onto_the_path);
    RUN_TEST(test_settle_turns_the_other_way_too);
    RUN_TEST(test_settle_seat_matches_double_over_widths);
    RUN_TEST(test_settle_needs_half_the_rod_over_a_groove_wide_enough);
    RUN_TEST(test_settle_empty_null_and_far_inputs);
    return UNITY_END();
}
