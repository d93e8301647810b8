/* test_kalman.c - fw_kalman: the drift's constant-velocity Kalman filter
 * against a double-precision reference, and its hard cases (the first
 * registration, a huge innovation, zero and near-zero variances, long gaps,
 * a negative variance refused); what it costs on the board. */
#include <math.h>
#include <stdio.h>
#include "unity.h"
#include "fw_kalman.h"
#include "test_util.h"
#include "cost_util.h"

void setUp(void) {}
void tearDown(void) {}

#define Q16(x) ((int64_t)llround((x) * 65536.0))

/* The lab's drift (issue 48): 50 nm/min with a random walk of 10
 * nm/sqrt(min): q = 100 nm^2/min; the velocity's prior (100 nm/min)^2. */
static fw_kalman_params_t lab_params(void)
{
    fw_kalman_params_t p;
    p.period_us = 1000;
    p.walk_nm2_per_s = (q16_t)Q16(100.0 / 60.0);
    p.vel_prior_nm2_per_s2 = (q16_t)Q16((100.0 / 60.0) * (100.0 / 60.0));
    return p;
}

/* The filter in double precision: d nm, v nm/s, P in nm. */
typedef struct { double d, v, dd, dv, vv, q; } ref_t;

static void ref_step(ref_t *r, double t_s, double z_nm, double var_nm2)
{
    double dd = r->dd + 2 * t_s * r->dv + t_s * t_s * r->vv + r->q * t_s;
    double dv = r->dv + t_s * r->vv;
    double s = dd + var_nm2;
    double kd = dd / s, kv = dv / s;
    double y = z_nm - (r->d + r->v * t_s);
    r->d = r->d + r->v * t_s + kd * y;
    r->v += kv * y;
    r->vv -= kv * dv;
    r->dd = dd - kd * dd;
    r->dv = dv - kd * dv;
}

static void test_kalman_check_refuses_bad_parameters(void)
{
    fw_kalman_t k;
    fw_kalman_params_t p = lab_params();
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, fw_kalman_check(&p));
    TEST_ASSERT_EQUAL_INT(FW_RULE_NULL_POINTER, fw_kalman_check(NULL));
    p.period_us = 0;
    TEST_ASSERT_EQUAL_INT(FW_RULE_DRIFT_KALMAN, fw_kalman_check(&p));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_kalman_init(&k, &p));
    p = lab_params();
    p.walk_nm2_per_s = -1;
    TEST_ASSERT_EQUAL_INT(FW_RULE_DRIFT_KALMAN, fw_kalman_check(&p));
    p = lab_params();
    p.vel_prior_nm2_per_s2 = -1;
    TEST_ASSERT_EQUAL_INT(FW_RULE_DRIFT_KALMAN, fw_kalman_check(&p));
    p = lab_params();
    p.period_us = FW_KALMAN_PERIOD_MAX_US + 1;
    TEST_ASSERT_EQUAL_INT(FW_RULE_DRIFT_KALMAN, fw_kalman_check(&p));
}

static void test_kalman_first_update_takes_the_drift_and_its_velocity(void)
{
    fw_kalman_t k;
    fw_kalman_params_t p = lab_params();
    int64_t dd, dv, vv;
    int i;
    p.walk_nm2_per_s = 0;
    p.vel_prior_nm2_per_s2 = (q16_t)Q16(4.0);   /* (2 nm/s)^2 */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    TEST_ASSERT_EQUAL_INT32(0, fw_kalman_drift_pm(&k));
    for (i = 0; i < 1000; i++) {
        fw_kalman_predict(&k);   /* 1 s */
    }
    TEST_ASSERT_EQUAL_UINT32(1000000u, k.gap_us);
    fw_kalman_covariance(&k, &dd, &dv, &vv);
    TEST_ASSERT_INT64_WITHIN(1, Q16(4.0), dd);   /* T^2 P_vv */
    TEST_ASSERT_INT64_WITHIN(1, Q16(4.0), dv);
    /* z = 1 nm, r = 1 nm^2: K_d = K_v = 0.8 */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, 1000, (q16_t)Q16(1.0)));
    TEST_ASSERT_EQUAL_INT32(800, fw_kalman_drift_pm(&k));
    /* K_v's rounding (half an LSB, 2^-17 /s) times y = 1000 pm */
    TEST_ASSERT_INT32_WITHIN(500, (int32_t)Q16(800.0), k.v_pm_per_s);
    TEST_ASSERT_INT64_WITHIN(2, Q16(0.8), k.p_dd);
    TEST_ASSERT_INT64_WITHIN(2, Q16(0.8), k.p_dv);
    TEST_ASSERT_INT64_WITHIN(2, Q16(0.8), k.p_vv);
    TEST_ASSERT_EQUAL_UINT32(0u, k.gap_us);
    TEST_ASSERT_EQUAL_UINT32(1u, k.updates);
    TEST_ASSERT_FALSE(k.sat);
    /* half a second on: d + v T */
    fw_kalman_advance_us(&k, 500000);
    TEST_ASSERT_EQUAL_INT32(1200, fw_kalman_drift_pm(&k));
}

/* The lab's drift, scanned every 7.3 s with a registration error of 0.5
 * nm, against the double-precision filter: within 2 pm and 0.05 nm/min;
 * after a minute the velocity within 10 nm/min of the truth's mean. */
static void test_kalman_follows_the_reference_on_a_lab_drift(void)
{
    fw_kalman_t k;
    const fw_kalman_params_t p = lab_params();
    const double var = 0.25, t_s = 7.3;
    ref_t r = { 0, 0, 0, 0, (100.0 / 60.0) * (100.0 / 60.0), 100.0 / 60.0 };
    double truth = 0;
    uint32_t seed = 12345u;
    int i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    for (i = 0; i < 40; i++) {
        /* a deterministic normal draw (sum of 12 uniforms) for the walk and the scan */
        double n1 = -6, n2 = -6;
        int j;
        for (j = 0; j < 12; j++) {
            seed = seed * 1664525u + 1013904223u;
            n1 += (seed >> 8) / 16777216.0;
            seed = seed * 1664525u + 1013904223u;
            n2 += (seed >> 8) / 16777216.0;
        }
        truth += (50.0 / 60.0) * t_s + sqrt(r.q * t_s) * n1;
        fw_kalman_advance_us(&k, (int32_t)(t_s * 1e6));
        TEST_ASSERT_INT32_WITHIN(3, (int32_t)llround((r.d + r.v * t_s) * 1000.0), fw_kalman_drift_pm(&k));
        {
            const double z = truth + 0.5 * n2;
            const int32_t z_pm = (int32_t)llround(z * 1000.0);
            ref_step(&r, t_s, z_pm / 1000.0, var);
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, z_pm, (q16_t)Q16(var)));
        }
        TEST_ASSERT_INT32_WITHIN(2, (int32_t)llround(r.d * 1000.0), fw_kalman_drift_pm(&k));
        TEST_ASSERT_DOUBLE_WITHIN(0.05 / 60.0, r.v, k.v_pm_per_s / 65536.0 / 1000.0);
        TEST_ASSERT_INT64_WITHIN(Q16(0.01) + (int64_t)(r.dd * 65536.0 * 1e-3), Q16(r.dd), k.p_dd);
    }
    TEST_ASSERT_DOUBLE_WITHIN(10.0, 50.0, k.v_pm_per_s / 65536.0 / 1000.0 * 60.0);
    TEST_ASSERT_FALSE(k.sat);
}

static void test_kalman_zero_and_near_zero_variance_divide_safely(void)
{
    fw_kalman_t k;
    const fw_kalman_params_t p = lab_params();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    /* no time since reset: P'_dd = 0 and r = 0, S is 1 LSB: nothing taken */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, 5000, 0));
    TEST_ASSERT_EQUAL_INT32(0, fw_kalman_drift_pm(&k));
    TEST_ASSERT_EQUAL_INT32(0, k.v_pm_per_s);
    /* P'_dd > 0, r = 0: z taken whole */
    fw_kalman_advance_us(&k, 2000000);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, 5000, 0));
    TEST_ASSERT_EQUAL_INT32(5000, fw_kalman_drift_pm(&k));
    TEST_ASSERT_EQUAL_INT64(0, k.p_dd);
    /* r = 1 LSB: within a pm */
    fw_kalman_advance_us(&k, 1000000);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, -7000, 1));
    TEST_ASSERT_INT32_WITHIN(1, -7000, fw_kalman_drift_pm(&k));
    TEST_ASSERT_FALSE(k.sat);
}

static void test_kalman_negative_variance_is_refused_and_changes_nothing(void)
{
    fw_kalman_t k, before;
    const fw_kalman_params_t p = lab_params();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    fw_kalman_advance_us(&k, 1000000);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, 900, (q16_t)Q16(0.25)));
    fw_kalman_advance_us(&k, 1000000);
    before = k;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_kalman_update(&k, 100000, -1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_kalman_update(&k, 100000, INT32_MIN));
    TEST_ASSERT_EQUAL_UINT32(2u, k.refused);
    TEST_ASSERT_EQUAL_INT64(before.d_pm_q16, k.d_pm_q16);
    TEST_ASSERT_EQUAL_INT32(before.v_pm_per_s, k.v_pm_per_s);
    TEST_ASSERT_EQUAL_UINT32(before.gap_us, k.gap_us);
    TEST_ASSERT_EQUAL_INT64(before.p_dd, k.p_dd);
    TEST_ASSERT_EQUAL_UINT32(before.updates, k.updates);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_kalman_update(NULL, 0, 0));
}

/* An innovation of the whole int32 range, right after reset (a huge
 * velocity gain): v and d clamp, flagged; the opposite extreme next. */
static void test_kalman_huge_innovation_saturates(void)
{
    fw_kalman_t k;
    fw_kalman_params_t p = lab_params();
    p.vel_prior_nm2_per_s2 = INT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    fw_kalman_predict(&k);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, INT32_MAX, 0));
    TEST_ASSERT_TRUE(k.sat);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, k.v_pm_per_s);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_kalman_drift_pm(&k));
    fw_kalman_advance_us(&k, INT32_MAX);   /* d + v gap beyond int32: clamped */
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_kalman_drift_pm(&k));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, INT32_MIN, (q16_t)Q16(1.0)));
    TEST_ASSERT_TRUE(k.v_pm_per_s < 0);
    TEST_ASSERT_TRUE(fw_kalman_drift_pm(&k) <= 0);
    TEST_ASSERT_TRUE(k.p_dd >= 0 && k.p_dd <= FW_KALMAN_P_MAX);
    TEST_ASSERT_TRUE(k.p_vv >= 0 && k.p_vv <= FW_KALMAN_P_MAX);
    TEST_ASSERT_TRUE(k.sat_count >= 2u);
}

/* Hours without a registration: the gap stops at its maximum, the
 * covariance at P_MAX, no overflow; the next registration is taken whole. */
static void test_kalman_long_gap_saturates_the_covariance(void)
{
    fw_kalman_t k;
    fw_kalman_params_t p = lab_params();
    int64_t dd, dv, vv;
    int i;
    p.walk_nm2_per_s = INT32_MAX;
    p.vel_prior_nm2_per_s2 = INT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    fw_kalman_advance_us(&k, 1000000);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, 50000, (q16_t)Q16(1.0)));
    TEST_ASSERT_FALSE(k.sat);
    for (i = 0; i < 4; i++) {
        fw_kalman_advance_us(&k, INT32_MAX);
    }
    TEST_ASSERT_EQUAL_UINT32(FW_KALMAN_GAP_MAX_US, k.gap_us);
    TEST_ASSERT_TRUE(k.sat);
    fw_kalman_covariance(&k, &dd, &dv, &vv);
    TEST_ASSERT_EQUAL_INT64(FW_KALMAN_P_MAX, dd);
    TEST_ASSERT_TRUE(dv > 0 && dv <= FW_KALMAN_P_MAX);
    TEST_ASSERT_TRUE(vv >= 0 && vv <= FW_KALMAN_P_MAX);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, -123456, (q16_t)Q16(1.0)));
    TEST_ASSERT_INT32_WITHIN(1, -123456, fw_kalman_drift_pm(&k));
    TEST_ASSERT_TRUE(k.p_dd >= 0 && k.p_dd <= Q16(1.0));
    /* the lab's q over the longest gap stays far from P_MAX: no clamp */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    k.p.walk_nm2_per_s = (q16_t)Q16(100.0 / 60.0);
    k.p_vv = Q16(1.0);
    k.gap_us = FW_KALMAN_GAP_MAX_US;
    fw_kalman_covariance(&k, &dd, NULL, NULL);
    TEST_ASSERT_FALSE(k.sat);
    TEST_ASSERT_INT64_WITHIN(Q16(10.0), Q16(2147.483647 * 2147.483647 + 2147.483647 * 100.0 / 60.0), dd);
}

static void test_kalman_shift_moves_the_drift_whole(void)
{
    fw_kalman_t k;
    const fw_kalman_params_t p = lab_params();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    fw_kalman_shift_pm(&k, 250000);
    TEST_ASSERT_EQUAL_INT32(250000, fw_kalman_drift_pm(&k));
    fw_kalman_shift_pm(&k, INT32_MAX);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_kalman_drift_pm(&k));
    TEST_ASSERT_TRUE(k.sat);
    fw_kalman_reset(&k);
    TEST_ASSERT_FALSE(k.sat);
    TEST_ASSERT_EQUAL_INT32(0, fw_kalman_drift_pm(&k));
}

static void test_cost_on_the_board(void)
{
    fw_kalman_t k;
    const fw_kalman_params_t p = lab_params();
    volatile int32_t sink = 0;
    uint32_t t;
    int i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_init(&k, &p));
    fw_kalman_advance_us(&k, 5000000);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_kalman_update(&k, 4000, (q16_t)Q16(0.25)));
    cost_start_timer();
    t = cost_ticks();
    for (i = 0; i < 1000; i++) {
        fw_kalman_predict(&k);
        sink += fw_kalman_drift_pm(&k);
    }
    cost_print("fw_kalman_predict + fw_kalman_drift_pm (a block)", t - cost_ticks(), 1000u);
    t = cost_ticks();
    for (i = 0; i < 100; i++) {
        fw_kalman_advance_us(&k, 5000000);
        (void)fw_kalman_update(&k, 4000 + i, (q16_t)Q16(0.25));
    }
    cost_print("fw_kalman_update (a registration)", t - cost_ticks(), 100u);
    TEST_ASSERT_FALSE(k.sat);
    (void)sink;
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_kalman_check_refuses_bad_parameters);
    RUN_TEST(test_kalman_first_update_takes_the_drift_and_its_velocity);
    RUN_TEST(test_kalman_follows_the_reference_on_a_lab_drift);
    RUN_TEST(test_kalman_zero_and_near_zero_variance_divide_safely);
    RUN_TEST(test_kalman_negative_variance_is_refused_and_changes_nothing);
    RUN_TEST(test_kalman_huge_innovation_saturates);
    RUN_TEST(test_kalman_long_gap_saturates_the_covariance);
    RUN_TEST(test_kalman_shift_moves_the_drift_whole);
    RUN_TEST(test_cost_on_the_board);
    return UNITY_END();
}
