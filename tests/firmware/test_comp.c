/* test_comp.c - fw_comp: bending offset, apex estimate, joystick set point. */
#include "unity.h"
#include "fw_comp.h"
#include "fw_math.h"
#include "test_util.h"

static fw_comp_t c;
static const int32_t centre[2] = { 45000000, -2000000 };

void setUp(void)
{
    /* paper C_n 23.1 nm/V, C_l 23.1 nm/V, scan angle 270 (alpha 0),
     * 5 um scan (half range 2.5 um), kappa 1 */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&c, 23100, 23100, 0u, centre, 2500000, FW_Q16_ONE));
}
void tearDown(void) {}

static void test_comp_init_rejects_negative_constants(void)
{
    fw_comp_t d;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_comp_init(&d, -1, 0, 0u, centre, 0, 0));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_comp_init(&d, 0, 0, 0u, centre, -1, 0));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_comp_init(&d, 0, 0, 0u, centre, 0, -1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_comp_init(&d, 0, 0, 0u, NULL, 0, 0));
}

static void test_comp_offset_alpha_0_is_plus_cn_sn_plus_cl_sl(void)
{
    int32_t off[3];
    fw_comp_offset_pm(&c, FW_Q23_ONE, 2 * FW_Q23_ONE, off);
    TEST_ASSERT_EQUAL_INT32(23100, off[0]);
    TEST_ASSERT_EQUAL_INT32(46200, off[1]);
    TEST_ASSERT_EQUAL_INT32(0, off[2]);
}

static void test_comp_offset_alpha_90_rotates_into_frame_a(void)
{
    fw_comp_t d;
    int32_t off[3];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, 23100, 10000, FW_BAM_QUARTER_TURN, centre, 0, 0));
    /* C offset (23100, 10000) -> A (-10000, 23100) */
    fw_comp_offset_pm(&d, FW_Q23_ONE, FW_Q23_ONE, off);
    TEST_ASSERT_EQUAL_INT32(-10000, off[0]);
    TEST_ASSERT_EQUAL_INT32(23100, off[1]);
}

static void test_comp_target_full_deflection_reaches_half_range(void)
{
    q15_t joy[2] = { FW_Q15_MIN, FW_Q15_MAX };
    int32_t t[2];
    bool sat = false;
    fw_comp_target_pm(&c, joy, t, &sat);
    TEST_ASSERT_EQUAL_INT32(centre[0] - 2500000, t[0]);
    /* 32767/32768 of the half range */
    TEST_ASSERT_INT32_WITHIN(1, centre[1] + (int32_t)lround(2500000.0 * 32767.0 / 32768.0), t[1]);
    TEST_ASSERT_FALSE(sat);
}

static void test_comp_target_saturates_exactly_at_extremes(void)
{
    fw_comp_t d;
    const int32_t far_centre[2] = { INT32_MAX, INT32_MIN };
    q15_t joy[2] = { FW_Q15_MAX, FW_Q15_MIN };
    int32_t t[2];
    bool sat = false;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, FW_COMP_C_MAX_PM_PER_V, FW_COMP_C_MAX_PM_PER_V, 0u,
                                              far_centre, INT32_MAX, FW_Q16_MAX));
    fw_comp_target_pm(&d, joy, t, &sat);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, t[0]);
    TEST_ASSERT_EQUAL_INT32(INT32_MIN, t[1]);
    TEST_ASSERT_TRUE(sat);
}

/* C at the domain's edge: 2^22 pm/V accepted, one more refused with
 * FW_ERR_DOMAIN (either constant), instance untouched by the refusal. */
static void test_comp_init_refuses_c_beyond_the_domain(void)
{
    fw_comp_t d;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, FW_COMP_C_MAX_PM_PER_V, FW_COMP_C_MAX_PM_PER_V, 0u,
                                              centre, 0, 0));
    TEST_ASSERT_EQUAL_INT32(FW_COMP_C_MAX_PM_PER_V << FW_COMP_M_FRAC, d.m[0][0]);
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_comp_init(&d, FW_COMP_C_MAX_PM_PER_V + 1, 0, 0u, centre, 0, 0));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_comp_init(&d, 0, FW_COMP_C_MAX_PM_PER_V + 1, 0u, centre, 0, 0));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_comp_init(&d, INT32_MAX, INT32_MAX, 0u, centre, 0, 0));
    TEST_ASSERT_EQUAL_INT32(FW_COMP_C_MAX_PM_PER_V << FW_COMP_M_FRAC, d.m[0][0]);
}

/* The offset's extremes: C = 2^22 pm/V, alpha = 45 deg and 225 deg (the
 * largest |m_0| + |m_1|), S_n, S_l at the 9.23 format's MAXPOS / MAXNEG
 * (+-256 V): the offset stays in int32 (no clamp exists) and equals the
 * double model within the bound of the sweep below. Then an apex that
 * does leave int32 is saturated exactly, with *sat. */
static void test_comp_offset_extremes_stay_in_int32_and_apex_saturates(void)
{
    static const q23_t s_ext[2] = { FW_Q23_MAX, FW_Q23_MIN };
    static const int32_t mdeg[2] = { 45000, 225000 };
    int a;
    int i;
    int j;
    for (a = 0; a < 2; a++) {
        fw_comp_t d;
        double al = mdeg[a] * 1e-3 * 3.14159265358979323846 / 180.0;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, FW_COMP_C_MAX_PM_PER_V, FW_COMP_C_MAX_PM_PER_V,
                                                  fw_math_bam_from_mdeg(mdeg[a]), centre, 0, 0));
        for (i = 0; i < 2; i++) {
            for (j = 0; j < 2; j++) {
                int32_t off[3];
                double on = FW_COMP_C_MAX_PM_PER_V * tu_q(s_ext[i], 23);
                double ol = FW_COMP_C_MAX_PM_PER_V * tu_q(s_ext[j], 23);
                fw_comp_offset_pm(&d, s_ext[i], s_ext[j], off);
                TEST_ASSERT_DOUBLE_WITHIN(3.0, cos(al) * on - sin(al) * ol, (double)off[0]);
                TEST_ASSERT_DOUBLE_WITHIN(3.0, sin(al) * on + cos(al) * ol, (double)off[1]);
                TEST_ASSERT_TRUE(fabs((double)off[0]) > 1.4e9 || fabs((double)off[1]) > 1.4e9);
            }
        }
    }
    {
        fw_comp_t d;
        const int32_t piezo[3] = { INT32_MAX - 10, INT32_MIN + 10, 7 };
        int32_t apex[3];
        bool sat = false;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, 23100, 23100, 0u, centre, 0, 0));
        fw_comp_apex_pm(&d, piezo, FW_Q23_ONE, -FW_Q23_ONE, apex, &sat);
        TEST_ASSERT_EQUAL_INT32(INT32_MAX, apex[0]);
        TEST_ASSERT_EQUAL_INT32(INT32_MIN, apex[1]);
        TEST_ASSERT_EQUAL_INT32(7, apex[2]);
        TEST_ASSERT_TRUE(sat);
        sat = false;
        fw_comp_apex_pm(&d, piezo, -FW_Q23_ONE, FW_Q23_ONE, apex, &sat);
        TEST_ASSERT_EQUAL_INT32(INT32_MAX - 10 - 23100, apex[0]);
        TEST_ASSERT_EQUAL_INT32(INT32_MIN + 10 + 23100, apex[1]);
        TEST_ASSERT_FALSE(sat);
    }
}

/* The offset M S against the double model R(alpha) diag(C_n, C_l) S over
 * random C in [0, 2^22] pm/V, any alpha and S in two ranges: the fast
 * path's +-20 V and the whole 9.23 format (+-256 V). Error budget: the
 * final rounding 0.5 pm, M's entries rounded to 2^-9 pm/V (|S| 2^-8 for
 * the two, 0.08 pm at 20 V, 1 pm at 256 V), and cos, sin alpha to 2^-30
 * (C |S| 2^-29.5: 0.1 pm at 20 V, 1.4 pm at 256 V). */
static void test_comp_offset_sweep_matches_double(void)
{
    static const int32_t s_max[2] = { 20 * FW_Q23_ONE, INT32_MAX };
    static const double bound[2] = { 0.7, 3.0 };
    int r;
    for (r = 0; r < 2; r++) {
        tu_rng_t rng;
        tu_err_t e;
        long i;
        tu_rng_seed(&rng, 43u + (uint64_t)r);
        tu_err_init(&e, r == 0 ? "comp_offset_pm (|S| <= 20 V)" : "comp_offset_pm (|S| <= 256 V)", "pm", 1.0);
        for (i = 0; i < AFM_SWEEP_N; i++) {
            fw_comp_t d;
            int32_t cn = tu_rng_range(&rng, 0, FW_COMP_C_MAX_PM_PER_V);
            int32_t cl = tu_rng_range(&rng, 0, FW_COMP_C_MAX_PM_PER_V);
            fw_bam_t alpha = tu_rng_u32(&rng);
            q23_t sn = tu_rng_range(&rng, -s_max[r], s_max[r]);
            q23_t sl = tu_rng_range(&rng, -s_max[r], s_max[r]);
            double al = tu_bam_rad(alpha);
            int32_t off[3];
            (void)fw_comp_init(&d, cn, cl, alpha, centre, 0, 0);
            fw_comp_offset_pm(&d, sn, sl, off);
            tu_err_add(&e, off[0] - (cos(al) * cn * tu_q(sn, 23) - sin(al) * cl * tu_q(sl, 23)));
            tu_err_add(&e, off[1] - (sin(al) * cn * tu_q(sn, 23) + cos(al) * cl * tu_q(sl, 23)));
        }
        tu_err_print(&e);
        TEST_ASSERT_TRUE(e.worst <= bound[r]);
    }
}

static void test_comp_target_sweep_matches_double(void)
{
    tu_rng_t rng;
    tu_err_t e;
    long i;
    tu_rng_seed(&rng, 41);
    tu_err_init(&e, "comp_target_pm", "pm", 1.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        fw_comp_t d;
        int32_t ctr[2] = { tu_rng_range(&rng, -1000000000, 1000000000), 0 };
        int32_t hr = tu_rng_range(&rng, 0, 100000000);
        q16_t kappa = tu_rng_range(&rng, 0, 4 * FW_Q16_ONE);
        q15_t joy[2] = { (q15_t)tu_rng_range(&rng, -32768, 32767), 0 };
        int32_t t[2];
        bool sat = false;
        (void)fw_comp_init(&d, 0, 0, 0u, ctr, hr, kappa);
        fw_comp_target_pm(&d, joy, t, &sat);
        tu_err_add(&e, t[0] - (ctr[0] + (double)hr * tu_q(kappa, 16) * tu_q(joy[0], 15)));
    }
    tu_err_print(&e);
    TEST_ASSERT_TRUE(e.worst <= 0.5);
}

static void test_comp_piezo_cmd_puts_apex_on_target(void)
{
    fw_comp_t d;
    q15_t joy[2] = { 12345, -20000 };
    int32_t target[2];
    int32_t piezo[2];
    int32_t p3[3];
    int32_t apex[3];
    bool sat = false;
    q23_t sn = 3 * FW_Q23_ONE + 12345;
    q23_t sl = -FW_Q23_ONE / 3;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, 23100, 19250, fw_math_bam_from_mdeg(-37000), centre,
                                              2500000, 3 * FW_Q16_ONE / 2));
    fw_comp_target_pm(&d, joy, target, &sat);
    fw_comp_piezo_cmd_pm(&d, joy, sn, sl, piezo, &sat);
    p3[0] = piezo[0];
    p3[1] = piezo[1];
    p3[2] = 0;
    fw_comp_apex_pm(&d, p3, sn, sl, apex, &sat);
    TEST_ASSERT_EQUAL_INT32(target[0], apex[0]);
    TEST_ASSERT_EQUAL_INT32(target[1], apex[1]);
    TEST_ASSERT_FALSE(sat);
}

/* The fast domain's bound on C: fast set up to 2^21 pm/V and not above.
 * (fw_board_step's fast apex is compared with the checked one in
 * tests/firmware/test_board.c, C = 2^21 included.) */
static void test_comp_fast_flag_at_the_c_bound(void)
{
    fw_comp_t d;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, 1 << 21, 1 << 21, 0u, centre, 0, 0));
    TEST_ASSERT_TRUE(d.fast);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, (1 << 21) + 1, 0, 0u, centre, 0, 0));
    TEST_ASSERT_FALSE(d.fast);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_comp_init(&d, 0, (1 << 21) + 1, 0u, centre, 0, 0));
    TEST_ASSERT_FALSE(d.fast);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_comp_init_rejects_negative_constants);
    RUN_TEST(test_comp_offset_alpha_0_is_plus_cn_sn_plus_cl_sl);
    RUN_TEST(test_comp_offset_alpha_90_rotates_into_frame_a);
    RUN_TEST(test_comp_target_full_deflection_reaches_half_range);
    RUN_TEST(test_comp_target_saturates_exactly_at_extremes);
    RUN_TEST(test_comp_init_refuses_c_beyond_the_domain);
    RUN_TEST(test_comp_offset_extremes_stay_in_int32_and_apex_saturates);
    RUN_TEST(test_comp_offset_sweep_matches_double);
    RUN_TEST(test_comp_target_sweep_matches_double);
    RUN_TEST(test_comp_piezo_cmd_puts_apex_on_target);
    RUN_TEST(test_comp_fast_flag_at_the_c_bound);
    return UNITY_END();
}
