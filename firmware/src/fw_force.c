/*
 * fw_force.c - see fw_force.h.
 */
#include "fw_force.h"
#include "fw_math.h"

#define FORCE_MU_G_MAX (FW_Q30_ONE / 2)   /* mu * 2h/l must stay <= 1/2 */

/* 2h/l and mu in 2.30, for h < l and mu_ppm in [0, 1e6]. */
static int64_t force_two_h_over_l_q30(int32_t tip_height_nm, int32_t lever_length_nm)
{
    return fw_math_div_round_i64((int64_t)2 * tip_height_nm * FW_Q30_ONE, lever_length_nm);
}

static int64_t force_mu_q30(int32_t mu_ppm)
{
    return fw_math_div_round_i64((int64_t)mu_ppm * FW_Q30_ONE, FW_PPM_PER_ONE);
}

fw_rule_t fw_force_check(int32_t normal_gain_pn_per_v, int32_t lateral_gain_pn_per_v,
                         int32_t tip_height_nm, int32_t lever_length_nm, int32_t mu_ppm,
                         int32_t adhesion_pn)
{
    if (normal_gain_pn_per_v <= 0 || lateral_gain_pn_per_v <= 0) {
        return FW_RULE_FORCE_GAINS;
    }
    if (tip_height_nm <= 0 || lever_length_nm <= 0) {
        return FW_RULE_LEVER_POSITIVE;
    }
    if (tip_height_nm >= lever_length_nm) {
        return FW_RULE_TIP_SHORTER_THAN_LEVER;   /* 2h/l >= 2 does not fit 2.30 and is no lever */
    }
    if (mu_ppm < 0 || mu_ppm > FW_PPM_PER_ONE) {
        return FW_RULE_MU_RANGE;
    }
    if (adhesion_pn < 0) {
        return FW_RULE_ADHESION;
    }
    if (fw_math_asr_i64(force_mu_q30(mu_ppm) * force_two_h_over_l_q30(tip_height_nm, lever_length_nm),
                        FW_Q30_FRAC) > FORCE_MU_G_MAX) {
        return FW_RULE_MU_2H_OVER_L;
    }
    return FW_RULE_OK;
}

fw_status_t fw_force_init(fw_force_t *f, int32_t normal_gain_pn_per_v, int32_t lateral_gain_pn_per_v,
                          int32_t tip_height_nm, int32_t lever_length_nm,
                          int32_t mu_ppm, int32_t adhesion_pn)
{
    fw_rule_t rule;
    if (f == NULL) {
        return FW_ERR_ARG;
    }
    rule = fw_force_check(normal_gain_pn_per_v, lateral_gain_pn_per_v, tip_height_nm, lever_length_nm,
                          mu_ppm, adhesion_pn);
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    f->normal_gain_pn_per_v = normal_gain_pn_per_v;
    f->lateral_gain_pn_per_v = lateral_gain_pn_per_v;
    f->two_h_over_l = (q30_t)force_two_h_over_l_q30(tip_height_nm, lever_length_nm);
    f->mu = (q30_t)force_mu_q30(mu_ppm);
    f->adhesion_pn = adhesion_pn;
    f->fast = normal_gain_pn_per_v <= FW_FORCE_FAST_GAIN_MAX_PN_PER_V
              && lateral_gain_pn_per_v <= FW_FORCE_FAST_GAIN_MAX_PN_PER_V
              && adhesion_pn <= FW_FORCE_FAST_ADHESION_MAX_PN;
    return FW_OK;
}

void fw_force_dir_fit(int32_t *dir_x, int32_t *dir_y)
{
    int64_t x = *dir_x;
    int64_t y = *dir_y;
    uint64_t ax = (uint64_t)(x < 0 ? -x : x);
    uint64_t ay = (uint64_t)(y < 0 ? -y : y);
    if (ax > (uint64_t)FW_FORCE_DIR_MAX || ay > (uint64_t)FW_FORCE_DIR_MAX) {
        int sh = 49 - fw_math_clz_u64(ax | ay);   /* (ax | ay) >> sh in [2^14, 2^15) */
        *dir_x = (int32_t)fw_math_rshift_round_i64(x, sh);
        *dir_y = (int32_t)fw_math_rshift_round_i64(y, sh);
    }
}

fw_status_t fw_force_solve_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v,
                              int32_t dir_x, int32_t dir_y,
                              int32_t force_c_pn[3], uint32_t *flags)
{
    if (f == NULL || force_c_pn == NULL || flags == NULL) {
        return FW_ERR_ARG;
    }
    fw_force_dir_fit(&dir_x, &dir_y);
    fw_force_solve_fit_pn(f, sn_v, sl_v, dir_x, dir_y, force_c_pn, flags);
    return FW_OK;
}

void fw_force_rotate_pn(const int32_t v_c[3], q30_t cos_a, q30_t sin_a,
                        int32_t v_a[3], bool *sat)
{
    int32_t x;
    int32_t y;
    fw_math_rotate_i32(v_c[0], v_c[1], cos_a, sin_a, &x, &y, sat);
    v_a[0] = x;
    v_a[1] = y;
    v_a[2] = v_c[2];
}

int64_t fw_force_lateral_excess_pn(const fw_force_t *f, const int32_t force_pn[3])
{
    uint64_t fxy2 = (uint64_t)((int64_t)force_pn[0] * force_pn[0])
                    + (uint64_t)((int64_t)force_pn[1] * force_pn[1]);
    int64_t base = fw_math_rshift_round_i64((int64_t)f->mu * ((int64_t)force_pn[2] + f->adhesion_pn),
                                            FW_Q30_FRAC);
    return (int64_t)fw_math_isqrt_u64(fxy2) - (base < 0 ? 0 : base);
}
