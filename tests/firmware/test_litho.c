/* test_litho.c - fw_litho: trenches above the load threshold, width from
 * the cone, fixed capacity. */
#include "unity.h"
#include "fw_litho.h"
#include "test_util.h"

#define CAP 4
static fw_trench_point_t pts[CAP];
static fw_litho_t l;

void setUp(void)
{
    /* threshold 20 nN, 0.5 pm/pN, gamma 20 deg, 10 nm spacing */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_init(&l, pts, CAP, 20000, FW_Q16_ONE / 2, 20000, 10000));
}
void tearDown(void) {}

static void test_litho_below_threshold_records_nothing(void)
{
    const int32_t tip[3] = { 0, 0, 0 };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 20000));
    TEST_ASSERT_EQUAL_INT32(0, l.count);
}

static void test_litho_width_is_2_depth_tan_gamma(void)
{
    const int32_t tip[3] = { 100, 200, 0 };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 60000));
    TEST_ASSERT_EQUAL_INT32(1, l.count);
    TEST_ASSERT_EQUAL_INT32(20000, pts[0].depth_pm);
    TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(2.0 * 20000.0 * tan(20.0 * TU_PI / 180.0)), pts[0].width_pm);
    TEST_ASSERT_EQUAL_UINT32(FW_LITHO_STROKE_START, pts[0].flags);
}

static void test_litho_spacing_strokes_and_capacity(void)
{
    int32_t tip[3] = { 0, 0, 0 };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 30000));
    tip[0] = 5000;                 /* zero-length-ish move: below the spacing */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 30000));
    TEST_ASSERT_EQUAL_INT32(1, l.count);
    tip[0] = 10000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 30000));
    TEST_ASSERT_EQUAL_INT32(2, l.count);
    TEST_ASSERT_EQUAL_UINT32(0u, pts[1].flags);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 0));   /* lift */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 30000));
    TEST_ASSERT_EQUAL_UINT32(FW_LITHO_STROKE_START, pts[2].flags);
    tip[1] = 20000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 30000));
    tip[1] = 40000;
    TEST_ASSERT_EQUAL_INT(FW_ERR_CAPACITY, fw_litho_step(&l, tip, 30000));
    TEST_ASSERT_TRUE(l.overflow);
    TEST_ASSERT_EQUAL_UINT32(1u, l.dropped);
    /* a full store counts dropped points, not samples: standing still drops none */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 30000));
    TEST_ASSERT_EQUAL_UINT32(1u, l.dropped);
    tip[1] = 50000;
    TEST_ASSERT_EQUAL_INT(FW_ERR_CAPACITY, fw_litho_step(&l, tip, 30000));
    TEST_ASSERT_EQUAL_UINT32(2u, l.dropped);
    fw_litho_shift(&l, -10, 10);
    TEST_ASSERT_EQUAL_INT32(-10, pts[0].x_pm);
    fw_litho_reset(&l);
    TEST_ASSERT_FALSE(l.overflow);
    TEST_ASSERT_EQUAL_INT32(0, l.count);
}

static void test_litho_depth_saturates_and_far_moves_do_not_overflow(void)
{
    fw_litho_t m;
    int32_t tip[3] = { INT32_MIN, INT32_MIN, 0 };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_init(&m, pts, CAP, 0, FW_Q16_MAX, 59999, 1));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&m, tip, INT32_MAX));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, pts[0].depth_pm);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, pts[0].width_pm);
    tip[0] = INT32_MAX;
    tip[1] = INT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&m, tip, INT32_MAX));
    TEST_ASSERT_EQUAL_INT32(2, m.count);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_litho_init(&m, pts, CAP, 0, 0, 60000, 1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_litho_init(&m, pts, 0, 0, 0, 20000, 1));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_litho_below_threshold_records_nothing);
    RUN_TEST(test_litho_width_is_2_depth_tan_gamma);
    RUN_TEST(test_litho_spacing_strokes_and_capacity);
    RUN_TEST(test_litho_depth_saturates_and_far_moves_do_not_overflow);
    return UNITY_END();
}
