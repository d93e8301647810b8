/* test_guard_card.c - the force interlock (fw_guard) through the card:
 * the limits the card refuses outside its channels; the trip exactly at and
 * one pN past a limit set from the card's own measured force; one sample
 * over in a block; the lateral channel alone and a saturated sample; the
 * retract, the flag and no object model while retracted, the release past
 * the hysteresis and by the joystick's move, a trip again; the interlock
 * off. The guard alone: test_guard.c. */
#include <string.h>
#include "unity.h"
#include "fw_guard.h"
#include "fw_card.h"
#include "fw_paper_probe.h"
#include "test_util.h"

#define LIM_N 85440     /* the paper's lever: 80 % of 10680 pN/V x 10 V */
#define LIM_L 303200    /* 80 % of 37900 pN/V x 10 V */
#define HYST (LIM_N >> FW_GUARD_HYST_SHIFT)

void setUp(void) {}
void tearDown(void) {}

/* ---- through the card ------------------------------------------------ */

#define SCRATCH 32
static fw_card_particle_t particles[1] = { { 1, 0, 200000, 50000 } };
static fw_card_config_t cfg;
static fw_card_storage_t st;
static fw_particle_t part_store[1];
static fw_sample_out_t scratch[SCRATCH];
static fw_card_t card;

static void card_config(bool interlock)
{
    memset(&cfg, 0, sizeof cfg);
    fw_paper_board_config(&cfg.board, 270000);
    cfg.tip_radius_pm = 10000;
    cfg.tip_half_angle_mdeg = 20000;
    cfg.particles = particles;
    cfg.n_particles = 1;
    cfg.particle_mu_ppm = 300000;
    cfg.particle_adhesion_pn = 3000;
    cfg.haptic_un_per_pn = FW_CARD_HAPTIC_UN_PER_PN_DEFAULT;
    cfg.haptic_max_un = FW_CARD_HAPTIC_MAX_UN_DEFAULT;
    cfg.interlock = interlock;
    cfg.interlock_normal_pn = LIM_N;
    cfg.interlock_lateral_pn = LIM_L;
    memset(&st, 0, sizeof st);
    st.particles = part_store;
    st.particle_capacity = 1;
    st.scratch = scratch;
    st.scratch_len = SCRATCH;
}

static fw_rule_t card_rule(void)
{
    fw_card_t c;
    fw_rule_t r = FW_RULE_OK;
    fw_status_t s = fw_card_init(&c, &cfg, &st, &r);
    TEST_ASSERT_EQUAL_INT(fw_rule_status(r), s);
    return r;
}

/* n samples at S_n, S_l (uV), the piezo still at (x, y) */
static void fill(fw_sample_in_t *in, int n, int32_t sn_uv, int32_t sl_uv, int32_t x, int32_t y)
{
    int i;
    for (i = 0; i < n; i++) {
        in[i].sn_uv = sn_uv;
        in[i].sl_uv = sl_uv;
        in[i].piezo_pm[0] = x;
        in[i].piezo_pm[1] = y;
        in[i].piezo_pm[2] = 0;
    }
}

static fw_card_out_t card_step(const fw_sample_in_t *in, int n, int32_t load_pn, int32_t joy_x_q15, bool engaged)
{
    fw_card_in_t ci;
    fw_card_out_t out;
    ci.samples = in;
    ci.n = n;
    ci.pose.joy_q15[0] = joy_x_q15;
    ci.pose.joy_q15[1] = 0;
    ci.pose.load_pn = load_pn;
    ci.pose.engaged = engaged;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_step_block(&card, &ci, &out));
    return out;
}

static void test_card_refuses_interlock_limits_outside_its_channels(void)
{
    card_config(true);
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, card_rule());
    cfg.interlock_normal_pn = 0;
    TEST_ASSERT_EQUAL_INT(FW_RULE_INTERLOCK_NORMAL, card_rule());
    cfg.interlock_normal_pn = 106800;   /* k_n K_n 10 V */
    TEST_ASSERT_EQUAL_INT(FW_RULE_INTERLOCK_NORMAL, card_rule());
    cfg.interlock_normal_pn = 106799;
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, card_rule());
    cfg.interlock_lateral_pn = -1;
    TEST_ASSERT_EQUAL_INT(FW_RULE_INTERLOCK_LATERAL, card_rule());
    cfg.interlock_lateral_pn = 379000;
    TEST_ASSERT_EQUAL_INT(FW_RULE_INTERLOCK_LATERAL, card_rule());
    /* the lateral gain the card runs with: a calibrated one moves the bound */
    cfg.board.lateral_gain_pn_per_v = 40000;
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, card_rule());
    /* off: the limits are not looked at */
    card_config(false);
    cfg.interlock_normal_pn = 0;
    cfg.interlock_lateral_pn = INT32_MIN;
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, card_rule());
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    TEST_ASSERT_NULL(fw_card_guard(&card));
    TEST_ASSERT_TRUE(strlen(fw_rule_text(FW_RULE_INTERLOCK_NORMAL)) > 10);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_rule_status(FW_RULE_INTERLOCK_LATERAL));
}

/* The force the card measures for a still tip at S_n (one sample through
 * a bare board with the card's configuration). */
static int32_t measured_fz(int32_t sn_uv)
{
    fw_board_t b;
    fw_sample_in_t in;
    fw_sample_out_t o;
    fill(&in, 1, sn_uv, 0, 0, 0);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &card.board.cfg));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &o));
    return o.force_pn[2];
}

static void test_card_trips_one_pn_over_its_own_measured_force_not_at_it(void)
{
    fw_sample_in_t in[20];
    fw_card_out_t out;
    int32_t f;
    card_config(true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    f = measured_fz(7000000);   /* 7 V: about 74.8 nN */
    TEST_ASSERT_TRUE(f > 70000 && f < LIM_N);
    fill(in, 20, 7000000, 0, 0, 0);
    /* the limit exactly at the force: no trip */
    cfg.interlock_normal_pn = f;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = card_step(in, 20, 70000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, out.interlock);
    TEST_ASSERT_TRUE(out.engaged);
    TEST_ASSERT_EQUAL_UINT32(0u, out.flags & FW_FLAG_INTERLOCK);
    /* one pN lower: the force is one LSB over it */
    cfg.interlock_normal_pn = f - 1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = card_step(in, 20, 70000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    TEST_ASSERT_FALSE(out.engaged);
    TEST_ASSERT_EQUAL_UINT32(FW_FLAG_INTERLOCK, out.flags & FW_FLAG_INTERLOCK);
    TEST_ASSERT_EQUAL_INT32(70000, out.load_pn);   /* the load passed on; the tip retracted */
    /* the sign flipped (the lever pulled down as hard): the limit at -F
     * holds, one pN below -F trips */
    f = measured_fz(-7000000);
    TEST_ASSERT_TRUE(f < -70000);
    fill(in, 20, -7000000, 0, 0, 0);
    cfg.interlock_normal_pn = -f;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = card_step(in, 20, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, out.interlock);
    cfg.interlock_normal_pn = -f - 1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = card_step(in, 20, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
}

static void test_card_one_sample_over_in_a_block_trips_it(void)
{
    fw_sample_in_t in[20];
    fw_card_out_t out;
    card_config(true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    fill(in, 20, 500000, 0, 0, 0);
    in[13].sn_uv = 8500000;   /* one sample at about 90.8 nN; the block's mean stays far below */
    out = card_step(in, 20, 5000, 0, true);
    TEST_ASSERT_TRUE(out.force_pn[2] < LIM_N);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    /* the last sample of a block, and a block longer than the scratch */
    {
        static fw_sample_in_t big[3 * SCRATCH + 5];
        fill(big, 3 * SCRATCH + 5, 500000, 0, 0, 0);
        big[3 * SCRATCH + 4].sn_uv = 8500000;
        fw_card_reset(&card);
        out = card_step(big, 3 * SCRATCH + 4, 5000, 0, true);
        TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, out.interlock);
        out = card_step(big, 3 * SCRATCH + 5, 5000, 0, true);
        TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    }
}

static void test_card_lateral_channel_alone_and_saturation_trip(void)
{
    fw_sample_in_t in[10];
    fw_card_out_t out;
    int32_t fy;
    card_config(true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    /* S_l 8 V (code 26214): F_y = 303195 pN, the card's own value; S_n
     * small all along. The limit at F_y holds, one pN below trips. */
    fy = fw_guard_lateral_pn(FW_PAPER_LATERAL_GAIN_PN_PER_V,
                             fw_acq_signal_of_code_q23(&card.board.acq_sl, fw_acq_quantize_code(16, 8000000, NULL)));
    TEST_ASSERT_INT32_WITHIN(1, 303195, fy);
    fill(in, 10, 300000, 8000000, 0, 0);
    cfg.interlock_lateral_pn = fy;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    out = card_step(in, 10, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, out.interlock);
    in[4].sl_uv = 8000306;    /* one code (305.2 uV, 11.6 pN) up, one sample */
    out = card_step(in, 10, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_LATERAL, fw_card_guard(&card)->causes);
    cfg.interlock_lateral_pn = fy - 1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    fill(in, 10, 300000, 8000000, 0, 0);
    out = card_step(in, 10, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_LATERAL, fw_card_guard(&card)->causes);
    cfg.interlock_lateral_pn = LIM_L;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    /* the other sign */
    fw_card_reset(&card);
    fill(in, 10, 300000, -8000306, 0, 0);
    out = card_step(in, 10, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    /* a saturated ADC sample: over, whatever it reads */
    fw_card_reset(&card);
    fill(in, 10, 300000, 0, 0, 0);
    in[9].sn_uv = 10000000;   /* at the rail */
    out = card_step(in, 10, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_NORMAL, fw_card_guard(&card)->causes);
    fw_card_reset(&card);
    fill(in, 10, 300000, 0, 0, 0);
    in[0].sl_uv = -10000000;
    out = card_step(in, 10, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_LATERAL, fw_card_guard(&card)->causes);
}

static void test_card_holds_retracted_releases_past_the_hysteresis_and_trips_again(void)
{
    fw_sample_in_t in[20];
    fw_sample_in_t off[20];
    fw_card_out_t out;
    int i;
    card_config(true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    fill(in, 20, 8500000, 0, 0, 0);   /* pressing past the limit */
    fill(off, 20, 0, 0, 0, 0);        /* retracted: no force */
    out = card_step(in, 20, 120000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    for (i = 0; i < 50; i++) {
        out = card_step(off, 20, 120000, (int32_t)(i * 100), true);   /* the load stays; xy moves: a normal trip holds */
        TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, out.interlock);
        TEST_ASSERT_FALSE(out.engaged);
        TEST_ASSERT_EQUAL_UINT32(FW_FLAG_INTERLOCK, out.flags & FW_FLAG_INTERLOCK);
        TEST_ASSERT_FALSE(card.down);   /* no object model runs on a retracted tip */
    }
    out = card_step(off, 20, LIM_N - HYST, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, out.interlock);
    out = card_step(off, 20, LIM_N - HYST - 1, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, out.interlock);
    TEST_ASSERT_TRUE(out.engaged);
    TEST_ASSERT_EQUAL_UINT32(0u, out.flags & FW_FLAG_INTERLOCK);
    TEST_ASSERT_TRUE(card.down);
    out = card_step(off, 20, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, out.interlock);
    out = card_step(in, 20, 120000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    TEST_ASSERT_EQUAL_UINT32(2u, fw_card_guard(&card)->trips);
    /* the operator lifts the tip: released (and lifted as asked) */
    out = card_step(off, 20, 120000, 0, false);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, out.interlock);
    TEST_ASSERT_FALSE(out.engaged);
    TEST_ASSERT_EQUAL_UINT32(0u, out.flags & FW_FLAG_INTERLOCK);
    /* reset: unlatched, no trips */
    out = card_step(in, 20, 120000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    fw_card_reset(&card);
    TEST_ASSERT_FALSE(fw_card_guard(&card)->latched);
    TEST_ASSERT_EQUAL_UINT32(0u, fw_card_guard(&card)->trips);
    out = card_step(off, 20, 120000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, out.interlock);
    TEST_ASSERT_TRUE(out.engaged);
}

static void test_card_lateral_trip_releases_when_the_joystick_moves_50_nm(void)
{
    /* the joystick's target: kappa r_scan joy = 2.5 um x joy (1.15); 50 nm
     * is joy = 0.02 = 655.36 LSB: 655 LSB (49.98 nm) holds, 656 (50.05 nm)
     * releases */
    fw_sample_in_t in[10];
    fw_sample_in_t off[10];
    fw_card_out_t out;
    card_config(true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    fill(in, 10, 300000, 9000000, 0, 0);
    fill(off, 10, 0, 0, 0, 0);
    out = card_step(in, 10, 5000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, out.interlock);
    out = card_step(off, 10, 5000, 655, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, out.interlock);
    out = card_step(off, 10, 5000, -656, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, out.interlock);
    TEST_ASSERT_TRUE(out.engaged);
}

static void test_card_without_the_interlock_never_retracts(void)
{
    fw_sample_in_t in[20];
    fw_card_out_t out;
    card_config(false);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_card_init(&card, &cfg, &st, NULL));
    fill(in, 20, 12000000, -12000000, 0, 0);   /* both rails */
    out = card_step(in, 20, 200000, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, out.interlock);
    TEST_ASSERT_TRUE(out.engaged);
    TEST_ASSERT_EQUAL_UINT32(0u, out.flags & FW_FLAG_INTERLOCK);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_card_refuses_interlock_limits_outside_its_channels);
    RUN_TEST(test_card_trips_one_pn_over_its_own_measured_force_not_at_it);
    RUN_TEST(test_card_one_sample_over_in_a_block_trips_it);
    RUN_TEST(test_card_lateral_channel_alone_and_saturation_trip);
    RUN_TEST(test_card_holds_retracted_releases_past_the_hysteresis_and_trips_again);
    RUN_TEST(test_card_lateral_trip_releases_when_the_joystick_moves_50_nm);
    RUN_TEST(test_card_without_the_interlock_never_retracts);
    return UNITY_END();
}
