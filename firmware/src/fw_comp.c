/*
 * fw_comp.c - see fw_comp.h.
 */
#include "fw_comp.h"
#include "fw_math.h"

/* kappa (16.16) * joy (1.15): 17.31 product, shifted by 31 to the unit of
 * half_range. */
#define COMP_TARGET_SHIFT (FW_Q16_FRAC + FW_Q15_FRAC)
/* cos, sin alpha (2.30) times C (pm/V) to FW_COMP_M_FRAC fraction bits */
#define COMP_M_SHIFT (FW_Q30_FRAC - FW_COMP_M_FRAC)

fw_rule_t fw_comp_check(int32_t disp_n_pm_per_v, int32_t disp_l_pm_per_v, int32_t half_range_pm, q16_t kappa)
{
    if (disp_n_pm_per_v < 0 || disp_l_pm_per_v < 0) {
        return FW_RULE_DISP_NEGATIVE;
    }
    if (disp_n_pm_per_v > FW_COMP_C_MAX_PM_PER_V || disp_l_pm_per_v > FW_COMP_C_MAX_PM_PER_V) {
        return FW_RULE_DISP_RANGE;
    }
    if (half_range_pm < 0 || kappa < 0) {
        return FW_RULE_JOYSTICK_RANGE;
    }
    return FW_RULE_OK;
}

fw_status_t fw_comp_init(fw_comp_t *c, int32_t disp_n_pm_per_v, int32_t disp_l_pm_per_v,
                         fw_bam_t alpha, const int32_t center_pm[2],
                         int32_t half_range_pm, q16_t kappa)
{
    fw_rule_t rule = fw_comp_check(disp_n_pm_per_v, disp_l_pm_per_v, half_range_pm, kappa);
    if (c == NULL || center_pm == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    fw_math_sincos_q30(alpha, &c->sin_a, &c->cos_a);
    /* M = R(alpha) diag(C_n, C_l): |C cos| <= 2^52, rounded to 2^-8 pm/V,
     * |m| <= 2^30 */
    c->m[0][0] = (int32_t)fw_math_rshift_round_i64((int64_t)c->cos_a * disp_n_pm_per_v, COMP_M_SHIFT);
    c->m[0][1] = (int32_t)fw_math_rshift_round_i64(-(int64_t)c->sin_a * disp_l_pm_per_v, COMP_M_SHIFT);
    c->m[1][0] = (int32_t)fw_math_rshift_round_i64((int64_t)c->sin_a * disp_n_pm_per_v, COMP_M_SHIFT);
    c->m[1][1] = (int32_t)fw_math_rshift_round_i64((int64_t)c->cos_a * disp_l_pm_per_v, COMP_M_SHIFT);
    c->center_pm[0] = center_pm[0];
    c->center_pm[1] = center_pm[1];
    c->half_range_pm = half_range_pm;
    c->kappa = kappa;
    c->fast = disp_n_pm_per_v <= FW_COMP_FAST_C_MAX_PM_PER_V && disp_l_pm_per_v <= FW_COMP_FAST_C_MAX_PM_PER_V;
    return FW_OK;
}

void fw_comp_target_pm(const fw_comp_t *c, const q15_t joy[2], int32_t target_pm[2], bool *sat)
{
    int i;
    /* hk = half_range * kappa < 2^62 (pm, 16.16); hk * joy / 2^31 is
     * split as hk = hi 2^31 + lo, lo in [0, 2^31), so both products stay
     * below 2^46 and the rounding of the whole is exact. */
    int64_t hk = (int64_t)c->half_range_pm * c->kappa;
    int64_t hi = fw_math_asr_i64(hk, COMP_TARGET_SHIFT);
    int64_t lo = hk - hi * ((int64_t)1 << COMP_TARGET_SHIFT);
    for (i = 0; i < 2; i++) {
        int64_t off = hi * joy[i] + fw_math_rshift_round_i64(lo * joy[i], COMP_TARGET_SHIFT);
        target_pm[i] = fw_math_sat_i32((int64_t)c->center_pm[i] + off, sat);
    }
}

void fw_comp_piezo_cmd_pm(const fw_comp_t *c, const q15_t joy[2], q23_t sn_v, q23_t sl_v,
                          int32_t piezo_pm[2], bool *sat)
{
    int32_t target[2];
    int32_t off[3];
    int i;
    fw_comp_target_pm(c, joy, target, sat);
    fw_comp_offset_pm(c, sn_v, sl_v, off);
    for (i = 0; i < 2; i++) {
        piezo_pm[i] = fw_math_sat_i32((int64_t)target[i] - off[i], sat);
    }
}

void fw_comp_code_gains(const fw_comp_t *c, const fw_acq_t *acq_n, const fw_acq_t *acq_l,
                        fw_comp_code_gains_t *g)
{
    const int shift = FW_Q23_FRAC + FW_COMP_M_FRAC;
    int i;
    for (i = 0; i < 2; i++) {
        fw_acq_gain_t gn = fw_acq_gain(acq_n, c->m[i][0], shift);
        fw_acq_gain_t gl = fw_acq_gain(acq_l, c->m[i][1], shift);
        g->mul[i][0] = gn.mul;
        g->mul[i][1] = gl.mul;
        g->add[i] = gn.add + gl.add - ((int64_t)1 << (shift - 1));
    }
}
