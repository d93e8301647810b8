/* test_card.c - fw_card: the whole card per block. Init names the rule it
 * refuses; the displacement estimate; the block's mean force, flags, apex
 * and counters; the command and the hand's force from the pose (the limit
 * exactly and one over); and the card as a pure function (two cards, any
 * split of the blocks, the same outputs). The objects through the card:
 * test_card_objects.c. */
#include <string.h>
#include "unity.h"
#include "fw_card.h"
#include "fw_calib.h"
#include "fw_paper_probe.h"
#include "test_util.h"
#include "card_util.h"

void setUp(void)
{
    default_config();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
}
void tearDown(void) {}

/* One broken rule per row, each a change to the default configuration. */
static void brk_adc_bits(void) { cfg.board.adc_bits = 17; }
static void brk_filter(void) { cfg.board.filter_log2 = 5; }
static void brk_gain(void) { cfg.board.lateral_gain_pn_per_v = 0; }
static void brk_lever(void) { cfg.board.lever_length_nm = 0; }
static void brk_tip_long(void) { cfg.board.tip_height_nm = cfg.board.lever_length_nm; }
static void brk_mu(void) { cfg.board.mu_ppm = 1000001; }
static void brk_adhesion(void) { cfg.board.adhesion_pn = -1; }
static void brk_mu_2h_l(void) { cfg.board.mu_ppm = 900000; cfg.board.tip_height_nm = 60000; }
static void brk_deflection(void) { cfg.board.deflection_pm_per_v = 0; }
static void brk_theta(void) { cfg.board.theta_min_disp_pm = -1; }
/* the lever's estimate 3 h K_n / (2 l) = 11.25 um/V: past 2^22 pm/V */
static void brk_disp_range(void)
{
    cfg.board.tip_height_nm = 50000;
    cfg.board.lever_length_nm = 60000;
    cfg.board.deflection_pm_per_v = 9000000;
}
static void brk_disp_negative(void) { cfg.board.disp_n_pm_per_v = -5; }
static void brk_joystick(void) { cfg.board.kappa_q16 = -1; }
static void brk_tip_radius(void) { cfg.tip_radius_pm = -1; }
static void brk_particle(void) { particles[1].radius_pm = 0; }
static void brk_margin(void) { cfg.particle_margin_pn = -1; }
static void brk_particles_null(void) { cfg.particles = NULL; }
static void brk_particle_capacity(void) { st.particle_capacity = N_PART - 1; }
static void brk_wire(void) { wires_on(); wires[0].diameter_pm = 2000000; }   /* thicker than long */
static void brk_wire_capacity(void) { wires_on(); st.wire_capacity = 0; }
static void brk_wire_mu(void) { wires_on(); cfg.wire_mu_ppm = 2000000; }
static void brk_gamma(void) { wires_on(); cfg.tip_half_angle_mdeg = 60000; }
static void brk_litho(void) { litho_on(); cfg.litho_threshold_pn = -1; }
static void brk_litho_storage(void) { litho_on(); st.trench = NULL; }
static void brk_landmark_step(void) { cfg.landmark_max_step_pm = 0; }
static void brk_landmarks(void) { cfg.landmarks = NULL; }
static void brk_haptic(void) { cfg.haptic_max_un = -1; }
static void brk_word(void) { cfg.word_bits = 24; }
static void brk_word16(void) { cfg.word_bits = 16; cfg.board.normal_gain_pn_per_v = 200000; }
static void brk_scratch(void) { st.scratch = NULL; }

static void test_card_init_names_each_rule_it_refuses(void)
{
    static const struct {
        int line;
        void (*breaks)(void);
        fw_rule_t rule;
    } rows[] = {
        { __LINE__, brk_adc_bits, FW_RULE_ADC_BITS },
        { __LINE__, brk_filter, FW_RULE_ADC_FILTER },
        { __LINE__, brk_gain, FW_RULE_FORCE_GAINS },
        { __LINE__, brk_lever, FW_RULE_LEVER_POSITIVE },
        { __LINE__, brk_tip_long, FW_RULE_TIP_SHORTER_THAN_LEVER },
        { __LINE__, brk_mu, FW_RULE_MU_RANGE },
        { __LINE__, brk_adhesion, FW_RULE_ADHESION },
        { __LINE__, brk_mu_2h_l, FW_RULE_MU_2H_OVER_L },
        { __LINE__, brk_deflection, FW_RULE_DEFLECTION_GAIN },
        { __LINE__, brk_theta, FW_RULE_THETA_MIN_DISP },
        { __LINE__, brk_disp_range, FW_RULE_DISP_RANGE },
        { __LINE__, brk_disp_negative, FW_RULE_DISP_NEGATIVE },
        { __LINE__, brk_joystick, FW_RULE_JOYSTICK_RANGE },
        { __LINE__, brk_tip_radius, FW_RULE_TIP_RADIUS },
        { __LINE__, brk_particle, FW_RULE_PARTICLE },
        { __LINE__, brk_margin, FW_RULE_PARTICLE },
        { __LINE__, brk_particles_null, FW_RULE_NULL_POINTER },
        { __LINE__, brk_particle_capacity, FW_RULE_PARTICLE_CAPACITY },
        { __LINE__, brk_wire, FW_RULE_WIRE },
        { __LINE__, brk_wire_capacity, FW_RULE_WIRE_CAPACITY },
        { __LINE__, brk_wire_mu, FW_RULE_WIRE_FRICTION },
        { __LINE__, brk_gamma, FW_RULE_TIP_HALF_ANGLE },
        { __LINE__, brk_litho, FW_RULE_LITHO },
        { __LINE__, brk_litho_storage, FW_RULE_LITHO_CAPACITY },
        { __LINE__, brk_landmark_step, FW_RULE_DRIFT_STEP },
        { __LINE__, brk_landmarks, FW_RULE_LANDMARKS },
        { __LINE__, brk_haptic, FW_RULE_HAPTIC },
        { __LINE__, brk_word, FW_RULE_WORD_BITS },
        { __LINE__, brk_word16, FW_RULE_WORD16_RANGE },
        { __LINE__, brk_scratch, FW_RULE_NULL_POINTER },
    };
    size_t i;
    int r;
    fw_rule_t got;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        default_config();
        rows[i].breaks();
        got = rule_of();
        particles[1].radius_pm = 50000;
        wires[0].diameter_pm = 100000;
        UNITY_TEST_ASSERT_EQUAL_INT(rows[i].rule, got, rows[i].line, fw_rule_text(rows[i].rule));
    }
    default_config();
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, rule_of());
    TEST_ASSERT_EQUAL_INT(FW_RULE_NULL_POINTER, fw_card_check(NULL, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_init(NULL, &cfg, &st, &got));
    TEST_ASSERT_EQUAL_INT(FW_RULE_NULL_POINTER, got);
    /* every rule has words and a status; outside the table, a text still */
    for (r = 1; r < FW_RULE_COUNT; r++) {
        TEST_ASSERT_TRUE(strlen(fw_rule_text((fw_rule_t)r)) > 10);
        TEST_ASSERT_TRUE(fw_rule_status((fw_rule_t)r) < 0);
    }
    TEST_ASSERT_EQUAL_STRING("unknown rule", fw_rule_text(FW_RULE_COUNT));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_rule_status(FW_RULE_OK));
}

static void test_card_displacement_estimate_explicit_and_off(void)
{
    int32_t est;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_disp_estimate(FW_PAPER_TIP_HEIGHT_NM, FW_PAPER_LEVER_LENGTH_NM,
                                                        FW_PAPER_DEFLECTION_PM_PER_V, &est));
    TEST_ASSERT_EQUAL_INT32(23096, est);   /* 3 17.3 um 89 nm/V / 200 um */
    TEST_ASSERT_EQUAL_INT32(est, fw_card_disp_n_pm_per_v(&card));
    TEST_ASSERT_EQUAL_INT32(est, fw_card_disp_l_pm_per_v(&card));
    default_config();
    cfg.board.disp_n_pm_per_v = 23100;   /* calibrated C_n, estimated C_l */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    TEST_ASSERT_EQUAL_INT32(23100, fw_card_disp_n_pm_per_v(&card));
    TEST_ASSERT_EQUAL_INT32(est, fw_card_disp_l_pm_per_v(&card));
    default_config();
    cfg.board.disp_n_pm_per_v = 0;       /* compensation off */
    cfg.board.disp_l_pm_per_v = 0;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    TEST_ASSERT_EQUAL_INT32(0, fw_card_disp_n_pm_per_v(&card));
}

static void test_card_block_mean_force_and_flags_are_the_boards(void)
{
    /* the same samples through a bare board: the card's mean is the
     * rounded mean of the board's per-sample forces */
    fw_sample_in_t in[20];
    fw_sample_out_t ob[20];
    fw_board_t b;
    fw_card_out_t out;
    tu_rng_t r;
    int i;
    int k;
    tu_rng_seed(&r, 7);
    for (i = 0; i < 20; i++) {
        in[i].sn_uv = tu_rng_range(&r, -3000000, 3000000);
        in[i].sl_uv = tu_rng_range(&r, -900000, 900000);
        in[i].piezo_pm[0] = i * 1500;
        in[i].piezo_pm[1] = tu_rng_range(&r, -2000, 2000);
        in[i].piezo_pm[2] = 0;
    }
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &card.board.cfg));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b, in, ob, 20));
    default_config();
    cfg.n_particles = 0;   /* no objects: only the signal chain */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = step(in, 20, &pose0);
    for (k = 0; k < 3; k++) {
        double sum = 0.0;
        for (i = 0; i < 20; i++) {
            sum += ob[i].force_pn[k];
        }
        TEST_ASSERT_EQUAL_INT32((int32_t)lround(sum / 20.0), out.force_pn[k]);
        TEST_ASSERT_EQUAL_INT32(ob[19].tip_pm[k], out.tip_pm[k]);
    }
    TEST_ASSERT_EQUAL_INT32(ob[19].sn_code, out.code_n);
    TEST_ASSERT_EQUAL_INT32(ob[19].sl_code, out.code_l);
    TEST_ASSERT_EQUAL_UINT32(fw_board_sticky_flags(&b), out.flags);
    /* an empty block: zero force, the last apex kept, a command */
    out = step(in, 0, &pose0);
    TEST_ASSERT_EQUAL_INT32(0, out.force_pn[2]);
    TEST_ASSERT_EQUAL_INT32(ob[19].tip_pm[0], out.tip_pm[0]);
    TEST_ASSERT_EQUAL_INT32(5000, out.load_pn);
}

static void test_card_step_refuses_null_and_negative_blocks(void)
{
    fw_card_in_t ci;
    fw_card_out_t out;
    ci.samples = NULL;
    ci.n = 1;
    ci.pose = pose0;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_step_block(&card, &ci, &out));
    ci.n = -1;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_step_block(&card, &ci, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_step_block(NULL, &ci, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_step_block(&card, NULL, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_step_block(&card, &ci, NULL));
}

static void test_card_saturated_samples_counted_and_flagged(void)
{
    fw_sample_in_t in[10];
    fw_card_out_t out;
    samples(in, 10, 2000000, 0, 0, 0, 0, 0);
    in[3].sn_uv = 10000000;    /* exactly at the rail */
    in[7].sl_uv = -12000000;
    out = step(in, 10, &pose0);
    TEST_ASSERT_EQUAL_UINT32(2u, out.sat_samples);
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_SN) != 0u);
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_SL) != 0u);
    out = step(in, 10, &pose0);
    TEST_ASSERT_EQUAL_UINT32(4u, out.sat_samples);
    fw_card_reset(&card);
    out = step(in, 2, &pose0);
    TEST_ASSERT_EQUAL_UINT32(0u, out.sat_samples);
}

static void test_card_haptic_force_exactly_at_the_limit_and_one_over(void)
{
    fw_sample_in_t in[20];
    fw_card_out_t out;
    int32_t f;
    samples(in, 20, 1500000, 0, 0, 0, 0, 0);   /* 16 nN pressing */
    cfg.haptic_max_un = INT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = step(in, 20, &pose0);
    f = out.force_pn[2];
    TEST_ASSERT_TRUE(f > 10000);
    TEST_ASSERT_EQUAL_INT32(f * FW_CARD_HAPTIC_UN_PER_PN_DEFAULT, out.haptic_un[2]);
    /* the limit exactly: not clamped; one uN lower: clamped to it */
    cfg.haptic_max_un = f * FW_CARD_HAPTIC_UN_PER_PN_DEFAULT;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = step(in, 20, &pose0);
    TEST_ASSERT_EQUAL_INT32(cfg.haptic_max_un, out.haptic_un[2]);
    cfg.haptic_max_un -= 1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = step(in, 20, &pose0);
    TEST_ASSERT_EQUAL_INT32(cfg.haptic_max_un, out.haptic_un[2]);
    /* sign flips: a pull clamps at the negative limit */
    samples(in, 20, -2000000, 0, 0, 0, 0, 0);
    out = step(in, 20, &pose0);
    TEST_ASSERT_EQUAL_INT32(-cfg.haptic_max_un, out.haptic_un[2]);
    /* gain 0: no feedback at all */
    cfg.haptic_un_per_pn = 0;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = step(in, 20, &pose0);
    TEST_ASSERT_EQUAL_INT32(0, out.haptic_un[2]);
}

static void test_card_command_puts_apex_on_target_and_follows_drift(void)
{
    fw_sample_in_t in[20];
    fw_card_out_t out;
    fw_card_pose_t pose = { { 16384, -8192 }, 5000, true };   /* (0.5, -0.25) of the half range */
    fw_card_fix_out_t fx;
    int32_t scan[2];
    samples(in, 20, 2000000, 300000, 0, 0, 0, 0);
    out = step(in, 20, &pose);
    TEST_ASSERT_EQUAL_INT32(1250000, out.target_pm[0]);
    TEST_ASSERT_EQUAL_INT32(-625000, out.target_pm[1]);
    /* piezo = target - C S (frame A = C at 270 deg), S the block's last signals */
    TEST_ASSERT_INT32_WITHIN(5, 1250000 - (int32_t)lround(23096 * 2.0), out.piezo_cmd_pm[0]);
    TEST_ASSERT_INT32_WITHIN(5, -625000 - (int32_t)lround(23096 * 0.3), out.piezo_cmd_pm[1]);
    TEST_ASSERT_TRUE(out.engaged);
    /* a fix of 40 nm moves the workspace with the sample from the next block */
    scan[0] = particles[1].x_pm + 40000;
    scan[1] = particles[1].y_pm;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_fix(&card, 2, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_APPLIED, fx.result);
    out = step(in, 20, &pose);
    TEST_ASSERT_EQUAL_INT32(1250000 + 40000, out.target_pm[0]);
    /* a joystick past its range is clamped, not refused */
    pose.joy_q15[0] = 40000;
    out = step(in, 20, &pose);
    TEST_ASSERT_EQUAL_INT32(2500000 - 76 + 40000, out.target_pm[0]);
}

/* Random blocks (pushes into particles and a wire, lithography on) and
 * fixes through two cards, one with a scratch of 7 samples (blocks run in
 * pieces): the same outputs and models, bit for bit. Then the first card,
 * reset, and a fresh third card given the same first blocks agree too. */
static fw_card_t c2;
static fw_particle_t parts2[N_PART];
static fw_wire_t wires2[1];
static fw_trench_point_t trench2[TRENCH_CAP];
static fw_sample_out_t scratch2[7];

static void random_block(tu_rng_t *r, int blk, int32_t *y, fw_sample_in_t *in, fw_card_in_t *ci)
{
    int n = tu_rng_range(r, 0, 40);
    int i;
    for (i = 0; i < n; i++) {
        in[i].sn_uv = tu_rng_range(r, -11000000, 11000000);
        in[i].sl_uv = tu_rng_range(r, -400000, 400000);
        in[i].piezo_pm[0] = tu_rng_range(r, -20000, 20000) - 325000 * (blk % 3 == 0);
        in[i].piezo_pm[1] = *y;
        in[i].piezo_pm[2] = tu_rng_range(r, -50000, 50000);
        *y += 400;
    }
    ci->samples = in;
    ci->n = n;
    ci->pose.joy_q15[0] = tu_rng_range(r, -40000, 40000);
    ci->pose.joy_q15[1] = tu_rng_range(r, -40000, 40000);
    ci->pose.load_pn = tu_rng_range(r, 0, 20000);
    ci->pose.engaged = (blk & 1) != 0;
}

static void test_card_is_a_pure_function_of_its_inputs(void)
{
    fw_card_storage_t st2;
    fw_sample_in_t in[40];
    tu_rng_t r;
    int blk;
    int32_t y = -400000;
    default_config();
    wires_on();
    litho_on();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    st2 = st;
    st2.particles = parts2;
    st2.wires = wires2;
    st2.trench = trench2;
    st2.scratch = scratch2;
    st2.scratch_len = 7;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&c2, &cfg, &st2, NULL));
    tu_rng_seed(&r, 99);
    for (blk = 0; blk < 400; blk++) {
        fw_card_in_t ci;
        fw_card_out_t o1;
        fw_card_out_t o2;
        random_block(&r, blk, &y, in, &ci);
        memset(&o1, 0, sizeof o1);
        memset(&o2, 0, sizeof o2);
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_step_block(&card, &ci, &o1));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_step_block(&c2, &ci, &o2));
        TEST_ASSERT_EQUAL_MEMORY(&o1, &o2, sizeof o1);
        if (blk % 50 == 49) {
            int32_t scan[2] = { particles[1].x_pm + tu_rng_range(&r, -150000, 150000), particles[1].y_pm };
            fw_card_fix_out_t f1;
            fw_card_fix_out_t f2;
            memset(&f1, 0, sizeof f1);
            memset(&f2, 0, sizeof f2);
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_fix(&card, 2, scan, &f1));
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_fix(&c2, 2, scan, &f2));
            TEST_ASSERT_EQUAL_MEMORY(&f1, &f2, sizeof f1);
        }
    }
    TEST_ASSERT_EQUAL_MEMORY(part_store, parts2, sizeof parts2);
    TEST_ASSERT_EQUAL_MEMORY(wire_store, wires2, sizeof wires2);
    TEST_ASSERT_EQUAL_INT32(fw_card_litho(&card)->count, fw_card_litho(&c2)->count);
    TEST_ASSERT_TRUE(fw_card_litho(&card)->count > 0);
    TEST_ASSERT_EQUAL_MEMORY(trench_store, trench2, sizeof trench2);
    /* reset against fresh: the same first 100 blocks */
    fw_card_reset(&card);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&c2, &cfg, &st2, NULL));
    tu_rng_seed(&r, 99);
    y = -400000;
    for (blk = 0; blk < 100; blk++) {
        fw_card_in_t ci;
        fw_card_out_t o1;
        fw_card_out_t o2;
        random_block(&r, blk, &y, in, &ci);
        memset(&o1, 0, sizeof o1);
        memset(&o2, 0, sizeof o2);
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_step_block(&card, &ci, &o1));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_step_block(&c2, &ci, &o2));
        TEST_ASSERT_EQUAL_MEMORY(&o1, &o2, sizeof o1);
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_card_init_names_each_rule_it_refuses);
    RUN_TEST(test_card_displacement_estimate_explicit_and_off);
    RUN_TEST(test_card_block_mean_force_and_flags_are_the_boards);
    RUN_TEST(test_card_step_refuses_null_and_negative_blocks);
    RUN_TEST(test_card_saturated_samples_counted_and_flagged);
    RUN_TEST(test_card_haptic_force_exactly_at_the_limit_and_one_over);
    RUN_TEST(test_card_command_puts_apex_on_target_and_follows_drift);
    RUN_TEST(test_card_is_a_pure_function_of_its_inputs);
    return UNITY_END();
}
