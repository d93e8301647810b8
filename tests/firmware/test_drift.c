/* test_drift.c - fw_drift: local-scan offsets applied to every object. */
#include "unity.h"
#include "fw_drift.h"
#include "test_util.h"
#include "fw_kalman.h"

void setUp(void) {}
void tearDown(void) {}

static void test_drift_measure_accepts_within_limit_and_accumulates(void)
{
    fw_drift_t d;
    const int32_t model[2] = { 1000000, 2000000 };
    const int32_t scan[2] = { 1030000, 1960000 };
    int32_t delta[2];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_init(&d, 500000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_measure(&d, model, scan, delta));
    TEST_ASSERT_EQUAL_INT32(30000, delta[0]);
    TEST_ASSERT_EQUAL_INT32(-40000, delta[1]);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_measure(&d, model, scan, delta));
    TEST_ASSERT_EQUAL_INT32(60000, d.offset_pm[0]);
    TEST_ASSERT_EQUAL_INT32(-80000, d.offset_pm[1]);
}

static void test_drift_refuses_jumps_beyond_limit(void)
{
    fw_drift_t d;
    const int32_t model[2] = { INT32_MIN, 0 };
    const int32_t scan[2] = { INT32_MAX, 0 };
    const int32_t near[2] = { 400000, 300000 };   /* |delta| = 500 nm: at the limit */
    const int32_t past[2] = { 400000, 300001 };
    const int32_t zero[2] = { 0, 0 };
    int32_t delta[2];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_init(&d, 500000));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_drift_measure(&d, model, scan, delta));
    TEST_ASSERT_EQUAL_UINT32(1u, d.rejected);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_measure(&d, zero, near, delta));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_drift_measure(&d, zero, past, delta));
    TEST_ASSERT_EQUAL_INT32(0, delta[0]);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_drift_init(&d, 0));
}

static void test_drift_apply_moves_particles_wires_and_trenches(void)
{
    fw_particle_t ps[2];
    fw_particles_t m;
    fw_wire_t w[2];
    fw_trench_point_t tp[2];
    fw_litho_t l;
    const int32_t tip[3] = { 7, 8, 0 };
    const int32_t delta[2] = { -1500, 2500 };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_init(&m, ps, 2, 20000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, 100, 200, 50000, 1000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w[0], 10, 20, 0u, 1300000, 100000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w[1], 30, 40, 0u, 1300000, 100000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_init(&l, tp, 2, 0, FW_Q16_ONE, 20000, 1000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_litho_step(&l, tip, 1000));
    fw_drift_apply(delta, &m, w, 2, &l);
    TEST_ASSERT_EQUAL_INT32(-1400, ps[0].x_pm);
    TEST_ASSERT_EQUAL_INT32(2700, ps[0].y_pm);
    TEST_ASSERT_EQUAL_INT32(-1490, w[0].x_pm);
    TEST_ASSERT_EQUAL_INT32(2540, w[1].y_pm);
    TEST_ASSERT_EQUAL_INT32(-1493, tp[0].x_pm);
    fw_drift_apply(delta, NULL, NULL, 0, NULL);
}

/* The Kalman filter (fw_drift_use_kalman): a registration moves the offset
 * by the change of its estimate, the blocks after it carry the drift on at
 * the estimated velocity, a landmark's jump is taken whole. */
static void test_drift_kalman_predicts_between_registrations(void)
{
    fw_drift_t d;
    fw_kalman_params_t p = { 1000, 109227, 182044 };   /* 1 ms; 10 nm/sqrt(min); (100 nm/min)^2 in 16.16 */
    const int32_t model[2] = { 0, 0 };
    const int32_t scan[2] = { 1000, -500 };
    const int32_t jump[2] = { 250000, 0 };
    int32_t delta[2], moved[2] = { 0, 0 };
    int i;
    TEST_ASSERT_EQUAL_INT(FW_RULE_DRIFT_KALMAN, fw_drift_filter_check(2, &p, 0));
    TEST_ASSERT_EQUAL_INT(FW_RULE_DRIFT_KALMAN, fw_drift_filter_check(FW_DRIFT_FILTER_KALMAN, &p, -1));
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, fw_drift_filter_check(FW_DRIFT_FILTER_STEP, NULL, -1));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_init(&d, 500000));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_drift_use_kalman(&d, &p, -1));
    TEST_ASSERT_EQUAL_INT(FW_DRIFT_FILTER_STEP, d.filter);
    fw_drift_predict(&d, delta);   /* the step filter: nothing moves */
    TEST_ASSERT_EQUAL_INT32(0, delta[0]);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_use_kalman(&d, &p, 16384));   /* (0.5 nm)^2 */
    for (i = 0; i < 1000; i++) {
        fw_drift_predict(&d, delta);
    }
    TEST_ASSERT_EQUAL_INT32(0, d.offset_pm[0]);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_measure(&d, model, scan, delta));
    TEST_ASSERT_INT32_WITHIN(100, 1000, delta[0]);    /* K_d = P / (P + r) with P = (1.7 nm)^2 + q */
    TEST_ASSERT_INT32_WITHIN(50, -500, delta[1]);
    TEST_ASSERT_EQUAL_INT32(delta[0], d.offset_pm[0]);
    for (i = 0; i < 1000; i++) {   /* a second on: about the same again */
        fw_drift_predict(&d, delta);
        moved[0] += delta[0];
        moved[1] += delta[1];
    }
    /* v = K_v z, K_v = T P_vv / (T^2 P_vv + q T + r) = 2.778 / 4.694 /s: the
     * walk explains part of the first second's drift */
    TEST_ASSERT_INT32_WITHIN(3, 592, moved[0]);
    TEST_ASSERT_INT32_WITHIN(3, -296, moved[1]);
    TEST_ASSERT_EQUAL_INT32(moved[0], d.offset_pm[0] - fw_kalman_drift_pm(&d.kalman[0]) + moved[0]);
    i = d.offset_pm[0];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_drift_jump_within(&d, model, jump, 300000, delta));
    TEST_ASSERT_EQUAL_INT32(250000, delta[0]);
    TEST_ASSERT_EQUAL_INT32(i + 250000, d.offset_pm[0]);
    TEST_ASSERT_EQUAL_INT32(d.offset_pm[0], fw_kalman_drift_pm(&d.kalman[0]));
    fw_drift_reset(&d);
    TEST_ASSERT_EQUAL_INT(FW_DRIFT_FILTER_KALMAN, d.filter);
    TEST_ASSERT_EQUAL_INT32(0, fw_kalman_drift_pm(&d.kalman[0]));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_drift_measure_accepts_within_limit_and_accumulates);
    RUN_TEST(test_drift_refuses_jumps_beyond_limit);
    RUN_TEST(test_drift_apply_moves_particles_wires_and_trenches);
    RUN_TEST(test_drift_kalman_predicts_between_registrations);
    return UNITY_END();
}
