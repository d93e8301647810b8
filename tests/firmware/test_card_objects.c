/* test_card_objects.c - fw_card's objects through the card: particles and
 * wires pushed, the squeeze flagged; the lithography store full; local-scan
 * fixes (particle, landmark, unknown, exactly at and one pm past the
 * limit) and places; a lifted tip pushes nothing, nor a blind push without
 * the tip down; a tiny rod refused or bounded. The card itself:
 * test_card.c. */
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
    RUN_TEST(test_card_pushes_a_particle_and_raises_contact);
    RUN_TEST(test_card_pushes_a_wire_above_half_its_minimum_push);
    RUN_TEST(test_card_squeeze_flagged_past_psi_max_and_the_wire_stays);
    RUN_TEST(test_card_lithography_store_full_flags_position);
    RUN_TEST(test_card_fix_particle_landmark_unknown_and_the_limits);
    RUN_TEST(test_card_lifted_tip_pushes_nothing);
    RUN_TEST(test_card_place_moves_one_model_within_the_limit);
    RUN_TEST(test_card_tiny_rod_refused_or_bounded);
    RUN_TEST(test_card_blind_push_needs_the_tip_down);
    return UNITY_END();
}
