/* test_card.c - fw_card: the whole card per block. Init names the rule it
 * refuses; the block's mean force, flags, apex and counters; the command
 * and the hand's force from the pose (the limit exactly and one over);
 * particles and wires pushed through the card, the squeeze flagged; the
 * lithography store full; local-scan fixes (particle, landmark, unknown,
 * exactly at and one pm past the limit); reset; and the card as a pure
 * function (two cards, any split of the blocks, the same outputs). */
#include <string.h>
#include "unity.h"
#include "fw_card.h"
#include "fw_calib.h"
#include "fw_paper_probe.h"
#include "test_util.h"

#define SCRATCH 64
#define N_PART 3
#define TRENCH_CAP 16

static fw_card_particle_t particles[N_PART] = {
    { 1, -1000000, -250000, 50000 },
    { 2, 0, -200000, 50000 },
    { 3, 1000000, -300000, 50000 },
};
static fw_card_landmark_t landmarks[1] = { { 9, 1500000, 1500000 } };
static fw_card_wire_t wires[1] = { { 5, { -650000, 0 }, { 650000, 0 }, 100000 } };

static fw_card_config_t cfg;
static fw_card_storage_t st;
static fw_particle_t part_store[N_PART];
static fw_wire_t wire_store[1];
static fw_trench_point_t trench_store[TRENCH_CAP];
static fw_sample_out_t scratch[SCRATCH];
static fw_card_t card;

/* The default scene's card: the paper's lever at 270 deg, C_n = C_l by the
 * lever's estimate, three particles on glass, one landmark. */
static void default_config(void)
{
    memset(&cfg, 0, sizeof cfg);
    fw_paper_board_config(&cfg.board, 270000);
    cfg.board.disp_n_pm_per_v = FW_CARD_DISP_ESTIMATE;
    cfg.board.disp_l_pm_per_v = FW_CARD_DISP_ESTIMATE;
    cfg.board.adhesion_pn = 1000;
    cfg.tip_radius_pm = 10000;
    cfg.tip_half_angle_mdeg = 20000;
    cfg.particles = particles;
    cfg.n_particles = N_PART;
    cfg.particle_mu_ppm = 300000;
    cfg.particle_adhesion_pn = 3000;
    cfg.wire_friction_pn_per_um = 20000;
    cfg.wire_mu_ppm = 300000;
    cfg.landmarks = landmarks;
    cfg.n_landmarks = 1;
    cfg.landmark_max_step_pm = 2500000;
    cfg.haptic_un_per_pn = FW_CARD_HAPTIC_UN_PER_PN_DEFAULT;
    cfg.haptic_max_un = FW_CARD_HAPTIC_MAX_UN_DEFAULT;
    memset(&st, 0, sizeof st);
    st.particles = part_store;
    st.particle_capacity = N_PART;
    st.wires = wire_store;
    st.wire_capacity = 1;
    st.trench = trench_store;
    st.trench_capacity = TRENCH_CAP;
    st.scratch = scratch;
    st.scratch_len = SCRATCH;
}

void setUp(void)
{
    default_config();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
}
void tearDown(void) {}

static fw_rule_t rule_of(void)
{
    fw_card_t c;
    fw_rule_t r = FW_RULE_OK;
    fw_status_t s = fw_card_init(&c, &cfg, &st, &r);
    TEST_ASSERT_EQUAL_INT(fw_rule_status(r), s);
    return r;
}

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
static void wires_on(void) { cfg.wires = wires; cfg.n_wires = 1; }
static void brk_wire(void) { wires_on(); wires[0].diameter_pm = 2000000; }   /* thicker than long */
static void brk_wire_capacity(void) { wires_on(); st.wire_capacity = 0; }
static void brk_wire_mu(void) { wires_on(); cfg.wire_mu_ppm = 2000000; }
static void brk_gamma(void) { wires_on(); cfg.tip_half_angle_mdeg = 60000; }
static void litho_on(void)
{
    cfg.litho = true;
    cfg.litho_threshold_pn = 20000;
    cfg.litho_depth_pm_per_pn = FW_Q16_ONE;
}
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

/* n samples: S_n, S_l (uV) constant, the piezo moving from p0 by dp per sample */
static void samples(fw_sample_in_t *in, int n, int32_t sn_uv, int32_t sl_uv, int32_t x0, int32_t y0, int32_t dx,
                    int32_t dy)
{
    int i;
    for (i = 0; i < n; i++) {
        in[i].sn_uv = sn_uv;
        in[i].sl_uv = sl_uv;
        in[i].piezo_pm[0] = x0 + i * dx;
        in[i].piezo_pm[1] = y0 + i * dy;
        in[i].piezo_pm[2] = 0;
    }
}

static fw_card_out_t step(const fw_sample_in_t *in, int n, const fw_card_pose_t *pose)
{
    fw_card_in_t ci;
    fw_card_out_t out;
    ci.samples = in;
    ci.n = n;
    ci.pose = *pose;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_step_block(&card, &ci, &out));
    return out;
}

static const fw_card_pose_t pose0 = { { 0, 0 }, 5000, true };

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

static void test_card_pushes_a_particle_and_raises_contact(void)
{
    /* the apex walks up +y into particle 2 (at y = -200 nm) with a lateral
     * force of 2 nN against the motion: its excess over the tip's friction
     * beats half the particle's 0.9 nN threshold */
    fw_sample_in_t in[20];
    fw_card_out_t out;
    const fw_particle_t *p;
    int32_t blk;
    int32_t y = -320000;
    uint32_t flags = 0;
    for (blk = 0; blk < 10; blk++) {
        samples(in, 20, 0, -52770, 0, y, 0, 500);
        out = step(in, 20, &pose0);
        flags |= out.flags;
        y += 20 * 500;
    }
    p = fw_particles_get(fw_card_particles(&card), 1);
    TEST_ASSERT_TRUE((flags & FW_FLAG_CONTACT) != 0u);
    /* it sits r_tip + r_p ahead of the apex along +y */
    TEST_ASSERT_INT32_WITHIN(1000, 0, p->x_pm);
    TEST_ASSERT_INT32_WITHIN(2000, out.tip_pm[1] + 60000, p->y_pm);
    /* the others did not move */
    TEST_ASSERT_EQUAL_INT32(-250000, fw_particles_get(fw_card_particles(&card), 0)->y_pm);
}

static void wire_config(int32_t gamma_mdeg, int32_t mu_ppm)
{
    default_config();
    cfg.n_particles = 0;
    cfg.wires = wires;
    cfg.n_wires = 1;
    cfg.tip_half_angle_mdeg = gamma_mdeg;
    cfg.wire_mu_ppm = mu_ppm;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
}

/* The apex walks +y into the rod at x = L/4 from end A (l = L/4 - ...),
 * with a lateral force of f_pn against the motion; returns the OR of the
 * flags. */
static uint32_t push_wire(int32_t sl_uv)
{
    fw_sample_in_t in[20];
    fw_card_out_t out;
    int32_t blk;
    int32_t y = -120000;
    uint32_t flags = 0;
    for (blk = 0; blk < 8; blk++) {
        samples(in, 20, 0, sl_uv, -325000, y, 0, 500);
        out = step(in, 20, &pose0);
        flags |= out.flags;
        y += 20 * 500;
    }
    return flags;
}

static void test_card_pushes_a_wire_above_half_its_minimum_push(void)
{
    /* k(L/4) f L = 0.618 20 nN/um 1.3 um = 16.1 nN; half is 8.0 nN */
    uint32_t flags;
    wire_config(20000, 300000);
    flags = push_wire(-(int32_t)lround(6.0e6 / 37.9));     /* 6 nN: below half */
    TEST_ASSERT_EQUAL_UINT32(0u, flags & (FW_FLAG_CONTACT | FW_FLAG_SQUEEZE));
    TEST_ASSERT_EQUAL_INT32(0, fw_card_wire(&card, 0)->y_pm);
    wire_config(20000, 300000);
    flags = push_wire(-(int32_t)lround(10.0e6 / 37.9));    /* 10 nN: pushed */
    TEST_ASSERT_TRUE((flags & FW_FLAG_CONTACT) != 0u);
    TEST_ASSERT_EQUAL_UINT32(0u, flags & FW_FLAG_SQUEEZE);
    TEST_ASSERT_TRUE(fw_card_wire(&card, 0)->y_pm > 0);
    TEST_ASSERT_EQUAL_INT32(5, fw_card_wire_id(&card, 0));
    TEST_ASSERT_EQUAL_INT32(0, fw_card_wire_id(&card, 1));
    TEST_ASSERT_NULL(fw_card_wire(&card, 1));
}

static void test_card_squeeze_flagged_past_psi_max_and_the_wire_stays(void)
{
    /* gamma 59 deg, wire mu 1.9: psi_max = atan(1 / (0.618 1.9)) = 40 deg */
    uint32_t flags;
    wire_config(59000, 1900000);
    cfg.down_force = true;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    flags = push_wire(-(int32_t)lround(10.0e6 / 37.9));
    TEST_ASSERT_TRUE((flags & FW_FLAG_SQUEEZE) != 0u);
    TEST_ASSERT_EQUAL_UINT32(0u, flags & FW_FLAG_CONTACT);
    TEST_ASSERT_EQUAL_INT32(0, fw_card_wire(&card, 0)->y_pm);
    TEST_ASSERT_TRUE((fw_card_wire(&card, 0)->flags & FW_WIRE_SQUEEZED) != 0u);
}

static void test_card_lithography_store_full_flags_position(void)
{
    fw_sample_in_t in[20];
    fw_card_out_t out;
    int32_t blk;
    uint32_t flags = 0;
    default_config();
    cfg.litho = true;
    cfg.litho_threshold_pn = 20000;
    cfg.litho_depth_pm_per_pn = 2 * FW_Q16_ONE;
    st.trench_capacity = 4;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    /* 32 nN pressing while the apex moves 1 nm per sample: a point per 5 nm */
    for (blk = 0; blk < 3; blk++) {
        samples(in, 20, 3000000, 0, 2000000 + blk * 20000, 0, 1000, 0);
        out = step(in, 20, &pose0);
        flags |= out.flags;
    }
    TEST_ASSERT_EQUAL_INT32(4, fw_card_litho(&card)->count);
    TEST_ASSERT_TRUE(fw_card_litho(&card)->overflow);
    TEST_ASSERT_TRUE((flags & FW_FLAG_SAT_POS) != 0u);
    /* depth = 2 pm/pN (F_z - 20 nN), F_z between N = 32.04 nN and N plus
     * the fallback's (2h/l) mu (N + F_adh) = 33.06 nN */
    TEST_ASSERT_TRUE(fw_card_litho(&card)->pts[1].depth_pm >= 2 * (32040 - 20000));
    TEST_ASSERT_TRUE(fw_card_litho(&card)->pts[1].depth_pm <= 2 * (33100 - 20000));
    fw_card_reset(&card);
    TEST_ASSERT_EQUAL_INT32(0, fw_card_litho(&card)->count);
    default_config();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    TEST_ASSERT_NULL(fw_card_litho(&card));
}

static void test_card_fix_particle_landmark_unknown_and_the_limits(void)
{
    fw_card_fix_out_t fx;
    int32_t scan[2];
    int32_t d[2];
    /* exactly the drift limit (200 nm): applied, every model moves */
    scan[0] = particles[0].x_pm + FW_DRIFT_MAX_STEP_DEFAULT_PM;
    scan[1] = particles[0].y_pm;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_fix(&card, 1, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_APPLIED, fx.result);
    TEST_ASSERT_FALSE(fx.landmark);
    TEST_ASSERT_EQUAL_INT32(FW_DRIFT_MAX_STEP_DEFAULT_PM, fx.delta_pm[0]);
    TEST_ASSERT_EQUAL_INT32(particles[2].x_pm + FW_DRIFT_MAX_STEP_DEFAULT_PM,
                            fw_particles_get(fw_card_particles(&card), 2)->x_pm);
    fw_card_drift_pm(&card, d);
    TEST_ASSERT_EQUAL_INT32(FW_DRIFT_MAX_STEP_DEFAULT_PM, d[0]);
    /* one pm past it: refused, nothing moves */
    scan[0] = fw_particles_get(fw_card_particles(&card), 0)->x_pm;
    scan[1] = fw_particles_get(fw_card_particles(&card), 0)->y_pm + FW_DRIFT_MAX_STEP_DEFAULT_PM + 1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_fix(&card, 1, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_NOT_DRIFT, fx.result);
    TEST_ASSERT_EQUAL_INT32(0, fx.delta_pm[1]);
    fw_card_drift_pm(&card, d);
    TEST_ASSERT_EQUAL_INT32(0, d[1]);
    /* a landmark 1 um off (a lever change): its own limit, 2.5 um */
    scan[0] = landmarks[0].x_pm + FW_DRIFT_MAX_STEP_DEFAULT_PM - 1000000;
    scan[1] = landmarks[0].y_pm;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_fix(&card, 9, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_APPLIED, fx.result);
    TEST_ASSERT_TRUE(fx.landmark);
    /* its model carried the drift so far */
    TEST_ASSERT_EQUAL_INT32(landmarks[0].x_pm + FW_DRIFT_MAX_STEP_DEFAULT_PM, fx.model_pm[0]);
    fw_card_drift_pm(&card, d);
    TEST_ASSERT_EQUAL_INT32(FW_DRIFT_MAX_STEP_DEFAULT_PM - 1000000, d[0]);
    /* an id nobody has */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_fix(&card, 77, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_UNKNOWN_OBJECT, fx.result);
    TEST_ASSERT_EQUAL_UINT32(2u, fw_card_fixes_applied(&card));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_fix(&card, 1, NULL, &fx));
    /* reset: the models back where configured, no drift */
    fw_card_reset(&card);
    fw_card_drift_pm(&card, d);
    TEST_ASSERT_EQUAL_INT32(0, d[0]);
    TEST_ASSERT_EQUAL_INT32(particles[2].x_pm, fw_particles_get(fw_card_particles(&card), 2)->x_pm);
    TEST_ASSERT_EQUAL_UINT32(0u, fw_card_fixes_applied(&card));
}

/* A lifted tip touches nothing: the apex walks into particle 2 within the
 * first block (from y = -262 nm, contact at -260 nm) with a pushing force.
 * With start_lifted the first block is taken lifted and nothing moves,
 * while a card started down pushes it in the same block; lifted poses keep
 * every later block lifted; the block after an engaged pose pushes again. */
static void test_card_lifted_tip_pushes_nothing(void)
{
    static const fw_card_pose_t lifted = { { 0, 0 }, 5000, false };
    fw_sample_in_t in[20];
    int32_t blk;
    int32_t y;
    /* started down: block 0 pushes */
    samples(in, 20, 0, -52770, 0, -262000, 0, 500);
    (void)step(in, 20, &lifted);
    TEST_ASSERT_TRUE(fw_particles_get(fw_card_particles(&card), 1)->y_pm > particles[1].y_pm);
    /* started lifted: block 0 and the lifted blocks after it push nothing */
    default_config();
    cfg.start_lifted = true;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    y = -262000;
    for (blk = 0; blk < 10; blk++) {
        samples(in, 20, 0, -52770, 0, y, 0, 500);
        (void)step(in, 20, &lifted);
        y += 20 * 500;
    }
    TEST_ASSERT_EQUAL_INT32(particles[1].y_pm, fw_particles_get(fw_card_particles(&card), 1)->y_pm);
    /* engaged from here: the block after the engaged pose pushes */
    y = -262000;
    samples(in, 20, 0, -52770, 0, y, 0, 500);
    (void)step(in, 20, &pose0);   /* taken lifted (the pose before was lifted) */
    TEST_ASSERT_EQUAL_INT32(particles[1].y_pm, fw_particles_get(fw_card_particles(&card), 1)->y_pm);
    samples(in, 20, 0, -52770, 0, y, 0, 500);
    (void)step(in, 20, &pose0);
    TEST_ASSERT_TRUE(fw_particles_get(fw_card_particles(&card), 1)->y_pm > particles[1].y_pm);
}

/* A place fix moves one particle's model, within the drift limit; the
 * drift and the others stay; a landmark or an unknown id is not placed. */
static void test_card_place_moves_one_model_within_the_limit(void)
{
    fw_card_fix_out_t fx;
    int32_t scan[2];
    int32_t d[2];
    scan[0] = particles[1].x_pm + 30000;
    scan[1] = particles[1].y_pm - FW_DRIFT_MAX_STEP_DEFAULT_PM + 30000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_place(&card, 2, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_APPLIED, fx.result);
    TEST_ASSERT_EQUAL_INT32(scan[0], fw_particles_get(fw_card_particles(&card), 1)->x_pm);
    TEST_ASSERT_EQUAL_INT32(scan[1], fw_particles_get(fw_card_particles(&card), 1)->y_pm);
    TEST_ASSERT_EQUAL_INT32(particles[0].x_pm, fw_particles_get(fw_card_particles(&card), 0)->x_pm);
    fw_card_drift_pm(&card, d);
    TEST_ASSERT_EQUAL_INT32(0, d[0]);
    TEST_ASSERT_EQUAL_INT32(0, d[1]);
    /* one pm past the limit (diagonal, in 64 bits): refused, nothing moves */
    scan[0] = particles[0].x_pm + 141422;
    scan[1] = particles[0].y_pm + 141422;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_place(&card, 1, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_NOT_DRIFT, fx.result);
    TEST_ASSERT_EQUAL_INT32(particles[0].x_pm, fw_particles_get(fw_card_particles(&card), 0)->x_pm);
    /* the far corners of int32: no overflow, refused */
    scan[0] = INT32_MAX;
    scan[1] = INT32_MIN;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_place(&card, 1, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_NOT_DRIFT, fx.result);
    /* a landmark (id 9) is registered by drift, not placed; unknown ids */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_place(&card, 9, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_UNKNOWN_OBJECT, fx.result);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_place(&card, 77, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_CARD_FIX_UNKNOWN_OBJECT, fx.result);
    TEST_ASSERT_EQUAL_UINT32(1u, fw_card_fixes_applied(&card));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_place(&card, 1, NULL, &fx));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_place(NULL, 1, scan, &fx));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_card_place(&card, 1, scan, NULL));
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

/* A rod shorter than four pm (the push's step L/4 rounds to 0) is refused
 * below its diameter; a rod of exactly its diameter pushed hard moves in at
 * most FW_WIRE_PUSH_STEPS_MAX steps per sample and never hangs. */
static void test_card_tiny_rod_refused_or_bounded(void)
{
    static fw_card_wire_t tiny[1] = { { 7, { 0, 0 }, { 3, 0 }, 3 } };
    fw_sample_in_t in[4];
    fw_card_out_t out;
    default_config();
    cfg.n_particles = 0;
    cfg.wires = tiny;
    cfg.n_wires = 1;
    tiny[0].diameter_pm = 4;
    TEST_ASSERT_EQUAL_INT(FW_RULE_WIRE, rule_of());
    tiny[0].diameter_pm = 3;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    samples(in, 4, 0, -2000000, 0, -5000, 0, 1000);   /* 76 nN lateral, across the rod */
    out = step(in, 4, &pose0);
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_FORCE) == 0u);
    TEST_ASSERT_NOT_NULL(fw_card_wire(&card, 0));
}

/* FW_FLAG_BLIND_PUSH: the apex run along the lever's axis (F_x
 * unobservable) through particle 2's model, the signals showing no push:
 * flagged while the tip is engaged; the same path with the tip lifted
 * (the previous block's pose not engaged) is not a push at all. */
static uint32_t blind_run(bool engaged)
{
    fw_sample_in_t in[20];
    fw_card_pose_t pose = pose0;
    fw_card_out_t out;
    q30_t axis[2];
    uint32_t seen = 0;
    int b;
    default_config();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    fw_board_lever_axis_q30(cfg.board.scan_angle_mdeg, axis);
    pose.engaged = engaged;
    /* 12 blocks of 20 samples, 1 nm a sample along the axis, from 120 nm before
     * particle 2's centre (0, -200 nm) to 120 nm past it */
    for (b = 0; b < 12; b++) {
        int32_t d0 = -120000 + b * 20000;
        samples(in, 20, 300000, 0, (int32_t)(((int64_t)d0 * axis[0]) >> 30), -200000 + (int32_t)(((int64_t)d0 * axis[1]) >> 30),
                (int32_t)((1000 * (int64_t)axis[0]) >> 30), (int32_t)((1000 * (int64_t)axis[1]) >> 30));
        out = step(in, 20, &pose);
        seen |= out.flags;
    }
    TEST_ASSERT_TRUE((seen & FW_FLAG_FX_UNOBSERVABLE) != 0u);   /* the path runs along the axis */
    return seen & FW_FLAG_BLIND_PUSH;
}

static void test_card_blind_push_needs_the_tip_down(void)
{
    TEST_ASSERT_EQUAL_UINT32(FW_FLAG_BLIND_PUSH, blind_run(true));
    TEST_ASSERT_EQUAL_UINT32(0u, blind_run(false));
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
    RUN_TEST(test_card_pushes_a_particle_and_raises_contact);
    RUN_TEST(test_card_pushes_a_wire_above_half_its_minimum_push);
    RUN_TEST(test_card_squeeze_flagged_past_psi_max_and_the_wire_stays);
    RUN_TEST(test_card_lithography_store_full_flags_position);
    RUN_TEST(test_card_fix_particle_landmark_unknown_and_the_limits);
    RUN_TEST(test_card_lifted_tip_pushes_nothing);
    RUN_TEST(test_card_place_moves_one_model_within_the_limit);
    RUN_TEST(test_card_is_a_pure_function_of_its_inputs);
    RUN_TEST(test_card_tiny_rod_refused_or_bounded);
    RUN_TEST(test_card_blind_push_needs_the_tip_down);
    return UNITY_END();
}
