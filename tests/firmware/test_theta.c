/* test_theta.c - fw_theta: the direction of motion from the apex window. */
#include <stdlib.h>
#include "unity.h"
#include "fw_theta.h"
#include "fw_math.h"
#include "test_util.h"

void setUp(void) {}
void tearDown(void) {}

static void test_theta_unknown_until_min_displacement_then_held(void)
{
    fw_theta_t t;
    uint32_t flags = 0;
    int32_t p[2] = { 0, 0 };
    int i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_theta_init(&t, 0));
    TEST_ASSERT_EQUAL_INT32(FW_THETA_MIN_DISP_DEFAULT_PM, t.min_disp_pm);
    /* zero-length moves: unknown, default 90 deg */
    for (i = 0; i < 20; i++) {
        flags = 0;
        fw_theta_step(&t, p, FW_Q30_ONE, 0, &flags);
    }
    TEST_ASSERT_TRUE((flags & FW_FLAG_THETA_UNKNOWN) != 0u);
    TEST_ASSERT_EQUAL_INT16(0, t.cos_theta);
    TEST_ASSERT_EQUAL_INT16(FW_Q15_MAX, t.sin_theta);
    /* move along -x in 100 pm steps: after 10 steps 1000 pm over the window */
    for (i = 1; i <= 10; i++) {
        p[0] = -100 * i;
        flags = 0;
        fw_theta_step(&t, p, FW_Q30_ONE, 0, &flags);
    }
    TEST_ASSERT_EQUAL_UINT32(0u, flags);
    TEST_ASSERT_EQUAL_INT16(-FW_Q15_MAX, t.cos_theta);
    TEST_ASSERT_EQUAL_INT16(0, t.sin_theta);
    /* stop: direction held after the window empties of motion */
    for (i = 0; i < 40; i++) {
        flags = 0;
        fw_theta_step(&t, p, FW_Q30_ONE, 0, &flags);
    }
    TEST_ASSERT_EQUAL_UINT32(0u, flags);
    TEST_ASSERT_EQUAL_INT16(-FW_Q15_MAX, t.cos_theta);
    fw_theta_reset(&t);
    TEST_ASSERT_FALSE(t.known);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_theta_init(&t, -1));
}

static void test_theta_rotates_frame_a_motion_into_frame_c(void)
{
    fw_theta_t t;
    uint32_t flags = 0;
    int32_t p[2] = { 0, 0 };
    fw_bam_t alpha = fw_math_bam_from_mdeg(90000);  /* scan angle 360 deg */
    q30_t ca = fw_math_cos_q30(alpha);
    q30_t sa = fw_math_sin_q30(alpha);
    int i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_theta_init(&t, 500));
    /* moving +y in A is moving +x in C when alpha = 90 deg */
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        p[1] = 1000 * i;
        fw_theta_step(&t, p, ca, sa, &flags);
    }
    TEST_ASSERT_EQUAL_INT16(FW_Q15_MAX, t.cos_theta);
    TEST_ASSERT_EQUAL_INT16(0, t.sin_theta);
    /* extreme coordinates: clamped displacement, still finite */
    p[0] = INT32_MIN;
    p[1] = INT32_MAX;
    fw_theta_step(&t, p, ca, sa, &flags);
    TEST_ASSERT_TRUE(t.known);
}

static void test_theta_push_direction_matches_rotated_displacement(void)
{
    /* dir = R(-alpha) d rounded to pm, or scaled down above 2^15 pm: the
     * angle error is at most 0.71 pm over min(|d|, 2^13) */
    tu_rng_t rng;
    tu_err_t e;
    long i;
    tu_rng_seed(&rng, 34);
    tu_err_init(&e, "theta_push_pm", "(rel. bound)", 1.0);
    for (i = 0; i < AFM_SWEEP_N / 10; i++) {
        fw_theta_t t;
        uint32_t flags = 0;
        fw_bam_t alpha = tu_rng_u32(&rng);
        q30_t ca;
        q30_t sa;
        int sh = (int)(tu_rng_u32(&rng) % 24u);
        int32_t p0[2] = { (int32_t)tu_rng_u32(&rng), (int32_t)tu_rng_u32(&rng) };
        int32_t p1[2] = { (int32_t)tu_rng_u32(&rng) >> sh, (int32_t)tu_rng_u32(&rng) >> sh };
        double dx;
        double dy;
        double a;
        double len;
        double err;
        p1[0] = (int32_t)((uint32_t)p0[0] + (uint32_t)p1[0]);
        p1[1] = (int32_t)((uint32_t)p0[1] + (uint32_t)p1[1]);
        fw_math_sincos_q30(alpha, &sa, &ca);
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_theta_init(&t, 1));
        TEST_ASSERT_FALSE(fw_theta_push_pm(&t, p0, ca, sa, &flags));
        TEST_ASSERT_TRUE((flags & FW_FLAG_THETA_UNKNOWN) != 0u);
        dx = (double)p1[0] - p0[0];
        dy = (double)p1[1] - p0[1];
        len = sqrt(dx * dx + dy * dy);
        flags = 0;
        TEST_ASSERT_EQUAL(len >= 1.0, fw_theta_push_pm(&t, p1, ca, sa, &flags));
        if (len < 1.0) {
            continue;
        }
        TEST_ASSERT_EQUAL_UINT32(0u, flags);
        TEST_ASSERT_TRUE(t.dir_x >= -FW_FORCE_DIR_MAX && t.dir_x <= FW_FORCE_DIR_MAX);
        TEST_ASSERT_TRUE(t.dir_y >= -FW_FORCE_DIR_MAX && t.dir_y <= FW_FORCE_DIR_MAX);
        a = tu_bam_rad(alpha);
        err = tu_wrap_pi(atan2((double)t.dir_y, (double)t.dir_x)
                         - atan2(-sin(a) * dx + cos(a) * dy, cos(a) * dx + sin(a) * dy));
        /* in units of the bound (plus 2 LSB of the 2.30 cos/sin) */
        tu_err_add(&e, err / (0.7072 / (len < 8192.0 ? len : 8192.0) + 4.0 / TU_TWO_POW(30)));
    }
    tu_err_print(&e);
    TEST_ASSERT_TRUE(e.worst <= 1.0);
}

static void test_theta_min_displacement_exact_and_zero_length_unknown(void)
{
    fw_theta_t t;
    uint32_t flags = 0;
    int32_t p[2] = { 5000, -7000 };
    int i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_theta_init(&t, 1000));
    /* zero-length displacement: unknown, default direction (0, 1) */
    for (i = 0; i < 20; i++) {
        flags = 0;
        TEST_ASSERT_FALSE(fw_theta_push_pm(&t, p, FW_Q30_ONE, 0, &flags));
    }
    TEST_ASSERT_EQUAL_UINT32(FW_FLAG_THETA_UNKNOWN, flags);
    TEST_ASSERT_EQUAL_INT32(0, t.dir_x);
    TEST_ASSERT_EQUAL_INT32(1, t.dir_y);
    /* |d| = (600, 799): 999.6 pm < 1000, then (600, 800): exactly 1000 pm */
    fw_theta_reset(&t);
    TEST_ASSERT_FALSE(fw_theta_push_pm(&t, p, FW_Q30_ONE, 0, &flags));
    p[0] += 600;
    p[1] += 799;
    flags = 0;
    TEST_ASSERT_FALSE(fw_theta_push_pm(&t, p, FW_Q30_ONE, 0, &flags));
    TEST_ASSERT_EQUAL_UINT32(FW_FLAG_THETA_UNKNOWN, flags);
    p[1] += 1;
    flags = 0;
    TEST_ASSERT_TRUE(fw_theta_push_pm(&t, p, FW_Q30_ONE, 0, &flags));
    TEST_ASSERT_EQUAL_UINT32(0u, flags);
    TEST_ASSERT_EQUAL_INT32(600, t.dir_x);
    TEST_ASSERT_EQUAL_INT32(800, t.dir_y);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_theta_unknown_until_min_displacement_then_held);
    RUN_TEST(test_theta_rotates_frame_a_motion_into_frame_c);
    RUN_TEST(test_theta_push_direction_matches_rotated_displacement);
    RUN_TEST(test_theta_min_displacement_exact_and_zero_length_unknown);
    return UNITY_END();
}
