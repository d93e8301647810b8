/*
 * fw_litho.c - see fw_litho.h.
 */
#include "fw_litho.h"
#include "fw_math.h"

#define LITHO_GAMMA_MAX_MDEG 60000   /* tan 60 deg = 1.73 fits 2.30 */

fw_rule_t fw_litho_check(int32_t threshold_pn, q16_t depth_pm_per_pn, int32_t gamma_mdeg, int32_t min_step_pm)
{
    if (threshold_pn < 0 || depth_pm_per_pn < 0 || min_step_pm <= 0) {
        return FW_RULE_LITHO;
    }
    if (gamma_mdeg <= 0 || gamma_mdeg >= LITHO_GAMMA_MAX_MDEG) {
        return FW_RULE_TIP_HALF_ANGLE;
    }
    return FW_RULE_OK;
}

fw_status_t fw_litho_init(fw_litho_t *l, fw_trench_point_t *storage, int32_t capacity,
                          int32_t threshold_pn, q16_t depth_pm_per_pn, int32_t gamma_mdeg,
                          int32_t min_step_pm)
{
    q30_t s;
    q30_t c;
    fw_rule_t rule = fw_litho_check(threshold_pn, depth_pm_per_pn, gamma_mdeg, min_step_pm);
    if (l == NULL || storage == NULL || capacity <= 0) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    fw_math_sincos_q30(fw_math_bam_from_mdeg(gamma_mdeg), &s, &c);
    l->pts = storage;
    l->capacity = capacity;
    l->threshold_pn = threshold_pn;
    l->depth_pm_per_pn = depth_pm_per_pn;
    l->tan_gamma = (q30_t)fw_math_div_round_i64((int64_t)s * FW_Q30_ONE, c);
    l->min_step_pm = min_step_pm;
    fw_litho_reset(l);
    return FW_OK;
}

void fw_litho_reset(fw_litho_t *l)
{
    int32_t i;
    for (i = 0; i < l->capacity; i++) {
        l->pts[i].x_pm = 0;
        l->pts[i].y_pm = 0;
        l->pts[i].depth_pm = 0;
        l->pts[i].width_pm = 0;
        l->pts[i].flags = 0;
    }
    l->count = 0;
    l->in_stroke = false;
    l->last_pm[0] = 0;
    l->last_pm[1] = 0;
    l->overflow = false;
    l->dropped = 0;
}

fw_status_t fw_litho_step(fw_litho_t *l, const int32_t tip_pm[3], int32_t load_pn)
{
    fw_trench_point_t *p;
    int64_t excess;
    int32_t depth;
    uint32_t flags = 0;
    if (l == NULL || tip_pm == NULL) {
        return FW_ERR_ARG;
    }
    if (load_pn <= l->threshold_pn) {
        l->in_stroke = false;
        return FW_OK;
    }
    if (!l->in_stroke) {
        flags = FW_LITHO_STROKE_START;
    } else {
        int64_t dx = (int64_t)tip_pm[0] - l->last_pm[0];
        int64_t dy = (int64_t)tip_pm[1] - l->last_pm[1];
        int64_t step = l->min_step_pm;
        /* |dx|, |dy| < 2^32: compare per axis first so the squares fit */
        if (dx < step && -dx < step && dy < step && -dy < step
            && dx * dx + dy * dy < step * step) {
            return FW_OK;
        }
    }
    l->in_stroke = true;
    l->last_pm[0] = tip_pm[0];
    l->last_pm[1] = tip_pm[1];
    if (l->count >= l->capacity) {
        l->overflow = true;
        if (l->dropped != UINT32_MAX) {
            l->dropped++;
        }
        return FW_ERR_CAPACITY;
    }
    excess = (int64_t)load_pn - l->threshold_pn;                 /* < 2^32 */
    depth = fw_math_sat_i32(fw_math_rshift_round_i64(excess * l->depth_pm_per_pn, FW_Q16_FRAC), NULL);
    p = &l->pts[l->count];
    p->x_pm = tip_pm[0];
    p->y_pm = tip_pm[1];
    p->depth_pm = depth;
    p->width_pm = fw_math_sat_i32(
        fw_math_rshift_round_i64(2 * (int64_t)depth * l->tan_gamma, FW_Q30_FRAC), NULL);
    p->flags = flags;
    l->count++;
    return FW_OK;
}

void fw_litho_shift(fw_litho_t *l, int32_t dx_pm, int32_t dy_pm)
{
    int32_t i;
    if (l == NULL) {
        return;
    }
    for (i = 0; i < l->count; i++) {
        l->pts[i].x_pm = fw_math_sat_i32((int64_t)l->pts[i].x_pm + dx_pm, NULL);
        l->pts[i].y_pm = fw_math_sat_i32((int64_t)l->pts[i].y_pm + dy_pm, NULL);
    }
    l->last_pm[0] = fw_math_sat_i32((int64_t)l->last_pm[0] + dx_pm, NULL);
    l->last_pm[1] = fw_math_sat_i32((int64_t)l->last_pm[1] + dy_pm, NULL);
}
