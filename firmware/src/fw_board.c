/*
 * fw_board.c - see fw_board.h.
 */
#include "fw_board.h"
#include "fw_math.h"

/* The scan angle at which frames A and C coincide. */
#define BOARD_ALIGNED_SCAN_MDEG 270000

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
    b->sn_ref_v = 0;
    b->z_ref_pm = 0;
    b->have_ref = false;
    b->sticky_flags = 0;
    b->samples = 0;
    b->sat_force_count = 0;
}

fw_status_t fw_board_step(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out)
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
        if (b->have_ref) {
            bool sat_v = false;
            (void)fw_acq_virtual_sn_q23(b->sn_ref_v, b->z_ref_pm, in->piezo_pm[2],
                                        b->cfg.Kn_pm_per_v, &vn, &sat_v);
            flags |= FW_FLAG_VIRTUAL_SN;
        }
    } else {
        b->sn_ref_v = vn;
        b->z_ref_pm = in->piezo_pm[2];
        b->have_ref = true;
    }
    if (sat_l) {
        flags |= FW_FLAG_SAT_SL;
    }
    b->sn_v = vn;
    b->sl_v = vl;

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
    if (b->samples != UINT32_MAX) {
        b->samples++;
    }
    b->sticky_flags |= flags;
    out->flags = flags;
    return FW_OK;
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
    if (b->samples == 0u) {
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
