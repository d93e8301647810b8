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

/* One sample on the fast path (fw_board.h): both inputs in the ADC's fast
 * range, a configuration with path_cfg fast, the theta window primed.
 * aligned: path FW_BOARD_PATH_FAST_ALIGNED (a constant at each call, so the
 * compiler emits one specialisation per path).
 * Scaling and overflow: the signals are within +-20 V
 * (fw_acq_step_fast_q23); within that, the offsets (fw_comp_apex_fast_pm)
 * stay below 2^26 pm and the forces (fw_force_solve_dir_fast_pn) below
 * 2^29 pN, so the rotation into frame A (fw_math_rotate_unit_fit_i32,
 * inputs < 2^30) cannot clamp and FW_FLAG_SAT_FORCE cannot occur. The
 * apex keeps its saturation (FW_FLAG_SAT_POS): the piezo input is not
 * bounded. Same state changes as fw_board_step_checked for such a sample:
 * no saturation counters move; stepped, have_ref and ref_live are already
 * set (fw_board_step_checked opens the fast path only while ref_live), so
 * the virtual S_n's reference is this sample through sn_v and z_pm. */
static FW_ALWAYS_INLINE void board_step_fast(fw_board_t *restrict b, const fw_sample_in_t *restrict in,
                                             fw_sample_out_t *restrict out, bool aligned)
{
    uint32_t flags = 0;
    int32_t force_c[3];
    q23_t vn = fw_acq_step_fast_q23(&b->acq_sn, in->sn_uv, &out->sn_code);
    q23_t vl = fw_acq_step_fast_q23(&b->acq_sl, in->sl_uv, &out->sl_code);
    b->sn_v = vn;
    b->sl_v = vl;
    b->z_pm = in->piezo_pm[2];
    if (fw_comp_apex_fast_pm(&b->comp, in->piezo_pm, vn, vl, aligned, out->tip_pm)) {
        flags |= FW_FLAG_SAT_POS;
    }
    (void)fw_theta_push_fast_pm(&b->theta, out->tip_pm, b->cos_a, b->sin_a, aligned, &flags);
    fw_force_solve_dir_fast_pn(&b->force, vn, vl, b->theta.dir_x, b->theta.dir_y, force_c, &flags);
    if (aligned) {
        out->force_pn[0] = force_c[0];
        out->force_pn[1] = force_c[1];
    } else {
        fw_math_rotate_unit_fit_i32(force_c[0], force_c[1], b->cos_a, b->sin_a,
                                    &out->force_pn[0], &out->force_pn[1]);
    }
    out->force_pn[2] = force_c[2];
    b->sticky_flags |= flags;
    out->flags = flags;
}

fw_status_t fw_board_step(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out)
{
    if (b == NULL || in == NULL || out == NULL) {
        return FW_ERR_ARG;
    }
    /* both inputs in the fast range (span 0 while the checked path is due;
     * both channels have the same ADC, so the same range) */
    if ((uint32_t)in->sn_uv - (uint32_t)b->fast_lo_uv < b->fast_span_uv
        && (uint32_t)in->sl_uv - (uint32_t)b->fast_lo_uv < b->fast_span_uv) {
        if (b->path_cfg == FW_BOARD_PATH_FAST_ALIGNED) {
            board_step_fast(b, in, out, true);
        } else {
            board_step_fast(b, in, out, false);
        }
        return FW_OK;
    }
    return fw_board_step_checked(b, in, out);
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
