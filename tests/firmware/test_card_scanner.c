/* test_card_scanner.c - the card's scanner compensation (fw_card.h's
 * creep_enable, hyst_enable): off, the card as it was; on, the command
 * passes fw_creep then fw_hyst's inverse; refused models; what it costs a
 * block on the board. */
#include <math.h>
#include "card_util.h"
#include "test_util.h"
#include "cost_util.h"

#define BLOCK 20
#define BLOCKS 400
#define R_PM 5000000   /* the scanner's half range: twice the paper scene's joystick reach */

/* A second card, its own storage (card_util.h's is the first's). */
static fw_card_t card_b;
static fw_card_storage_t st_b;
static fw_particle_t part_store_b[N_PART];
static fw_wire_t wire_store_b[1];
static fw_trench_point_t trench_store_b[TRENCH_CAP];
static fw_sample_out_t scratch_b[SCRATCH];

static fw_status_t init_b(void)
{
    st_b = st;
    st_b.particles = part_store_b;
    st_b.wires = wire_store_b;
    st_b.trench = trench_store_b;
    st_b.scratch = scratch_b;
    return fw_card_init(&card_b, &cfg, &st_b, NULL);
}

void setUp(void) { default_config(); }
void tearDown(void) {}

/* A direct model about 10 % of the range wide (as test_hyst.c's), half
 * range range_pm. */
static void lab_hyst_range(fw_hyst_params_t *p, int32_t origin_pm, int32_t range_pm)
{
    static const double w[8] = { 0.56, 0.13, 0.09, 0.07, 0.055, 0.045, 0.035, 0.025 };
    int i;
    memset(p, 0, sizeof *p);
    p->n = 8;
    for (i = 0; i < p->n; i++) {
        p->r_pm[i] = (int32_t)((int64_t)range_pm * i / p->n);
        p->w_q24[i] = (q24_t)lround(w[i] * TU_TWO_POW(24));
    }
    p->range_pm = range_pm;
    p->origin_pm = origin_pm;
}

static void lab_hyst(fw_hyst_params_t *p, int32_t origin_pm)
{
    lab_hyst_range(p, origin_pm, R_PM);
}

/* The same with 16 plays, as ./afm calib scanner fits (the lab scene's):
 * the weights past the first split evenly. */
static void lab_hyst16(fw_hyst_params_t *p, int32_t origin_pm)
{
    int i;
    lab_hyst(p, origin_pm);
    p->n = FW_HYST_N_MAX;
    for (i = 0; i < p->n; i++) {
        p->r_pm[i] = (int32_t)((int64_t)R_PM * i / p->n);
        p->w_q24[i] = (i == 0) ? (q24_t)lround(0.56 * TU_TWO_POW(24)) : (q24_t)lround(0.44 / 15 * TU_TWO_POW(24));
    }
}

static void lab_creep(fw_creep_params_t *p)
{
    p->gamma_ppm = 15000;
    p->t0_us = 100000;
    p->period_us = 1000;
}

/* Block k's pose: the stylus on a slow circle, engaged. */
static fw_card_pose_t pose_of(int k)
{
    fw_card_pose_t pose = pose0;
    pose.joy_q15[0] = (int32_t)lround(20000.0 * cos(k / 40.0));
    pose.joy_q15[1] = (int32_t)lround(15000.0 * sin(k / 55.0));
    return pose;
}

static fw_card_out_t step_card(fw_card_t *c, int k)
{
    fw_sample_in_t in[BLOCK];
    fw_card_in_t ci;
    fw_card_out_t out;
    samples(in, BLOCK, 150000 + 1000 * (k % 7), -20000, -1200000 + 500 * k, -300000, 40, 0);
    ci.samples = in;
    ci.n = BLOCK;
    ci.pose = pose_of(k);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_step_block(c, &ci, &out));
    return out;
}

static void assert_same_out(const fw_card_out_t *a, const fw_card_out_t *b, int k)
{
    UNITY_TEST_ASSERT_EQUAL_INT32(a->piezo_cmd_pm[0], b->piezo_cmd_pm[0], k, "command x");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->piezo_cmd_pm[1], b->piezo_cmd_pm[1], k, "command y");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->target_pm[0], b->target_pm[0], k, "target x");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->target_pm[1], b->target_pm[1], k, "target y");
    UNITY_TEST_ASSERT_EQUAL_UINT32(a->flags, b->flags, k, "flags");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->force_pn[0], b->force_pn[0], k, "force x");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->tip_pm[0], b->tip_pm[0], k, "apex x");
}

/* Off, whatever the models hold (even models the check would refuse):
 * the card of a zeroed configuration, block for block. */
static void test_switches_off_leave_the_card_as_it_was(void)
{
    fw_card_config_t off = cfg;
    int k;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &off, &st, NULL));
    cfg.creep.period_us = -1;
    cfg.hyst[0].n = 0;
    cfg.hyst[1].w_q24[0] = -1;
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, rule_of());
    TEST_ASSERT_EQUAL_INT(FW_OK, init_b());
    for (k = 0; k < BLOCKS; k++) {
        const fw_card_out_t a = step_card(&card, k);
        const fw_card_out_t b = step_card(&card_b, k);
        assert_same_out(&a, &b, k);
    }
}

/* On with models that do nothing (gamma 0; one play of threshold 0 and
 * weight 1): the same commands, bit for bit. */
static void test_identity_models_on_change_no_command(void)
{
    fw_card_config_t off = cfg;
    int k;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &off, &st, NULL));
    cfg.creep_enable = true;
    lab_creep(&cfg.creep);
    cfg.creep.gamma_ppm = 0;
    cfg.hyst_enable = true;
    for (k = 0; k < 2; k++) {
        memset(&cfg.hyst[k], 0, sizeof cfg.hyst[k]);
        cfg.hyst[k].n = 1;
        cfg.hyst[k].w_q24[0] = FW_Q24_ONE;
        cfg.hyst[k].range_pm = FW_HYST_RANGE_MAX_PM;
    }
    TEST_ASSERT_EQUAL_INT(FW_OK, init_b());
    for (k = 0; k < BLOCKS; k++) {
        const fw_card_out_t a = step_card(&card, k);
        const fw_card_out_t b = step_card(&card_b, k);
        assert_same_out(&a, &b, k);
    }
}

/* Block k's samples' piezo x (step_card's): the direct model's input. */
static int32_t piezo_x_of(int k, int j)
{
    return -1200000 + 500 * k + 40 * j;
}

/* The apex x the card with the compensation on gives for block k, from the
 * card's with it off (off_tip_pm): each sample's piezo reading through the
 * direct model hd, plus the creep the feed-forward took off the previous
 * command (*expect_pm). */
static int32_t apex_on(fw_hyst_t *hd, int k, int32_t off_tip_pm, int32_t expect_pm)
{
    int32_t p = 0;
    int j;
    for (j = 0; j < BLOCK; j++) {
        p = fw_hyst_direct_pm(hd, piezo_x_of(k, j), NULL);
    }
    return off_tip_pm + (p - piezo_x_of(k, BLOCK - 1)) + expect_pm;
}

/* On: each axis's command is fw_hyst's inverse of fw_creep's shaping of
 * the command the card gives with both off; the apex is the scanner's
 * (apex_on); nothing else changes. */
static void test_on_the_command_passes_creep_then_the_inverse_hysteresis(void)
{
    fw_card_config_t off = cfg;
    fw_creep_t cr[2];
    fw_hyst_t hy[2], hd;
    int32_t expect = 0;
    int k, i;
    /* no object models: the apex moves them (test_card_objects), not this */
    cfg.n_particles = 0;
    cfg.n_wires = 0;
    cfg.litho = false;
    off = cfg;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &off, &st, NULL));
    cfg.creep_enable = true;
    lab_creep(&cfg.creep);
    cfg.hyst_enable = true;
    lab_hyst(&cfg.hyst[0], 0);
    lab_hyst(&cfg.hyst[1], -100000);
    TEST_ASSERT_EQUAL_INT(FW_OK, init_b());
    for (i = 0; i < 2; i++) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&cr[i], &cfg.creep));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&hy[i], &cfg.hyst[i]));
    }
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&hd, &cfg.hyst[0]));
    for (k = 0; k < BLOCKS; k++) {
        fw_card_out_t a = step_card(&card, k);
        const fw_card_out_t b = step_card(&card_b, k);
        a.tip_pm[0] = apex_on(&hd, k, a.tip_pm[0], expect);
        for (i = 0; i < 2; i++) {
            const int32_t r = a.piezo_cmd_pm[i];
            const int32_t u = fw_creep_step_pm(&cr[i], r, NULL);
            if (i == 0) {
                expect = r - u;
            }
            a.piezo_cmd_pm[i] = fw_hyst_inverse_pm(&hy[i], u, NULL);
        }
        assert_same_out(&a, &b, k);
    }
    /* and reset starts both models again */
    fw_card_reset(&card);
    fw_card_reset(&card_b);
    for (i = 0; i < 2; i++) {
        fw_creep_reset(&cr[i]);
        fw_hyst_reset(&hy[i]);
    }
    fw_hyst_reset(&hd);
    expect = 0;
    for (k = 0; k < 20; k++) {
        fw_card_out_t a = step_card(&card, k);
        const fw_card_out_t b = step_card(&card_b, k);
        a.tip_pm[0] = apex_on(&hd, k, a.tip_pm[0], expect);
        for (i = 0; i < 2; i++) {
            const int32_t r = a.piezo_cmd_pm[i];
            const int32_t u = fw_creep_step_pm(&cr[i], r, NULL);
            if (i == 0) {
                expect = r - u;
            }
            a.piezo_cmd_pm[i] = fw_hyst_inverse_pm(&hy[i], u, NULL);
        }
        assert_same_out(&a, &b, k);
    }
}

/* A command the hysteresis model clamps is a position clamped. */
static void test_a_clamped_command_is_flagged(void)
{
    fw_card_out_t b;
    cfg.hyst_enable = true;
    lab_hyst_range(&cfg.hyst[0], 0, 1000000);   /* 1 um: the joystick reaches past it */
    lab_hyst(&cfg.hyst[1], 0);
    TEST_ASSERT_EQUAL_INT(FW_OK, init_b());
    b = step_card(&card_b, 0);   /* joystick x at 0.61 of 2.5 um */
    TEST_ASSERT_TRUE((b.flags & FW_FLAG_SAT_POS) != 0u);
    TEST_ASSERT_INT32_WITHIN(1, 1000000, b.piezo_cmd_pm[0]);
}

static void test_check_names_the_scanner_rules(void)
{
    cfg.creep_enable = true;
    lab_creep(&cfg.creep);
    cfg.hyst_enable = true;
    lab_hyst(&cfg.hyst[0], 0);
    lab_hyst(&cfg.hyst[1], 0);
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, rule_of());
    cfg.hyst[1].r_pm[0] = 5;
    TEST_ASSERT_EQUAL_INT(FW_RULE_HYST, rule_of());
    cfg.hyst[1].r_pm[0] = 0;
    cfg.creep.period_us = cfg.creep.t0_us;
    TEST_ASSERT_EQUAL_INT(FW_RULE_CREEP, rule_of());
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_rule_status(FW_RULE_CREEP));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_rule_status(FW_RULE_HYST));
}

/* Median and worst instructions a block of fw_card_step_block. */
static void block_cost(fw_card_t *c, const char *what)
{
    static uint32_t ticks[BLOCKS];
    uint32_t worst = 0u;
    int k, j;
    for (k = 0; k < BLOCKS; k++) {
        fw_sample_in_t in[BLOCK];
        fw_card_in_t ci;
        fw_card_out_t out;
        uint32_t t;
        samples(in, BLOCK, 150000 + 1000 * (k % 7), -20000, -1200000 + 500 * k, -300000, 40, 0);
        ci.samples = in;
        ci.n = BLOCK;
        ci.pose = pose_of(k);
        t = cost_ticks();
        (void)fw_card_step_block(c, &ci, &out);
        ticks[k] = t - cost_ticks();
        worst = (ticks[k] > worst) ? ticks[k] : worst;
    }
    for (k = 1; k < BLOCKS; k++) {   /* insertion sort for the median */
        const uint32_t v = ticks[k];
        for (j = k - 1; j >= 0 && ticks[j] > v; j--) {
            ticks[j + 1] = ticks[j];
        }
        ticks[j + 1] = v;
    }
    if (COST_ON_BOARD) {
        printf("cost on the board: fw_card_step_block, %d samples, %s: %lu instructions a block median, %lu worst\n",
               BLOCK, what, (unsigned long)(ticks[BLOCKS / 2] * COST_INSTR_PER_TICK),
               (unsigned long)(worst * COST_INSTR_PER_TICK));
    }
}

static void test_cost_on_the_board(void)
{
    fw_card_config_t off = cfg;
    cost_start_timer();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &off, &st, NULL));
    block_cost(&card, "compensation off");
    /* the drift's Kalman filter, at 1 nm/s: the models move a pm a block */
    off.drift_filter = FW_DRIFT_FILTER_KALMAN;
    off.drift_kalman.period_us = 1000;
    off.drift_kalman.walk_nm2_per_s = 109227;           /* 10 nm/sqrt(min), 16.16 */
    off.drift_kalman.vel_prior_nm2_per_s2 = 182044;     /* (100 nm/min)^2, 16.16 */
    off.drift_scan_var_nm2 = 16384;                     /* (0.5 nm)^2, 16.16 */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &off, &st, NULL));
    card.drift.kalman[0].v_pm_per_s = 1000 * 65536;
    card.drift.kalman[1].v_pm_per_s = -1000 * 65536;
    block_cost(&card, "drift Kalman filter on");
    TEST_ASSERT_INT32_WITHIN(2, BLOCKS, card.drift.offset_pm[0]);
    cfg.creep_enable = true;
    lab_creep(&cfg.creep);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    block_cost(&card, "creep on");
    cfg.creep_enable = false;
    cfg.hyst_enable = true;
    lab_hyst(&cfg.hyst[0], 0);
    lab_hyst(&cfg.hyst[1], 0);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    block_cost(&card, "hysteresis on (8 plays)");
    cfg.creep_enable = true;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    block_cost(&card, "both on");
    lab_hyst16(&cfg.hyst[0], 0);
    lab_hyst16(&cfg.hyst[1], 0);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    block_cost(&card, "both on (16 plays)");
    cfg.creep_enable = false;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    block_cost(&card, "hysteresis on (16 plays)");
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_switches_off_leave_the_card_as_it_was);
    RUN_TEST(test_identity_models_on_change_no_command);
    RUN_TEST(test_on_the_command_passes_creep_then_the_inverse_hysteresis);
    RUN_TEST(test_a_clamped_command_is_flagged);
    RUN_TEST(test_check_names_the_scanner_rules);
    RUN_TEST(test_cost_on_the_board);
    return UNITY_END();
}
