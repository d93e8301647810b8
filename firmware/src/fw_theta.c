/*
 * fw_theta.c - see fw_theta.h.
 */
#include "fw_theta.h"
#include "fw_math.h"

fw_rule_t fw_theta_check(int32_t min_disp_pm)
{
    return (min_disp_pm < 0) ? FW_RULE_THETA_MIN_DISP : FW_RULE_OK;
}

fw_status_t fw_theta_init(fw_theta_t *t, int32_t min_disp_pm)
{
    fw_rule_t rule = fw_theta_check(min_disp_pm);
    if (t == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    t->min_disp_pm = (min_disp_pm == 0) ? FW_THETA_MIN_DISP_DEFAULT_PM : min_disp_pm;
    t->min_disp2_pm2 = (uint64_t)t->min_disp_pm * (uint64_t)t->min_disp_pm;
    fw_theta_reset(t);
    return FW_OK;
}

void fw_theta_reset(fw_theta_t *t)
{
    int32_t i;
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        t->x_pm[i] = 0;
        t->y_pm[i] = 0;
    }
    t->pos = 0;
    t->fill = 0;
    t->dir_x = 0;
    t->dir_y = 1;
    t->cos_theta = 0;
    t->sin_theta = FW_Q15_MAX;
    t->known = false;
}

void fw_theta_prime(fw_theta_t *t, const int32_t apex_pm[2])
{
    int32_t i;
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        t->x_pm[i] = apex_pm[0];
        t->y_pm[i] = apex_pm[1];
    }
    t->fill = FW_THETA_WINDOW;
}

void fw_theta_step(fw_theta_t *t, const int32_t apex_pm[2], q30_t cos_a, q30_t sin_a,
                   uint32_t *flags)
{
    cos_a = (cos_a > FW_Q30_ONE) ? FW_Q30_ONE : ((cos_a < -FW_Q30_ONE) ? -FW_Q30_ONE : cos_a);
    sin_a = (sin_a > FW_Q30_ONE) ? FW_Q30_ONE : ((sin_a < -FW_Q30_ONE) ? -FW_Q30_ONE : sin_a);
    if (fw_theta_push_pm(t, apex_pm, cos_a, sin_a, flags)) {
        q15_t c;
        q15_t s;
        if (fw_math_unit_q15(t->dir_x, t->dir_y, &c, &s)) {
            t->cos_theta = c;
            t->sin_theta = s;
        }
    }
}
