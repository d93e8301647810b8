/* test_board.c - fw_board: one sample through acquisition, force and
 * compensation; frame invariance; saturation; virtual S_n; a block of
 * samples against single steps. The fast path: test_board_fast.c. */
#include <string.h>
#include "unity.h"
#include "fw_board.h"
#include "fw_paper_probe.h"
#include "fw_math.h"
#include "test_util.h"
#include "board_util.h"

static fw_board_config_t cfg;
static fw_board_t b;

void setUp(void)
{
    paper_config(&cfg);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &cfg));
}
void tearDown(void) {}

static void test_board_init_validates_config(void)
{
    fw_board_t x;
    fw_board_config_t c;
    paper_config(&c);
    c.adc_bits = 7;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.deflection_pm_per_v = 0;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.lateral_gain_pn_per_v = -5;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.disp_n_pm_per_v = -5;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.filter_log2 = 9;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.tip_height_nm = c.lever_length_nm;
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_board_init(&x, &c));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(NULL, &c));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, NULL));
    paper_config(&c);
    c.scan_angle_mdeg = INT32_MIN;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&x, &c));
}

/* signals (uV) that a force F_A on a tip moving along dir_A would produce
 * at scan angle scan_deg, using the documented model backwards */
static void signals_for(double scan_deg, double fa_x, double fa_y, double fz,
                        int32_t *sn_uv, int32_t *sl_uv)
{
    double a = (scan_deg - 270.0) * TU_PI / 180.0;
    double fcx = cos(a) * fa_x + sin(a) * fa_y;
    double fcy = -sin(a) * fa_x + cos(a) * fa_y;
    double g = 2.0 * cfg.tip_height_nm / cfg.lever_length_nm;
    *sl_uv = (int32_t)lround(fcy / cfg.lateral_gain_pn_per_v * 1e6);
    *sn_uv = (int32_t)lround((fz + g * fcx) / cfg.normal_gain_pn_per_v * 1e6);
}

static void test_board_same_push_same_frame_a_force_at_every_scan_angle(void)
{
    /* friction on a tip moving at 30 deg in frame A, load 20 nN:
     * |F_par| = mu (F_z + F_adh) so the cot path and the fallback agree */
    static const double scans[] = { 0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0,
                                    17.5, 300.123, 240.0, 60.0 };
    const double dir = 30.0 * TU_PI / 180.0;
    const double fz = 20000.0;
    const double fpar = 0.0865 * (fz + 5000.0);
    const double fax = -fpar * cos(dir);
    const double fay = -fpar * sin(dir);
    size_t k;
    double worst = 0.0;
    for (k = 0; k < sizeof scans / sizeof scans[0]; k++) {
        fw_sample_in_t in;
        fw_sample_out_t out;
        int i;
        cfg.scan_angle_mdeg = (int32_t)lround(scans[k] * 1000.0);
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &cfg));
        signals_for(scans[k], fax, fay, fz, &in.sn_uv, &in.sl_uv);
        for (i = 0; i < 40; i++) {
            in.piezo_pm[0] = (int32_t)lround(200.0 * i * cos(dir));
            in.piezo_pm[1] = (int32_t)lround(200.0 * i * sin(dir));
            in.piezo_pm[2] = 0;
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
        }
        TEST_ASSERT_EQUAL_UINT32(0u, out.flags & ~FW_FLAG_FX_UNOBSERVABLE);
        TEST_ASSERT_INT32_WITHIN(100, (int32_t)lround(fax), out.force_pn[0]);
        TEST_ASSERT_INT32_WITHIN(100, (int32_t)lround(fay), out.force_pn[1]);
        TEST_ASSERT_INT32_WITHIN(40, (int32_t)lround(fz), out.force_pn[2]);
        if (fabs(out.force_pn[0] - fax) > worst) {
            worst = fabs(out.force_pn[0] - fax);
        }
        if (fabs(out.force_pn[1] - fay) > worst) {
            worst = fabs(out.force_pn[1] - fay);
        }
    }
    printf("frame invariance: worst lateral error %.1f pN of %.1f pN (16-bit ADC)\n", worst, fpar);
}

static void test_board_sn_past_10v_flags_and_uses_virtual_sn(void)
{
    fw_sample_in_t in = { 5000000, 0, { 0, 0, 0 } };
    fw_sample_out_t out;
    /* saturated before any reference: no virtual output */
    fw_sample_in_t first = { 12000000, 0, { 0, 0, 0 } };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &first, &out));
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_SN) != 0u);
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_VIRTUAL_SN) == 0u);
    TEST_ASSERT_EQUAL_INT32(32767, out.sn_code);
    /* 5 V at z = 0, then 1 um further down, saturated */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_UINT32(0u, out.flags & FW_FLAG_SAT_SN);
    in.sn_uv = 10000000;   /* exactly at the rail counts as saturated */
    in.piezo_pm[2] = -1000000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_TRUE((out.flags & (FW_FLAG_SAT_SN | FW_FLAG_VIRTUAL_SN)) == (FW_FLAG_SAT_SN | FW_FLAG_VIRTUAL_SN));
    /* S_n' = 5 V + 1000/89 V. The bending offset moved the apex by
     * +C_n dS_n along x_C: theta = 0, friction fallback against the motion
     * F_x = -mu (N + F_adh) / (1 - mu 2h/l), F_z = N - (2h/l) F_x */
    {
        double n = 10680.0 * (5.0 + 1000.0 / 89.0);
        double g = 2.0 * 17300.0 / 100000.0;
        double fx = -0.0865 * (n + 5000.0) / (1.0 - 0.0865 * g);
        TEST_ASSERT_INT32_WITHIN(4, (int32_t)lround(fx), out.force_pn[0]);
        TEST_ASSERT_INT32_WITHIN(4, (int32_t)lround(n - g * fx), out.force_pn[2]);
    }
    /* the apex uses S_n' too: x offset +C_n S_n' */
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(23100.0 * (5.0 + 1000.0 / 89.0)), out.tip_pm[0]);
    TEST_ASSERT_EQUAL_UINT32(2u, fw_board_sat_count(&b, FW_FLAG_SAT_SN));
    TEST_ASSERT_TRUE((fw_board_sticky_flags(&b) & FW_FLAG_VIRTUAL_SN) != 0u);
    fw_board_reset(&b);
    TEST_ASSERT_EQUAL_UINT32(0u, fw_board_sat_count(&b, FW_FLAG_SAT_SN));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_board_sticky_flags(&b));
}

static void test_board_sl_at_just_past_far_past_rail_flags(void)
{
    static const struct { int line; int32_t uv; int32_t code; bool sat; } rows[] = {
        { __LINE__, 9999999, 32767, false },
        { __LINE__, 10000000, 32767, true },
        { __LINE__, 10000001, 32767, true },
        { __LINE__, INT32_MAX, 32767, true },
        { __LINE__, -9999999, -32768, false },
        { __LINE__, -10000000, -32768, true },
        { __LINE__, INT32_MIN, -32768, true },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        fw_sample_in_t in = { 0, rows[i].uv, { 0, 0, 0 } };
        fw_sample_out_t out;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].code, out.sl_code, rows[i].line, "code");
        UNITY_TEST_ASSERT(((out.flags & FW_FLAG_SAT_SL) != 0u) == rows[i].sat, rows[i].line, "flag");
    }
    TEST_ASSERT_EQUAL_UINT32(5u, fw_board_sat_count(&b, FW_FLAG_SAT_SL));
}

static void test_board_zero_length_moves_stay_finite_theta_unknown(void)
{
    fw_sample_in_t in = { 3000000, 1000000, { 100, 200, 0 } };
    fw_sample_out_t out;
    int i;
    for (i = 0; i < 50; i++) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    }
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_THETA_UNKNOWN) != 0u);
    /* theta 90 deg: F_x = 0, F_y = lat S_l */
    TEST_ASSERT_EQUAL_INT32(0, out.force_pn[0]);
    TEST_ASSERT_INT32_WITHIN(12, 37900, out.force_pn[1]);
}

static void test_board_piezo_cmd_puts_apex_at_joystick_target(void)
{
    fw_sample_in_t in = { 4000000, -2000000, { 45000000, 45000000, 0 } };
    fw_sample_out_t out;
    int32_t joy[2] = { 16384, -32768 };
    int32_t cmd[2];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_piezo_cmd(&b, joy, cmd));
    in.piezo_pm[0] = cmd[0];
    in.piezo_pm[1] = cmd[1];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_INT32_WITHIN(1, 45000000 + 1250000, out.tip_pm[0]);
    TEST_ASSERT_INT32_WITHIN(1, 45000000 - 2500000, out.tip_pm[1]);
    joy[0] = 40000;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_piezo_cmd(&b, joy, cmd));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_piezo_cmd(&b, NULL, cmd));
}

static void test_board_baseline_removes_offset(void)
{
    fw_sample_in_t in = { 500000, -300000, { 0, 0, 0 } };
    fw_sample_out_t out;
    TEST_ASSERT_EQUAL_INT(FW_ERR_STATE, fw_board_record_baseline(&b));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_record_baseline(&b));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_INT32(0, out.force_pn[1]);
    TEST_ASSERT_EQUAL_INT32(0, out.force_pn[2]);
}

static void test_board_force_saturates_with_flag_and_counter(void)
{
    fw_board_config_t c;
    fw_sample_in_t in = { 9000000, 9000000, { 0, 0, 0 } };
    fw_sample_out_t out;
    paper_config(&c);
    c.normal_gain_pn_per_v = INT32_MAX;
    c.lateral_gain_pn_per_v = INT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &c));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_FORCE) != 0u);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, out.force_pn[2]);
    TEST_ASSERT_EQUAL_UINT32(1u, fw_board_sat_count(&b, FW_FLAG_SAT_FORCE));
}

/* fw_board_step_block on a configuration with only the checked path (ADC
 * filter on), in uneven blocks, against fw_board_step one sample at a
 * time: the same outputs and state. */
static void test_board_step_block_checked_config_matches_single_steps(void)
{
    static fw_board_t s1;
    static fw_board_t s2;
    fw_sample_in_t in[300];
    fw_sample_out_t o1[300];
    fw_sample_out_t o2[300];
    size_t i;
    size_t at = 0;
    size_t len = 1;
    cfg.filter_log2 = 2;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&s1, &cfg));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&s2, &cfg));
    TEST_ASSERT_EQUAL_INT(FW_BOARD_PATH_CHECKED, s2.path_cfg);
    for (i = 0; i < 300; i++) {
        in[i].sn_uv = (int32_t)(3000000 + 40000 * (long)(i % 17)) * ((i % 50 == 7) ? 4 : 1);
        in[i].sl_uv = -200000 + 3000 * (int32_t)i;
        in[i].piezo_pm[0] = 45000000 + 400 * (int32_t)i;
        in[i].piezo_pm[1] = 45000000 + 90 * (int32_t)i;
        in[i].piezo_pm[2] = -100 * (int32_t)i;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&s1, &in[i], &o1[i]));
    }
    while (at < 300) {
        size_t n = (300 - at < len) ? 300 - at : len;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&s2, &in[at], &o2[at], n));
        at += n;
        len = len * 2 + 1;
    }
    TEST_ASSERT_EQUAL_MEMORY(o1, o2, sizeof o1);
    assert_boards_identical(&s2, &s1, &o2[299], &o1[299], 299);
    TEST_ASSERT_TRUE((fw_board_sticky_flags(&s2) & FW_FLAG_SAT_SN) != 0u);
}

/* fw_board_step_block's arguments: NULL board or buffers refused with
 * nothing changed; an empty block is FW_OK and changes nothing. */
static void test_board_step_block_null_and_empty(void)
{
    fw_sample_in_t in = { 1000, 2000, { 0, 0, 0 } };
    fw_sample_out_t out;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(NULL, &in, &out, 1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(&b, NULL, &out, 1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(&b, &in, NULL, 1));
    TEST_ASSERT_FALSE(b.stepped);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b, NULL, NULL, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b, &in, &out, 0));
    TEST_ASSERT_FALSE(b.stepped);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(NULL, NULL, NULL, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b, &in, &out, 1));
    TEST_ASSERT_TRUE(b.stepped);
}

/* Every entry tests its pointers (fw_board.h) and leaves the instance
 * untouched on FW_ERR_ARG. */
static void test_board_step_checked_null_pointers_return_arg_error(void)
{
    fw_board_config_t c;
    fw_board_t b;
    fw_sample_in_t in = { 0, 0, { 0, 0, 0 } };
    fw_sample_out_t out;
    paper_config(&c);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &c));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_checked(NULL, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_checked(&b, NULL, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_checked(&b, &in, NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step(NULL, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step(&b, NULL, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step(&b, &in, NULL));
    TEST_ASSERT_FALSE(b.stepped);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_TRUE(b.stepped);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_board_init_validates_config);
    RUN_TEST(test_board_same_push_same_frame_a_force_at_every_scan_angle);
    RUN_TEST(test_board_sn_past_10v_flags_and_uses_virtual_sn);
    RUN_TEST(test_board_sl_at_just_past_far_past_rail_flags);
    RUN_TEST(test_board_zero_length_moves_stay_finite_theta_unknown);
    RUN_TEST(test_board_piezo_cmd_puts_apex_at_joystick_target);
    RUN_TEST(test_board_baseline_removes_offset);
    RUN_TEST(test_board_force_saturates_with_flag_and_counter);
    RUN_TEST(test_board_step_checked_null_pointers_return_arg_error);
    RUN_TEST(test_board_step_block_checked_config_matches_single_steps);
    RUN_TEST(test_board_step_block_null_and_empty);
    return UNITY_END();
}
