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

fw_status_t fw_board_init(fw_board_t *b, const fw_board_config_t *cfg)
{
    fw_status_t st;
    fw_bam_t alpha;
    if (b == NULL || cfg == NULL || cfg->Kn_pm_per_v <= 0 || cfg->theta_min_disp_pm < 0) {
        return FW_ERR_ARG;
    }
    st = fw_acq_init(&b->acq_sn, cfg->adc_bits, cfg->filter_log2);
    if (st != FW_OK) {
        return st;
    }
    st = fw_acq_init(&b->acq_sl, cfg->adc_bits, cfg->filter_log2);
    if (st != FW_OK) {
        return st;
    }
    st = fw_force_init(&b->force, cfg->kn_Kn_pn_per_v, cfg->lat_pn_per_v, cfg->tip_height_nm,
                       cfg->lever_length_nm, cfg->mu_ppm, cfg->adhesion_pn);
    if (st != FW_OK) {
        return st;
    }
    alpha = fw_math_bam_from_mdeg(cfg->scan_angle_mdeg % FW_MDEG_PER_TURN - BOARD_ALIGNED_SCAN_MDEG);
    st = fw_comp_init(&b->comp, cfg->cn_pm_per_v, cfg->cl_pm_per_v, alpha, cfg->scan_center_pm,
                      cfg->scan_half_range_pm, cfg->kappa_q16);
    if (st != FW_OK) {
        return st;
    }
    st = fw_theta_init(&b->theta, cfg->theta_min_disp_pm);
    if (st != FW_OK) {
        return st;
    }
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
                                        b->cfg.Kn_pm_per_v, &vn, &sat_v);
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
    fw_force_solve_dir_fit_pn(&b->force, vn, vl, b->theta.dir_x, b->theta.dir_y,
                              force_c, &flags);
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

/* The fast path's gains on the ADC codes (fw_board_gains_t), from M, the
 * force gains and the baselines, with the baselines they were formed
 * from. Out of line: formed again only when a baseline has changed
 * (board_run_fast compares them at the start of each run). The offset's
 * row i: floor((code_n P_i0 + code_l P_i1 + K_i) / 2^31) with P_ij =
 * m_ij lsb_j and K_i = 2^30 - m_i0 baseline_n - m_i1 baseline_l, i.e.
 * fw_comp_offset_row_pm of the signals code lsb - baseline, exactly
 * (fw_acq_gain: |m| <= 2^30, so |code P|, |m baseline| < 2^56.4, the sum
 * < 2^58.5). */
static FW_NOINLINE void board_gains_form(fw_board_t *b)
{
    fw_board_gains_t *g = &b->gains;
    const int shift = FW_Q23_FRAC + FW_COMP_M_FRAC;
    int i;
    g->baseline_n_v = b->acq_sn.baseline_v;
    g->baseline_l_v = b->acq_sl.baseline_v;
    g->valid = true;
    for (i = 0; i < 2; i++) {
        fw_acq_gain_t gn = fw_acq_gain(&b->acq_sn, b->comp.m[i][0], shift);
        fw_acq_gain_t gl = fw_acq_gain(&b->acq_sl, b->comp.m[i][1], shift);
        g->off_mul[i][0] = gn.mul;
        g->off_mul[i][1] = gl.mul;
        g->off_add[i] = gn.add + gl.add - ((int64_t)1 << (shift - 1));
    }
    g->n8 = fw_acq_gain(&b->acq_sn, b->force.kn_pn_per_v, FW_Q23_FRAC - FW_FORCE_XFRAC);
    g->fy8 = fw_acq_gain(&b->acq_sl, b->force.lat_pn_per_v, FW_Q23_FRAC - FW_FORCE_XFRAC);
}

/* The fast path (fw_board.h) over a run of samples: from in[0] on, while
 * both inputs lie in the ADC's fast range [lo, lo + span) (span 0 while the
 * checked path is due; both channels have the same ADC, so the same range)
 * and the sample needs nothing of the checked path. Returns the number of
 * samples done, k <= n; when k < n, in[k] belongs to fw_board_step_checked,
 * which the caller then calls. aligned: path FW_BOARD_PATH_FAST_ALIGNED (a
 * constant at each call, so the compiler emits one specialisation per
 * path); the configuration's path_cfg is fast and the theta window primed.
 *
 * State in locals: the state a sample leaves for the next (the theta
 * window's position and direction, the sticky flags) is kept in locals for
 * the run and stored once at its end; the latest signals (the ADC's
 * last_v, sn_v, sl_v: the baseline's and the virtual S_n's reference) and
 * piezo z are stored from the run's last sample, out of its code. So the
 * state at the end of a run, and at every return, is the one k calls of
 * fw_board_step_checked leave.
 *
 * A sample goes to the checked path, before the window's position moves,
 * when its apex leaves int32 or its theta window exceeds the fast one: the
 * stores made until then (codes, apex, the apex in its window slot) are
 * the values the checked path stores again. Every direction is finished
 * here, with no call: the force is fw_force_solve_dir_fast_pn's (cot zone
 * |sin theta| > S_HI, friction fallback and blend below it, the zero
 * vector), inline, given the squares the window test already formed.
 * Scaling and overflow: the signals are within +-20 V
 * (fw_acq_take_code_q23); within that, the offsets M S (fw_comp.h; formed
 * from the codes, board_gains_form; FW_COMP_FAST_C_MAX_PM_PER_V) stay
 * below 2^26 pm and the forces (fw_force_solve_dir_fast_pn) below 2^29 pN,
 * so the rotation into frame A (inputs < 2^30) cannot clamp and
 * FW_FLAG_SAT_FORCE cannot occur. Window as FW_THETA_FAST_WINDOW_PM (|dx|,
 * |dy| <= 2^14 pm, squares summed < 2^29, direction |dir_x|, |dir_y| <=
 * 2^15). Force as fw_force_solve_dir_fast_pn: |F_y x| < 2^30.4 2^15 in 64
 * bits, one division, rounded >> 8 (|F_x| < 2^27.2 pN in every zone);
 * (2h/l) F_x < 2^31 2^27.2 in 64 bits. Same state changes as
 * fw_board_step_checked for such a sample: no saturation counters move;
 * stepped, have_ref and ref_live are already set (fw_board_step_checked
 * opens the fast path only while ref_live), so the virtual S_n's reference
 * is the latest sample through sn_v and z_pm. The flags it can raise are
 * FW_FLAG_THETA_UNKNOWN (no direction known yet; the direction is then
 * (0, 1), in the cot zone) and FW_FLAG_FX_UNOBSERVABLE (below S_HI). */
static FW_ALWAYS_INLINE size_t board_run_fast(fw_board_t *b, const fw_sample_in_t *in,
                                              fw_sample_out_t *out, size_t n, bool aligned)
{
    fw_theta_t *t = &b->theta;
    const uint32_t lo = (uint32_t)b->fast_lo_uv;
    const uint32_t span = b->fast_span_uv;
    uint32_t pos = (uint32_t)t->pos;
    int32_t dir_x = t->dir_x;
    int32_t dir_y = t->dir_y;
    bool known = t->known;
    uint32_t sticky = 0;
    const fw_board_gains_t *g = &b->gains;
    const fw_sample_in_t *const end = in + n;
    const fw_sample_in_t *i = in;
    fw_sample_out_t *o = out;
    size_t k;
    /* the offsets' and the forces' terms straight from the codes (exact:
     * fw_acq_gain); the gains are a cache, formed again when a baseline
     * has changed since (the baselines cannot change within a run) */
    if (FW_UNLIKELY(!g->valid || g->baseline_n_v != b->acq_sn.baseline_v
                    || g->baseline_l_v != b->acq_sl.baseline_v)) {
        board_gains_form(b);
    }
    for (; i != end; i++, o++) {
        int32_t cn;
        int32_t cl;
        int64_t ox;
        int64_t oy;
        int64_t ax;
        int64_t ay;
        uint32_t next;
        int64_t dx;
        int64_t dy;
        int64_t x2;
        int64_t y2;
        uint32_t flags = 0;
        int32_t force_c[3];
        uint32_t un = (uint32_t)i->sn_uv - lo;
        uint32_t ul = (uint32_t)i->sl_uv - lo;
        if (FW_UNLIKELY((un > ul ? un : ul) >= span)) {
            break;
        }
        cn = fw_acq_code_fast(&b->acq_sn, i->sn_uv);
        cl = fw_acq_code_fast(&b->acq_sl, i->sl_uv);
        o->sn_code = cn;
        o->sl_code = cl;
        /* the apex (fw_comp_apex_pm's value: the offset M S from the codes,
         * below 2^26 pm; M is diagonal when aligned), past int32 to the
         * checked path */
        if (aligned) {
            ox = fw_math_asr_i64(cn * g->off_mul[0][0] + g->off_add[0], FW_Q23_FRAC + FW_COMP_M_FRAC);
            oy = fw_math_asr_i64(cl * g->off_mul[1][1] + g->off_add[1], FW_Q23_FRAC + FW_COMP_M_FRAC);
        } else {
            ox = fw_math_asr_i64(cn * g->off_mul[0][0] + cl * g->off_mul[0][1] + g->off_add[0],
                                 FW_Q23_FRAC + FW_COMP_M_FRAC);
            oy = fw_math_asr_i64(cn * g->off_mul[1][0] + cl * g->off_mul[1][1] + g->off_add[1],
                                 FW_Q23_FRAC + FW_COMP_M_FRAC);
        }
        ax = i->piezo_pm[0] + ox;
        ay = i->piezo_pm[1] + oy;
        if (FW_UNLIKELY(((((uint64_t)ax - (uint64_t)INT32_MIN) | ((uint64_t)ay - (uint64_t)INT32_MIN)) >> 32) != 0u)) {
            break;
        }
        o->tip_pm[0] = (int32_t)ax;
        o->tip_pm[1] = (int32_t)ay;
        o->tip_pm[2] = i->piezo_pm[2];
        /* the window (fw_theta_push_pm's state and direction); beyond the
         * fast window to the checked path. The slot of this apex held the
         * one before the window's oldest: the checked path, if it takes
         * over, stores the same apex there again */
        t->x_pm[pos] = (int32_t)ax;
        t->y_pm[pos] = (int32_t)ay;
        next = (pos + 1u) & (FW_THETA_WINDOW - 1u);
        dx = ax - t->x_pm[next];
        dy = ay - t->y_pm[next];
        if (FW_UNLIKELY((((uint64_t)dx + (uint64_t)FW_THETA_FAST_WINDOW_PM)
                         | ((uint64_t)dy + (uint64_t)FW_THETA_FAST_WINDOW_PM)) > (uint64_t)(2 * FW_THETA_FAST_WINDOW_PM))) {
            break;
        }
        pos = next;
        x2 = dx * dx;
        y2 = dy * dy;
        if (FW_LIKELY((uint64_t)(x2 + y2) >= t->min_disp2_pm2)) {
            if (!aligned) {
                int64_t rx = fw_math_rshift_round_i64((int64_t)b->cos_a * dx + (int64_t)b->sin_a * dy, FW_Q30_FRAC);
                dy = fw_math_rshift_round_i64((int64_t)b->cos_a * dy - (int64_t)b->sin_a * dx, FW_Q30_FRAC);
                dx = rx;
                x2 = dx * dx;
                y2 = dy * dy;
            }
            dir_x = (int32_t)dx;
            dir_y = (int32_t)dy;
            known = true;
        } else {
            x2 = (int64_t)dir_x * dir_x;
            y2 = (int64_t)dir_y * dir_y;
            if (!known) {
                flags = FW_FLAG_THETA_UNKNOWN;
            }
        }
        /* the force in frame C, then eq. 3 (the identity when aligned) */
        fw_force_solve_dir_fast_pn(&b->force, fw_acq_gain_apply(g->n8, cn, FW_Q23_FRAC - FW_FORCE_XFRAC),
                                   fw_acq_gain_apply(g->fy8, cl, FW_Q23_FRAC - FW_FORCE_XFRAC), dir_x, dir_y,
                                   x2, y2, force_c, &flags);
        o->force_pn[2] = force_c[2];
        if (aligned) {
            o->force_pn[0] = force_c[0];
            o->force_pn[1] = force_c[1];
        } else {
            fw_math_rotate_unit_fit_i32(force_c[0], force_c[1], b->cos_a, b->sin_a, &o->force_pn[0],
                                        &o->force_pn[1]);
        }
        sticky |= flags;
        o->flags = flags;
    }
    k = (size_t)(i - in);
    t->pos = (int32_t)pos;
    t->dir_x = dir_x;
    t->dir_y = dir_y;
    t->known = known;
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
