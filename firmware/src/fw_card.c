/*
 * fw_card.c - see fw_card.h.
 */
#include "fw_card.h"
#include "fw_calib.h"
#include "fw_math.h"

/* The displacement constants the board is given: the lever's estimate
 * where the configuration asks for it. Returns the estimate's status (only
 * when one is asked for). */
static fw_status_t card_board_config(const fw_card_config_t *cfg, fw_board_config_t *board)
{
    int32_t est = 0;
    fw_status_t st = FW_OK;
    *board = cfg->board;
    if (board->disp_n_pm_per_v == FW_CARD_DISP_ESTIMATE || board->disp_l_pm_per_v == FW_CARD_DISP_ESTIMATE) {
        st = fw_calib_disp_estimate(board->tip_height_nm, board->lever_length_nm, board->deflection_pm_per_v, &est);
    }
    if (board->disp_n_pm_per_v == FW_CARD_DISP_ESTIMATE) {
        board->disp_n_pm_per_v = est;
    }
    if (board->disp_l_pm_per_v == FW_CARD_DISP_ESTIMATE) {
        board->disp_l_pm_per_v = est;
    }
    return st;
}

/* Every particle's push threshold (section 5): F_down = 0, or with the
 * cone's down force at psi = gamma (the lever's twist, mrad, neglected:
 * the threshold is fixed at init; the simulator adds the twist, so ./afm
 * paper squeeze's particle rows measure the neglect). Scaling: fw_particles_threshold_pn,
 * fw_particles_down_threshold_pn (saturated). */
static int32_t card_particle_threshold_pn(const fw_card_config_t *cfg)
{
    int32_t th = fw_particles_threshold_pn(cfg->particle_mu_ppm, cfg->particle_adhesion_pn, 0,
                                           cfg->particle_shear_kpa, cfg->particle_contact_area_nm2);
    return cfg->down_force ? fw_particles_down_threshold_pn(th, cfg->particle_mu_ppm,
                                                            fw_math_bam_from_mdeg(cfg->tip_half_angle_mdeg))
                           : th;
}

static fw_rule_t card_check_particles(const fw_card_config_t *cfg, const fw_card_storage_t *st)
{
    int32_t i;
    fw_rule_t rule = fw_particles_check(cfg->tip_radius_pm);
    int32_t th = card_particle_threshold_pn(cfg);
    if (rule != FW_RULE_OK) {
        return rule;
    }
    if (cfg->n_particles < 0 || cfg->particle_margin_pn < 0) {
        return FW_RULE_PARTICLE;
    }
    if (cfg->n_particles > 0 && cfg->particles == NULL) {
        return FW_RULE_NULL_POINTER;
    }
    if (cfg->particle_mu_ppm < 0 || cfg->particle_mu_ppm > FW_PPM_PER_ONE || cfg->particle_adhesion_pn < 0
        || cfg->particle_shear_kpa < 0 || cfg->particle_contact_area_nm2 < 0) {
        return FW_RULE_PARTICLE;
    }
    for (i = 0; i < cfg->n_particles; i++) {
        rule = fw_particles_check_particle(cfg->particles[i].radius_pm, th);
        if (rule != FW_RULE_OK) {
            return rule;
        }
    }
    if (cfg->n_particles > 0 && (st->particles == NULL || st->particle_capacity < cfg->n_particles)) {
        return FW_RULE_PARTICLE_CAPACITY;
    }
    return FW_RULE_OK;
}

static fw_rule_t card_check_wires(const fw_card_config_t *cfg, const fw_card_storage_t *st)
{
    int32_t i;
    fw_rule_t rule;
    if (cfg->n_wires < 0) {
        return FW_RULE_WIRE;
    }
    if (cfg->n_wires == 0) {
        return FW_RULE_OK;
    }
    if (cfg->wires == NULL) {
        return FW_RULE_NULL_POINTER;
    }
    for (i = 0; i < cfg->n_wires; i++) {
        fw_wire_t w;
        if (fw_wire_init_ends(&w, cfg->wires[i].a_pm, cfg->wires[i].b_pm, cfg->wires[i].diameter_pm) != FW_OK) {
            return FW_RULE_WIRE;
        }
    }
    rule = fw_wire_check_tip(cfg->tip_radius_pm, cfg->tip_half_angle_mdeg, cfg->wire_friction_pn_per_um,
                             cfg->wire_mu_ppm, cfg->board.adhesion_pn);
    if (rule != FW_RULE_OK) {
        return rule;
    }
    if (st->wires == NULL || st->wire_capacity < cfg->n_wires) {
        return FW_RULE_WIRE_CAPACITY;
    }
    return FW_RULE_OK;
}

static int32_t card_litho_step_pm(const fw_card_config_t *cfg)
{
    return (cfg->litho_step_pm == 0) ? FW_CARD_LITHO_STEP_DEFAULT_PM : cfg->litho_step_pm;
}

static int32_t card_drift_step_pm(const fw_card_config_t *cfg)
{
    return (cfg->drift_max_step_pm == 0) ? FW_DRIFT_MAX_STEP_DEFAULT_PM : cfg->drift_max_step_pm;
}

/* The scanner's compensation, each part when it is on. */
static fw_rule_t card_check_scanner(const fw_card_config_t *cfg)
{
    fw_rule_t rule = cfg->creep_enable ? fw_creep_check(&cfg->creep) : FW_RULE_OK;
    int i;
    for (i = 0; i < 2 && rule == FW_RULE_OK && cfg->hyst_enable; i++) {
        rule = fw_hyst_check(&cfg->hyst[i]);
    }
    return rule;
}

fw_rule_t fw_card_check(const fw_card_config_t *cfg, const fw_card_storage_t *st)
{
    fw_board_config_t board;
    fw_rule_t rule;
    if (cfg == NULL || st == NULL || st->scratch == NULL || st->scratch_len < 1) {
        return FW_RULE_NULL_POINTER;
    }
    if (cfg->word_bits != 0 && cfg->word_bits != 16 && cfg->word_bits != 32) {
        return FW_RULE_WORD_BITS;
    }
    /* an estimate of a lever the force module refuses is 0: the board's
     * check then names the lever's rule */
    (void)card_board_config(cfg, &board);
    rule = (cfg->word_bits == 16) ? fw_board16_check(&board) : fw_board_check(&board);
    if (rule == FW_RULE_OK) {
        rule = card_check_particles(cfg, st);
    }
    if (rule == FW_RULE_OK) {
        rule = card_check_wires(cfg, st);
    }
    if (rule == FW_RULE_OK && cfg->litho) {
        rule = fw_litho_check(cfg->litho_threshold_pn, cfg->litho_depth_pm_per_pn, cfg->tip_half_angle_mdeg,
                              card_litho_step_pm(cfg));
        if (rule == FW_RULE_OK && (st->trench == NULL || st->trench_capacity < 1)) {
            rule = FW_RULE_LITHO_CAPACITY;
        }
    }
    if (rule == FW_RULE_OK) {
        rule = fw_drift_check(card_drift_step_pm(cfg));
    }
    if (rule == FW_RULE_OK) {
        rule = fw_drift_filter_check(cfg->drift_filter, &cfg->drift_kalman, cfg->drift_scan_var_nm2);
    }
    if (rule == FW_RULE_OK && cfg->n_landmarks != 0) {
        if (cfg->n_landmarks < 0 || cfg->landmarks == NULL) {
            rule = FW_RULE_LANDMARKS;
        } else {
            rule = fw_drift_check(cfg->landmark_max_step_pm);
        }
    }
    if (rule == FW_RULE_OK && (cfg->haptic_un_per_pn < 0 || cfg->haptic_max_un < 0)) {
        rule = FW_RULE_HAPTIC;
    }
    if (rule == FW_RULE_OK && cfg->interlock) {
        rule = fw_guard_check(cfg->interlock_normal_pn, cfg->interlock_lateral_pn, board.normal_gain_pn_per_v,
                              board.lateral_gain_pn_per_v);
    }
    if (rule == FW_RULE_OK) {
        rule = card_check_scanner(cfg);
    }
    return rule;
}

fw_status_t fw_card_init(fw_card_t *c, const fw_card_config_t *cfg, const fw_card_storage_t *st,
                         fw_rule_t *rule)
{
    fw_board_config_t board;
    fw_rule_t r = fw_card_check(cfg, st);
    int i;
    if (rule != NULL) {
        *rule = (c == NULL) ? FW_RULE_NULL_POINTER : r;
    }
    if (c == NULL) {
        return FW_ERR_ARG;
    }
    if (r != FW_RULE_OK) {
        return fw_rule_status(r);
    }
    /* every check passed: the inits below succeed */
    c->cfg = *cfg;
    c->st = *st;
    if (c->st.particles == NULL) {
        c->st.particle_capacity = 0;   /* no particles: a model that holds none */
    }
    (void)card_board_config(cfg, &board);
    (void)fw_board_init(&c->board, &board);
    c->chain16 = cfg->word_bits == 16;
    if (c->chain16) {
        (void)fw_board16_init(&c->board16, &board);
    }
    c->n_wires = cfg->n_wires;
    if (cfg->n_wires > 0) {
        (void)fw_wire_tip_init(&c->wire_tip, cfg->tip_radius_pm, cfg->tip_half_angle_mdeg,
                               cfg->wire_friction_pn_per_um, cfg->wire_mu_ppm, cfg->board.adhesion_pn);
        c->wire_tip.down_force = cfg->down_force;
    }
    (void)fw_calib_twist_estimate_q30(board.deflection_pm_per_v, board.lever_length_nm, &c->twist_rad_per_v);
    if (cfg->litho) {
        (void)fw_litho_init(&c->litho, st->trench, st->trench_capacity, cfg->litho_threshold_pn,
                            cfg->litho_depth_pm_per_pn, cfg->tip_half_angle_mdeg, card_litho_step_pm(cfg));
    }
    (void)fw_drift_init(&c->drift, card_drift_step_pm(cfg));
    if (cfg->drift_filter == FW_DRIFT_FILTER_KALMAN) {
        (void)fw_drift_use_kalman(&c->drift, &cfg->drift_kalman, cfg->drift_scan_var_nm2);
    }
    if (cfg->interlock) {
        (void)fw_guard_init(&c->guard, cfg->interlock_normal_pn, cfg->interlock_lateral_pn,
                            board.normal_gain_pn_per_v, board.lateral_gain_pn_per_v);
    }
    for (i = 0; i < 2; i++) {
        if (cfg->creep_enable) {
            (void)fw_creep_init(&c->creep[i], &cfg->creep);
        }
        if (cfg->hyst_enable) {
            (void)fw_hyst_init(&c->hyst[i], &cfg->hyst[i]);
        }
    }
    c->objects = cfg->n_particles > 0 || cfg->n_wires > 0 || cfg->litho;
    fw_card_reset(c);
    return FW_OK;
}

void fw_card_reset(fw_card_t *c)
{
    const fw_card_config_t *cfg = &c->cfg;
    int32_t th = card_particle_threshold_pn(cfg);
    int32_t i;
    fw_board_reset(&c->board);
    if (c->chain16) {
        fw_board16_reset(&c->board16);
    }
    (void)fw_particles_init(&c->parts, c->st.particles, c->st.particle_capacity, cfg->tip_radius_pm);
    (void)fw_particles_set_margin(&c->parts, cfg->particle_margin_pn);
    for (i = 0; i < cfg->n_particles; i++) {
        const fw_card_particle_t *p = &cfg->particles[i];
        (void)fw_particles_add(&c->parts, p->id, p->x_pm, p->y_pm, p->radius_pm, th);
    }
    for (i = 0; i < cfg->n_wires; i++) {
        (void)fw_wire_init_ends(&c->st.wires[i], cfg->wires[i].a_pm, cfg->wires[i].b_pm, cfg->wires[i].diameter_pm);
    }
    if (cfg->litho) {
        fw_litho_reset(&c->litho);
    }
    fw_drift_reset(&c->drift);
    if (cfg->interlock) {
        fw_guard_reset(&c->guard);
    }
    for (i = 0; i < 2; i++) {
        if (cfg->creep_enable) {
            fw_creep_reset(&c->creep[i]);
        }
        if (cfg->hyst_enable) {
            fw_hyst_reset(&c->hyst[i]);
        }
        c->creep_expect_pm[i] = 0;
    }
    c->sat_samples = 0;
    c->fixes_applied = 0;
    for (i = 0; i < 3; i++) {
        c->last_tip_pm[i] = 0;
    }
    c->last_code_n = 0;
    c->last_code_l = 0;
    c->down = !cfg->start_lifted;
}

/* The lever's twist theta_t = K_l S_l (radians, 2.30) from a sample's
 * lateral code. Scaling and overflow: |K_l| < 2^31, |S_l| <= 20 V < 2^27.4
 * in 9.23: the product < 2^58.4, >> 23 rounded, saturated. */
static q30_t card_twist_rad(const fw_card_t *c, int32_t code_l)
{
    int64_t s = fw_acq_signal_of_code_q23(&c->board.acq_sl, code_l);
    return fw_math_sat_i32(fw_math_rshift_round_i64((int64_t)c->twist_rad_per_v * s, FW_Q23_FRAC), NULL);
}

/* The object models for one sample (fw_card.h, step 2); ORs their flags
 * into the sample's. */
static void card_objects_sample(fw_card_t *c, fw_sample_out_t *o)
{
    int64_t excess = fw_force_lateral_excess_pn(&c->board.force, o->force_pn);
    int32_t i;
    if (c->parts.count > 0) {
        (void)fw_particles_update(&c->parts, o->tip_pm, o->force_pn, excess);
        o->flags |= fw_particles_flags(&c->parts);
    }
    if (c->n_wires > 0) {
        q30_t twist = card_twist_rad(c, o->sl_code);
        for (i = 0; i < c->n_wires; i++) {
            fw_wire_t *w = &c->st.wires[i];
            if (c->cfg.litho) {
                (void)fw_wire_hold(w, &c->wire_tip, c->litho.pts, c->litho.count);
            }
            (void)fw_wire_update(w, &c->wire_tip, o->tip_pm, excess, twist, o->force_pn[2]);
            if ((w->flags & FW_WIRE_PUSHED) != 0u) {
                o->flags |= FW_FLAG_CONTACT;
                if (c->cfg.litho) {
                    (void)fw_wire_settle(w, &c->wire_tip, c->litho.pts, c->litho.count);   /* pushed over a groove: it slides in */
                }
            }
            if ((w->flags & FW_WIRE_SQUEEZED) != 0u) {
                o->flags |= FW_FLAG_SQUEEZE;
            }
            if ((w->flags & FW_WIRE_RIDDEN) != 0u) {
                o->flags |= FW_FLAG_RIDEOVER;
            }
        }
    }
    /* a full trench store drops points: flagged as a position clamp */
    if (c->cfg.litho && fw_litho_step(&c->litho, o->tip_pm, o->force_pn[2]) == FW_ERR_CAPACITY) {
        o->flags |= FW_FLAG_SAT_POS;
    }
}

/* The interlock's causes of k samples (fw_card.h, step 3), ORed: each
 * sample's F_z, and its lateral channel's F_y from its code (eq. 1a with
 * the board's gain, given to the guard at init; the code's signal less the
 * baseline, as card_twist_rad forms it). A loop of its own that stores
 * nothing, so the limits and gains stay in registers. Scaling and
 * overflow: fw_acq_signal_of_code_q23's (within +-20 V), fw_guard_over_q23's. */
static uint32_t card_guard_samples(const fw_card_t *c, const fw_sample_out_t *o, int32_t k)
{
    uint32_t causes = 0u;
    int32_t j;
    for (j = 0; j < k; j++) {
        causes |= fw_guard_over_q23(&c->guard, o[j].force_pn[2], fw_acq_signal_of_code_q23(&c->board.acq_sl, o[j].sl_code),
                                    o[j].flags);
    }
    return causes;
}

/* round(sum / n), half away from zero, n > 0. */
static int32_t card_mean_pn(int64_t sum, int32_t n)
{
    return fw_math_sat_i32(fw_math_div_round_i64(sum, n), NULL);
}

/* The command shaped for the scanner (fw_card.h: creep, then hysteresis,
 * each when on); a clamp in either sets *sat. */
static void card_shape_command(fw_card_t *c, int32_t cmd_pm[2], bool *sat)
{
    int i;
    for (i = 0; i < 2; i++) {
        if (c->cfg.creep_enable) {
            const int32_t r = cmd_pm[i];
            cmd_pm[i] = fw_creep_step_pm(&c->creep[i], r, sat);
            c->creep_expect_pm[i] = fw_math_sat_i32((int64_t)r - cmd_pm[i], NULL);
        }
        if (c->cfg.hyst_enable) {
            cmd_pm[i] = fw_hyst_inverse_pm(&c->hyst[i], cmd_pm[i], sat);
        }
    }
}

/* The apex of each of the block's k samples from in[], where the scanner
 * is (fw_card.h): the drive through the direct hysteresis model, plus the
 * creep the feed-forward expects. Scaling: P[u] - u and the expected creep
 * each within int32 (|P[u] - u| <= 2^30: fw_hyst.h), summed in int64,
 * saturated to int32. */
static void card_scanner_apex(fw_card_t *c, const fw_sample_in_t *in, fw_sample_out_t *o, int32_t k)
{
    int32_t j;
    int i;
    for (j = 0; j < k; j++) {
        for (i = 0; i < 2; i++) {
            const int32_t u = in[j].piezo_pm[i];
            const int32_t p = c->cfg.hyst_enable ? fw_hyst_direct_pm(&c->hyst[i], u, NULL) : u;
            o[j].tip_pm[i] = fw_math_sat_i32((int64_t)o[j].tip_pm[i] + ((int64_t)p - u) + c->creep_expect_pm[i], NULL);
        }
    }
}

/* The drift estimate at the block's end (fw_drift_predict), every model
 * moved by its change. */
static void card_drift_block(fw_card_t *c)
{
    int32_t delta[2];
    fw_drift_predict(&c->drift, delta);
    if (delta[0] != 0 || delta[1] != 0) {
        fw_drift_apply(delta, &c->parts, c->st.wires, c->n_wires, c->cfg.litho ? &c->litho : NULL);
    }
}

/* The block's end: the pose's target and command, the hand's force;
 * joy_target_pm: the joystick's target before the drift (the interlock's
 * xy set point). */
static void card_command(fw_card_t *c, const fw_card_pose_t *pose, fw_card_out_t *out, int32_t joy_target_pm[2])
{
    q15_t joy[2];
    bool sat = false;
    int i;
    for (i = 0; i < 2; i++) {
        int32_t j = pose->joy_q15[i];
        joy[i] = (q15_t)((j > FW_Q15_MAX) ? FW_Q15_MAX : ((j < FW_Q15_MIN) ? FW_Q15_MIN : j));
    }
    fw_comp_target_pm(&c->board.comp, joy, out->target_pm, &sat);
    joy_target_pm[0] = out->target_pm[0];
    joy_target_pm[1] = out->target_pm[1];
    if (c->chain16) {
        /* the 16-bit chain's own offset of its latest signals */
        int32_t off[2];
        fw_board16_offset_pm(&c->board16, off);
        for (i = 0; i < 2; i++) {
            out->piezo_cmd_pm[i] = fw_math_sat_i32((int64_t)out->target_pm[i] - off[i], &sat);
        }
    } else {
        fw_comp_piezo_cmd_pm(&c->board.comp, joy, c->board.sn_v, c->board.sl_v, out->piezo_cmd_pm, &sat);
    }
    /* the drift estimate moves on (the Kalman filter), every model with it;
     * the joystick's workspace follows the sample, as the display does */
    card_drift_block(c);
    for (i = 0; i < 2; i++) {
        out->target_pm[i] = fw_math_sat_i32((int64_t)out->target_pm[i] + c->drift.offset_pm[i], &sat);
        out->piezo_cmd_pm[i] = fw_math_sat_i32((int64_t)out->piezo_cmd_pm[i] + c->drift.offset_pm[i], &sat);
    }
    card_shape_command(c, out->piezo_cmd_pm, &sat);
    /* a clamped target or command is a position clamped */
    if (sat) {
        out->flags |= FW_FLAG_SAT_POS;
    }
    out->load_pn = pose->load_pn;
    out->engaged = pose->engaged;
    for (i = 0; i < 3; i++) {
        int64_t h = (int64_t)out->force_pn[i] * c->cfg.haptic_un_per_pn;
        int64_t m = c->cfg.haptic_max_un;
        out->haptic_un[i] = (int32_t)((h > m) ? m : ((h < -m) ? -m : h));
    }
}

/* |q - (a + t (b - a))| < reach for some t in [0, 1] (pm), a segment of
 * length 0 being a point. Scaling and overflow: coordinate differences of
 * 2^30 pm or more are far (false); the rest in 64 bits: products < 2^61,
 * the cross product over the length (isqrt of < 2^61), squares of the end
 * distances < 2^61. */
static bool card_within(const int32_t q[2], const int32_t a[2], const int32_t b[2], int64_t reach)
{
    const int64_t far = (int64_t)1 << 30;
    const int64_t ux = (int64_t)b[0] - a[0], uy = (int64_t)b[1] - a[1];
    const int64_t vx = (int64_t)q[0] - a[0], vy = (int64_t)q[1] - a[1];
    const int64_t wx = (int64_t)q[0] - b[0], wy = (int64_t)q[1] - b[1];
    int64_t dot, len2, len, cross;
    if (reach <= 0 || ux >= far || ux <= -far || uy >= far || uy <= -far || vx >= far || vx <= -far || vy >= far || vy <= -far
        || wx >= far || wx <= -far || wy >= far || wy <= -far) {
        return false;
    }
    dot = ux * vx + uy * vy;
    len2 = ux * ux + uy * uy;
    if (len2 == 0 || dot <= 0) {
        return vx * vx + vy * vy < reach * reach;
    }
    if (dot >= len2) {
        return wx * wx + wy * wy < reach * reach;
    }
    len = (int64_t)fw_math_isqrt_round_u64((uint64_t)len2);
    cross = ux * vy - uy * vx;
    return (cross < 0 ? -cross : cross) < reach * len;   /* reach * len < 2^31 2^31 */
}

/* The block's last apex more than FW_CARD_BLIND_DEPTH_PM inside a particle
 * or a rod as the card models it (its own frame): with F_x unobservable,
 * a push the card does not see (it neither flags contact nor moves the
 * model out of the apex's way, as it does for a push it sees, which leaves
 * the apex at contact distance). */
static bool card_apex_inside_model(const fw_card_t *c)
{
    const int64_t rt = (int64_t)c->cfg.tip_radius_pm - FW_CARD_BLIND_DEPTH_PM;
    int32_t a[2], b[2];
    int32_t i;
    for (i = 0; i < c->parts.count; i++) {
        const fw_particle_t *p = fw_particles_get(&c->parts, i);
        const int32_t at[2] = { p->x_pm, p->y_pm };
        if (card_within(c->last_tip_pm, at, at, p->radius_pm + rt)) {
            return true;
        }
    }
    for (i = 0; i < c->n_wires; i++) {
        fw_wire_ends_pm(&c->st.wires[i], a, b);
        if (card_within(c->last_tip_pm, a, b, c->st.wires[i].diameter_pm / 2 + rt)) {
            return true;
        }
    }
    return false;
}

fw_status_t fw_card_step_block(fw_card_t *c, const fw_card_in_t *in, fw_card_out_t *out)
{
    int64_t sum[3] = { 0, 0, 0 };
    uint32_t flags = 0;
    uint32_t causes = 0u;
    int32_t done = 0;
    int32_t joy_target_pm[2];
    fw_guard_pose_t gp;
    int i;
    if (c == NULL || in == NULL || out == NULL || in->n < 0 || (in->samples == NULL && in->n > 0)) {
        return FW_ERR_ARG;
    }
    while (done < in->n) {
        int32_t k = in->n - done;
        int32_t j;
        if (k > c->st.scratch_len) {
            k = c->st.scratch_len;
        }
        if (c->chain16) {
            (void)fw_board16_step_block(&c->board16, &in->samples[done], c->st.scratch, (size_t)k);
        } else {
            (void)fw_board_step_block(&c->board, &in->samples[done], c->st.scratch, (size_t)k);
        }
        if (c->cfg.hyst_enable || c->cfg.creep_enable) {
            card_scanner_apex(c, &in->samples[done], c->st.scratch, k);
        }
        for (j = 0; j < k; j++) {
            fw_sample_out_t *o = &c->st.scratch[j];
            if (c->objects && c->down) {
                card_objects_sample(c, o);
            }
            if ((o->flags & (FW_FLAG_SAT_SN | FW_FLAG_SAT_SL)) != 0u && c->sat_samples != UINT32_MAX) {
                c->sat_samples++;
            }
            flags |= o->flags;
            for (i = 0; i < 3; i++) {
                sum[i] += o->force_pn[i];
            }
        }
        if (c->cfg.interlock) {
            causes |= card_guard_samples(c, c->st.scratch, k);
        }
        for (i = 0; i < 3; i++) {
            c->last_tip_pm[i] = c->st.scratch[k - 1].tip_pm[i];
        }
        c->last_code_n = c->st.scratch[k - 1].sn_code;
        c->last_code_l = c->st.scratch[k - 1].sl_code;
        done += k;
    }
    for (i = 0; i < 3; i++) {
        out->force_pn[i] = (in->n > 0) ? card_mean_pn(sum[i], in->n) : 0;
        out->tip_pm[i] = c->last_tip_pm[i];
    }
    if (c->down && (flags & FW_FLAG_FX_UNOBSERVABLE) != 0u && card_apex_inside_model(c)) {   /* a lifted tip pushes nothing */
        flags |= FW_FLAG_BLIND_PUSH;
    }
    out->flags = flags;
    out->code_n = c->last_code_n;
    out->code_l = c->last_code_l;
    out->sat_samples = c->sat_samples;
    card_command(c, &in->pose, out, joy_target_pm);
    out->interlock = FW_GUARD_ARMED;
    if (c->cfg.interlock) {
        gp.load_pn = in->pose.load_pn;
        gp.xy_pm[0] = joy_target_pm[0];
        gp.xy_pm[1] = joy_target_pm[1];
        gp.engaged = in->pose.engaged;
        out->interlock = fw_guard_step(&c->guard, causes, &gp);
        if (fw_guard_retracts(out->interlock)) {
            out->engaged = false;
            out->flags |= FW_FLAG_INTERLOCK;
        }
    }
    /* the next block's samples are taken with this block's command */
    c->down = out->engaged;
    return FW_OK;
}

/* A fix's answer before anything is known: not a landmark, nothing moved. */
static void card_fix_out_clear(fw_card_fix_out_t *out)
{
    out->landmark = false;
    out->model_pm[0] = 0;
    out->model_pm[1] = 0;
    out->delta_pm[0] = 0;
    out->delta_pm[1] = 0;
}

fw_status_t fw_card_fix(fw_card_t *c, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out)
{
    int32_t i;
    bool found = false;
    int32_t limit;
    if (c == NULL || scan_pm == NULL || out == NULL) {
        return FW_ERR_ARG;
    }
    card_fix_out_clear(out);
    /* the object's modelled position: a particle's model, or a landmark's
     * configured place carried along by the drift so far */
    for (i = 0; i < c->parts.count && !found; i++) {
        if (c->parts.p[i].id == object_id) {
            out->model_pm[0] = c->parts.p[i].x_pm;
            out->model_pm[1] = c->parts.p[i].y_pm;
            found = true;
        }
    }
    for (i = 0; i < c->cfg.n_landmarks && !found; i++) {
        const fw_card_landmark_t *m = &c->cfg.landmarks[i];
        if (m->id == object_id) {
            out->model_pm[0] = fw_math_sat_i32((int64_t)m->x_pm + c->drift.offset_pm[0], NULL);
            out->model_pm[1] = fw_math_sat_i32((int64_t)m->y_pm + c->drift.offset_pm[1], NULL);
            out->landmark = true;
            found = true;
        }
    }
    if (!found) {
        out->result = FW_CARD_FIX_UNKNOWN_OBJECT;
        return FW_OK;
    }
    /* a landmark may have jumped far (a lever change): its own limit */
    limit = out->landmark ? c->cfg.landmark_max_step_pm : c->drift.max_step_pm;
    if ((out->landmark ? fw_drift_jump_within(&c->drift, out->model_pm, scan_pm, limit, out->delta_pm)
                       : fw_drift_measure_within(&c->drift, out->model_pm, scan_pm, limit, out->delta_pm)) != FW_OK) {
        out->result = FW_CARD_FIX_NOT_DRIFT;
        return FW_OK;
    }
    fw_drift_apply(out->delta_pm, &c->parts, c->st.wires, c->n_wires, c->cfg.litho ? &c->litho : NULL);
    if (c->fixes_applied != UINT32_MAX) {
        c->fixes_applied++;
    }
    out->result = FW_CARD_FIX_APPLIED;
    return FW_OK;
}

fw_status_t fw_card_place(fw_card_t *c, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out)
{
    int32_t i;
    fw_particle_t *p = NULL;
    if (c == NULL || scan_pm == NULL || out == NULL) {
        return FW_ERR_ARG;
    }
    card_fix_out_clear(out);
    for (i = 0; i < c->parts.count && p == NULL; i++) {
        if (c->parts.p[i].id == object_id) {
            p = &c->parts.p[i];
        }
    }
    if (p == NULL) {
        out->result = FW_CARD_FIX_UNKNOWN_OBJECT;
        return FW_OK;
    }
    out->model_pm[0] = p->x_pm;
    out->model_pm[1] = p->y_pm;
    if (!fw_drift_within(out->model_pm, scan_pm, c->drift.max_step_pm, out->delta_pm)) {
        if (c->drift.rejected != UINT32_MAX) {
            c->drift.rejected++;
        }
        out->result = FW_CARD_FIX_NOT_DRIFT;
        return FW_OK;
    }
    p->x_pm = scan_pm[0];
    p->y_pm = scan_pm[1];
    if (c->fixes_applied != UINT32_MAX) {
        c->fixes_applied++;
    }
    out->result = FW_CARD_FIX_APPLIED;
    return FW_OK;
}

const fw_particles_t *fw_card_particles(const fw_card_t *c)
{
    return (c == NULL) ? NULL : &c->parts;
}

int32_t fw_card_wire_count(const fw_card_t *c)
{
    return (c == NULL) ? 0 : c->n_wires;
}

const fw_wire_t *fw_card_wire(const fw_card_t *c, int32_t i)
{
    return (c == NULL || i < 0 || i >= c->n_wires) ? NULL : &c->st.wires[i];
}

int32_t fw_card_wire_id(const fw_card_t *c, int32_t i)
{
    return (c == NULL || i < 0 || i >= c->n_wires) ? 0 : c->cfg.wires[i].id;
}

const fw_litho_t *fw_card_litho(const fw_card_t *c)
{
    return (c == NULL || !c->cfg.litho) ? NULL : &c->litho;
}

void fw_card_drift_pm(const fw_card_t *c, int32_t offset_pm[2])
{
    offset_pm[0] = (c == NULL) ? 0 : c->drift.offset_pm[0];
    offset_pm[1] = (c == NULL) ? 0 : c->drift.offset_pm[1];
}

uint32_t fw_card_fixes_applied(const fw_card_t *c)
{
    return (c == NULL) ? 0u : c->fixes_applied;
}

const fw_guard_t *fw_card_guard(const fw_card_t *c)
{
    return (c == NULL || !c->cfg.interlock) ? NULL : &c->guard;
}

int32_t fw_card_disp_n_pm_per_v(const fw_card_t *c)
{
    return (c == NULL) ? 0 : c->board.cfg.disp_n_pm_per_v;
}

int32_t fw_card_disp_l_pm_per_v(const fw_card_t *c)
{
    return (c == NULL) ? 0 : c->board.cfg.disp_l_pm_per_v;
}
