/*
 * fw_board.c - see fw_board.h.
 */
#include "fw_board.h"
#include "fw_math.h"

/* The scan angle at which frames A and C coincide. */
#define BOARD_ALIGNED_SCAN_MDEG 270000

/* The path the configuration allows (fw_board.h): fast when the ADC has no
 * filter and the force and compensation modules proved their bounds at
 * init; aligned when R(alpha) is the identity exactly. */
static fw_board_path_t board_path_for(const fw_board_t *b)
{
    if (b->cfg.filter_log2 != 0 || !b->force.fast || !b->comp.fast) {
        return FW_BOARD_PATH_CHECKED;
    }
    if (b->cos_a == FW_Q30_ONE && b->sin_a == 0) {
        return FW_BOARD_PATH_FAST_ALIGNED;
    }
    return FW_BOARD_PATH_FAST;
}

static fw_bam_t board_alpha(int32_t scan_angle_mdeg)
{
    return fw_math_bam_from_mdeg(scan_angle_mdeg % FW_MDEG_PER_TURN - BOARD_ALIGNED_SCAN_MDEG);
}

void fw_board_lever_axis_q30(int32_t scan_angle_mdeg, q30_t axis[2])
{
    fw_math_sincos_q30(board_alpha(scan_angle_mdeg), &axis[1], &axis[0]);
}

fw_rule_t fw_board_check(const fw_board_config_t *cfg)
{
    fw_rule_t rule;
    if (cfg == NULL) {
        return FW_RULE_NULL_POINTER;
    }
    rule = fw_acq_check(cfg->adc_bits, cfg->filter_log2);
    if (rule == FW_RULE_OK) {
        rule = fw_force_check(cfg->normal_gain_pn_per_v, cfg->lateral_gain_pn_per_v, cfg->tip_height_nm,
                              cfg->lever_length_nm, cfg->mu_ppm, cfg->adhesion_pn);
    }
    if (rule == FW_RULE_OK && cfg->deflection_pm_per_v <= 0) {
        rule = FW_RULE_DEFLECTION_GAIN;
    }
    if (rule == FW_RULE_OK) {
        rule = fw_comp_check(cfg->disp_n_pm_per_v, cfg->disp_l_pm_per_v, cfg->scan_half_range_pm,
                             cfg->kappa_q16);
    }
    if (rule == FW_RULE_OK) {
        rule = fw_theta_check(cfg->theta_min_disp_pm);
    }
    return rule;
}

fw_status_t fw_board_init(fw_board_t *b, const fw_board_config_t *cfg)
{
    fw_rule_t rule = fw_board_check(cfg);
    if (b == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    /* the checks passed: every init below succeeds */
    (void)fw_acq_init(&b->acq_sn, cfg->adc_bits, cfg->filter_log2);
    (void)fw_acq_init(&b->acq_sl, cfg->adc_bits, cfg->filter_log2);
    (void)fw_force_init(&b->force, cfg->normal_gain_pn_per_v, cfg->lateral_gain_pn_per_v, cfg->tip_height_nm,
                        cfg->lever_length_nm, cfg->mu_ppm, cfg->adhesion_pn);
    (void)fw_comp_init(&b->comp, cfg->disp_n_pm_per_v, cfg->disp_l_pm_per_v, board_alpha(cfg->scan_angle_mdeg),
                       cfg->scan_center_pm, cfg->scan_half_range_pm, cfg->kappa_q16);
    (void)fw_theta_init(&b->theta, cfg->theta_min_disp_pm);
    b->cfg = *cfg;
    b->cos_a = b->comp.cos_a;
    b->sin_a = b->comp.sin_a;
    b->path_cfg = board_path_for(b);
    fw_board_reset(b);
    return FW_OK;
}

void fw_board_reset(fw_board_t *b)
{
    fw_acq_reset(&b->acq_sn);
    fw_acq_reset(&b->acq_sl);
    fw_theta_reset(&b->theta);
    b->sn_v = 0;
    b->sl_v = 0;
    b->z_pm = 0;
    b->sn_ref_v = 0;
    b->z_ref_pm = 0;
    b->have_ref = false;
    b->ref_live = false;
    b->stepped = false;
    b->fast_lo_uv = b->acq_sn.fast_lo_uv;
    b->fast_span_uv = 0;
    b->sticky_flags = 0;
    b->sat_force_count = 0;
    b->gains.valid = false;
}

fw_status_t fw_board_step_checked(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out)
{
    uint32_t flags = 0;
    bool sat_n = false;
    bool sat_l = false;
    bool sat_pos = false;
    bool sat_f = false;
    q23_t vn;
    q23_t vl;
    int32_t force_c[3];
    if (b == NULL || in == NULL || out == NULL) {
        return FW_ERR_ARG;
    }
    (void)fw_acq_step_q23(&b->acq_sn, in->sn_uv, &out->sn_code, &vn, &sat_n);
    (void)fw_acq_step_q23(&b->acq_sl, in->sl_uv, &out->sl_code, &vl, &sat_l);
    if (sat_n) {
        flags |= FW_FLAG_SAT_SN;
        if (b->ref_live) {
            /* the previous sample was the last unsaturated one: keep it */
            b->sn_ref_v = b->sn_v;
            b->z_ref_pm = b->z_pm;
            b->ref_live = false;
        }
        if (b->have_ref) {
            bool sat_v = false;
            (void)fw_acq_virtual_sn_q23(b->sn_ref_v, b->z_ref_pm, in->piezo_pm[2],
                                        b->cfg.deflection_pm_per_v, &vn, &sat_v);
            flags |= FW_FLAG_VIRTUAL_SN;
        }
    } else {
        b->have_ref = true;
        b->ref_live = true;
    }
    if (sat_l) {
        flags |= FW_FLAG_SAT_SL;
    }
    b->sn_v = vn;
    b->sl_v = vl;
    b->z_pm = in->piezo_pm[2];

    fw_comp_apex_pm(&b->comp, in->piezo_pm, vn, vl, out->tip_pm, &sat_pos);
    (void)fw_theta_push_pm(&b->theta, out->tip_pm, b->cos_a, b->sin_a, &flags);
    fw_force_solve_fit_pn(&b->force, vn, vl, b->theta.dir_x, b->theta.dir_y, force_c, &flags);
    /* eq. 3; cos_a, sin_a from fw_math_sincos_q30 lie in [-1, 1] */
    fw_math_rotate_unit_i32(force_c[0], force_c[1], b->cos_a, b->sin_a,
                            &out->force_pn[0], &out->force_pn[1], &sat_f);
    out->force_pn[2] = force_c[2];
    if (sat_f) {
        flags |= FW_FLAG_SAT_FORCE;
    }
    if (sat_pos) {
        flags |= FW_FLAG_SAT_POS;
    }
    if ((flags & FW_FLAG_SAT_FORCE) != 0u && b->sat_force_count != UINT32_MAX) {
        b->sat_force_count++;
    }
    b->stepped = true;
    /* the fast path from the next sample on, while this one is the virtual
     * S_n's live reference (so the fast path need not keep it) */
    b->fast_span_uv = (b->ref_live && b->path_cfg != FW_BOARD_PATH_CHECKED) ? b->acq_sn.fast_span_uv : 0u;
    b->sticky_flags |= flags;
    out->flags = flags;
    return FW_OK;
}

/* The fast path's gains on the ADC codes (fw_board_gains_t): the
 * offset's (fw_comp_code_gains) and the force terms' (fw_acq_gain), with
 * the baselines they were formed from. Out of line: formed again only
 * when a baseline has changed (board_run_fast compares them at the start
 * of each run). */
static FW_NOINLINE void board_gains_form(fw_board_t *b)
{
    fw_board_gains_t *g = &b->gains;
    g->baseline_n_v = b->acq_sn.baseline_v;
    g->baseline_l_v = b->acq_sl.baseline_v;
    g->valid = true;
    fw_comp_code_gains(&b->comp, &b->acq_sn, &b->acq_sl, &g->offset);
    g->n8 = fw_acq_gain(&b->acq_sn, b->force.normal_gain_pn_per_v, FW_Q23_FRAC - FW_FORCE_XFRAC);
    g->fy8 = fw_acq_gain(&b->acq_sl, b->force.lateral_gain_pn_per_v, FW_Q23_FRAC - FW_FORCE_XFRAC);
}

/* Both inputs in the ADC's fast range [lo, lo + span): one unsigned test
 * on the larger offset (both channels share the ADC, so the range). */
static FW_ALWAYS_INLINE bool board_in_fast_range(const fw_sample_in_t *in, uint32_t lo, uint32_t span)
{
    uint32_t un = (uint32_t)in->sn_uv - lo;
    uint32_t ul = (uint32_t)in->sl_uv - lo;
    return (un > ul ? un : ul) < span;
}

/* Both apex coordinates within int32 (they are formed in 64 bits). */
static FW_ALWAYS_INLINE bool board_apex_fits(int64_t ax, int64_t ay)
{
    return ((((uint64_t)ax - (uint64_t)INT32_MIN) | ((uint64_t)ay - (uint64_t)INT32_MIN)) >> 32) == 0u;
}

/* Eq. 3: the frame-C force into frame A (the identity when aligned); on
 * the fast path the inputs lie below 2^29 pN, so the rotation cannot
 * clamp (fw_math_rotate_unit_fit_i32). */
static FW_ALWAYS_INLINE void board_force_to_a(const fw_board_t *b, const int32_t force_c[3], bool aligned,
                                              int32_t force_a[3])
{
    force_a[2] = force_c[2];
    if (aligned) {
        force_a[0] = force_c[0];
        force_a[1] = force_c[1];
    } else {
        fw_math_rotate_unit_fit_i32(force_c[0], force_c[1], b->cos_a, b->sin_a, &force_a[0], &force_a[1]);
    }
}

/* The fast path (fw_board.h) over a run of samples: from in[0] on, while
 * both inputs lie in the ADC's fast range (span 0 while the checked path
 * is due) and the sample needs nothing of the checked path. Returns the
 * number of samples done, k <= n; when k < n, in[k] belongs to
 * fw_board_step_checked, which the caller then calls. aligned: path
 * FW_BOARD_PATH_FAST_ALIGNED (a constant at each call, so the compiler
 * emits one specialisation per path); the configuration's path_cfg is
 * fast and the theta window primed.
 *
 * The stages, each its module's inline fast function: the two codes
 * (fw_acq_code_fast), the apex (fw_comp_offset_codes_pm), the direction
 * (fw_theta_push_fast_pm), the force (fw_force_solve_fast_pn, its terms
 * from the codes by fw_acq_gain_apply), frame A (board_force_to_a).
 *
 * State in locals: the window's position and direction
 * (fw_theta_run_t) and the sticky flags are kept in locals for the run and
 * stored once at its end; the latest signals (the ADC's last_v, sn_v,
 * sl_v: the baseline's and the virtual S_n's reference) and piezo z are
 * stored from the run's last sample. So the state at the end of a run is
 * the one k calls of fw_board_step_checked leave.
 *
 * A sample goes to the checked path, before the window's position moves,
 * when its apex leaves int32 or its theta window exceeds the fast one: the
 * stores made until then (codes, apex, the apex in its window slot) are
 * the values the checked path stores again.
 * Scaling and overflow: the signals are within +-20 V
 * (fw_acq_take_code_q23); within that, the offsets M S (fw_comp.h,
 * FW_COMP_FAST_C_MAX_PM_PER_V) stay below 2^26 pm and the forces
 * (fw_force_solve_fast_pn) below 2^29 pN, so the rotation into frame A
 * cannot clamp and FW_FLAG_SAT_FORCE cannot occur. Same state changes as
 * fw_board_step_checked for such a sample: no saturation counters move;
 * stepped, have_ref and ref_live are already set (fw_board_step_checked
 * opens the fast path only while ref_live), so the virtual S_n's reference
 * is the latest sample through sn_v and z_pm. The flags it can raise are
 * FW_FLAG_THETA_UNKNOWN (no direction known yet; the direction is then
 * (0, 1), in the cot zone) and FW_FLAG_FX_UNOBSERVABLE (below S_HI). */
static FW_ALWAYS_INLINE size_t board_run_fast(fw_board_t *b, const fw_sample_in_t *in,
                                              fw_sample_out_t *out, size_t n, bool aligned)
{
    const uint32_t lo = (uint32_t)b->fast_lo_uv;
    const uint32_t span = b->fast_span_uv;
    const fw_board_gains_t *g = &b->gains;
    fw_theta_run_t run = fw_theta_run_begin(&b->theta);
    uint32_t sticky = 0;
    const fw_sample_in_t *const end = in + n;
    const fw_sample_in_t *i = in;
    fw_sample_out_t *o = out;
    size_t k;
    /* the gains are a cache, formed again when a baseline has changed
     * since (the baselines cannot change within a run) */
    if (FW_UNLIKELY(!g->valid || g->baseline_n_v != b->acq_sn.baseline_v
                    || g->baseline_l_v != b->acq_sl.baseline_v)) {
        board_gains_form(b);
    }
    for (; i != end; i++, o++) {
        uint32_t flags = 0;
        int32_t code_n;
        int32_t code_l;
        int64_t off[2];
        int64_t ax;
        int64_t ay;
        int64_t x2;
        int64_t y2;
        int32_t force_c[3];
        if (FW_UNLIKELY(!board_in_fast_range(i, lo, span))) {
            break;
        }
        code_n = fw_acq_code_fast(&b->acq_sn, i->sn_uv);
        code_l = fw_acq_code_fast(&b->acq_sl, i->sl_uv);
        o->sn_code = code_n;
        o->sl_code = code_l;
        fw_comp_offset_codes_pm(&g->offset, code_n, code_l, aligned, off);
        ax = i->piezo_pm[0] + off[0];
        ay = i->piezo_pm[1] + off[1];
        if (FW_UNLIKELY(!board_apex_fits(ax, ay))) {
            break;
        }
        o->tip_pm[0] = (int32_t)ax;
        o->tip_pm[1] = (int32_t)ay;
        o->tip_pm[2] = i->piezo_pm[2];
        if (FW_UNLIKELY(!fw_theta_push_fast_pm(&b->theta, &run, ax, ay, b->cos_a, b->sin_a, aligned, &x2, &y2,
                                                &flags))) {
            break;
        }
        fw_force_solve_fast_pn(&b->force, fw_acq_gain_apply(g->n8, code_n, FW_Q23_FRAC - FW_FORCE_XFRAC),
                               fw_acq_gain_apply(g->fy8, code_l, FW_Q23_FRAC - FW_FORCE_XFRAC), run.dir_x,
                               run.dir_y, x2, y2, force_c, &flags);
        board_force_to_a(b, force_c, aligned, o->force_pn);
        sticky |= flags;
        o->flags = flags;
    }
    k = (size_t)(i - in);
    fw_theta_run_end(&b->theta, &run);
    b->sticky_flags |= sticky;
    if (k > 0) {
        /* the latest signals, as fw_acq_take_code_q23 leaves them */
        b->sn_v = fw_acq_take_code_q23(&b->acq_sn, out[k - 1].sn_code);
        b->sl_v = fw_acq_take_code_q23(&b->acq_sl, out[k - 1].sl_code);
        b->z_pm = in[k - 1].piezo_pm[2];
    }
    return k;
}

/* n samples on one path; the path test is hoisted out of the loop. Fast
 * runs (board_run_fast) and single checked samples alternate; the fast
 * range is read again after each checked sample (only the checked path
 * changes it: fast_span_uv; fast_lo_uv only changes at a reset). */
static FW_ALWAYS_INLINE void board_block(fw_board_t *b, const fw_sample_in_t *in,
                                         fw_sample_out_t *out, size_t n, bool aligned)
{
    for (;;) {
        size_t k = board_run_fast(b, in, out, n, aligned);
        if (k == n) {
            return;
        }
        (void)fw_board_step_checked(b, &in[k], &out[k]);
        in += k + 1;
        out += k + 1;
        n -= k + 1;
    }
}

fw_status_t fw_board_step_block(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out, size_t n)
{
    size_t i;
    if (b == NULL || ((in == NULL || out == NULL) && n != 0)) {
        return FW_ERR_ARG;
    }
    switch (b->path_cfg) {
    case FW_BOARD_PATH_FAST_ALIGNED:
        board_block(b, in, out, n, true);
        break;
    case FW_BOARD_PATH_FAST:
        board_block(b, in, out, n, false);
        break;
    default:
        for (i = 0; i < n; i++) {
            (void)fw_board_step_checked(b, &in[i], &out[i]);
        }
        break;
    }
    return FW_OK;
}

/* One copy of the fast path per specialisation (the block's): a single
 * sample is a block of one. */
fw_status_t fw_board_step(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out)
{
    return fw_board_step_block(b, in, out, 1u);
}

fw_status_t fw_board_piezo_cmd(const fw_board_t *b, const int32_t joy_q15[2], int32_t piezo_cmd_pm[2])
{
    q15_t joy[2];
    bool sat = false;
    int i;
    if (b == NULL || joy_q15 == NULL || piezo_cmd_pm == NULL) {
        return FW_ERR_ARG;
    }
    for (i = 0; i < 2; i++) {
        if (joy_q15[i] < FW_Q15_MIN || joy_q15[i] > FW_Q15_MAX) {
            return FW_ERR_ARG;
        }
        joy[i] = (q15_t)joy_q15[i];
    }
    fw_comp_piezo_cmd_pm(&b->comp, joy, b->sn_v, b->sl_v, piezo_cmd_pm, &sat);
    return FW_OK;
}

fw_status_t fw_board_record_baseline(fw_board_t *b)
{
    if (b == NULL) {
        return FW_ERR_ARG;
    }
    if (!b->stepped) {
        return FW_ERR_STATE;
    }
    fw_acq_record_baseline(&b->acq_sn);
    fw_acq_record_baseline(&b->acq_sl);
    return FW_OK;
}

uint32_t fw_board_sticky_flags(const fw_board_t *b)
{
    return (b == NULL) ? 0u : b->sticky_flags;
}

uint32_t fw_board_sat_count(const fw_board_t *b, uint32_t flag)
{
    if (b == NULL) {
        return 0u;
    }
    if (flag == FW_FLAG_SAT_SN) {
        return b->acq_sn.sat_count;
    }
    if (flag == FW_FLAG_SAT_SL) {
        return b->acq_sl.sat_count;
    }
    if (flag == FW_FLAG_SAT_FORCE) {
        return b->sat_force_count;
    }
    return 0u;
}
