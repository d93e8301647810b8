/* card_util.h - what the card's tests share (test_card.c,
 * test_card_objects.c): the default scene's card (three particles on glass,
 * a landmark, a rod, a trench store), the rule a configuration breaks, the
 * wires and the lithography switched on, a block of samples and its step. */
#ifndef CARD_UTIL_H
#define CARD_UTIL_H

#include <string.h>
#include "unity.h"
#include "fw_card.h"
#include "fw_paper_probe.h"

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
static inline void default_config(void)
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

static inline fw_rule_t rule_of(void)
{
    fw_card_t c;
    fw_rule_t r = FW_RULE_OK;
    fw_status_t s = fw_card_init(&c, &cfg, &st, &r);
    TEST_ASSERT_EQUAL_INT(fw_rule_status(r), s);
    return r;
}

static inline void wires_on(void) { cfg.wires = wires; cfg.n_wires = 1; }
static inline void litho_on(void)
{
    cfg.litho = true;
    cfg.litho_threshold_pn = 20000;
    cfg.litho_depth_pm_per_pn = FW_Q16_ONE;
}

/* n samples: S_n, S_l (uV) constant, the piezo moving from p0 by dp per sample */
static inline void samples(fw_sample_in_t *in, int n, int32_t sn_uv, int32_t sl_uv, int32_t x0, int32_t y0, int32_t dx,
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

static inline fw_card_out_t step(const fw_sample_in_t *in, int n, const fw_card_pose_t *pose)
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

#endif
