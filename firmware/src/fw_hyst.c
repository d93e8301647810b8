/*
 * fw_hyst.c - see fw_hyst.h.
 */
#include "fw_hyst.h"
#include "fw_math.h"

fw_rule_t fw_hyst_check(const fw_hyst_params_t *p)
{
    int64_t W = 0;
    int32_t i;
    if (p == NULL) {
        return FW_RULE_NULL_POINTER;
    }
    if (p->n < 1 || p->n > FW_HYST_N_MAX || p->range_pm <= 0 || p->range_pm > FW_HYST_RANGE_MAX_PM
        || p->origin_pm < -FW_HYST_ORIGIN_MAX_PM || p->origin_pm > FW_HYST_ORIGIN_MAX_PM || p->r_pm[0] != 0) {
        return FW_RULE_HYST;
    }
    for (i = 0; i < p->n; i++) {
        if (i > 0 && p->r_pm[i] <= p->r_pm[i - 1]) {
            return FW_RULE_HYST;
        }
        W += p->w_q24[i];
        if (W < FW_HYST_SLOPE_MIN_Q24 || W > FW_HYST_SLOPE_MAX_Q24) {
            return FW_RULE_HYST;
        }
    }
    return (p->r_pm[p->n - 1] > p->range_pm) ? FW_RULE_HYST : FW_RULE_OK;
}

fw_status_t fw_hyst_init(fw_hyst_t *h, const fw_hyst_params_t *p)
{
    fw_rule_t rule = fw_hyst_check(p);
    int64_t W = 0;        /* W_i, 8.24 */
    int64_t acc = 0;      /* r'_i (then y_max) times 2^24, exact */
    int32_t s_prev = 0;   /* 1/W_{i-1}, 8.24 */
    int32_t i;
    if (h == NULL || rule != FW_RULE_OK) {
        return (h == NULL) ? FW_ERR_ARG : fw_rule_status(rule);
    }
    h->p = *p;
    for (i = 0; i < p->n; i++) {
        int32_t s;
        if (i > 0) {
            acc += W * ((int64_t)p->r_pm[i] - p->r_pm[i - 1]);   /* r'_i = r'_{i-1} + W_{i-1} (r_i - r_{i-1}) */
        }
        W += p->w_q24[i];
        s = (int32_t)fw_math_div_round_i64((int64_t)1 << (2 * FW_Q24_FRAC), W);
        h->wi_q24[i] = s - s_prev;
        s_prev = s;
        h->ri_pm[i] = (int32_t)fw_math_rshift_round_i64(acc, FW_Q24_FRAC);
    }
    /* y_max = sum_j w_j (R - r_j) = r'_{n-1} + W_{n-1} (R - r_{n-1}) */
    acc += W * ((int64_t)p->range_pm - p->r_pm[p->n - 1]);
    h->y_max_pm = (int32_t)fw_math_rshift_round_i64(acc, FW_Q24_FRAC);
    fw_hyst_reset(h);
    return FW_OK;
}

void fw_hyst_reset(fw_hyst_t *h)
{
    int32_t i;
    for (i = 0; i < FW_HYST_N_MAX; i++) {
        h->z_pm[i] = 0;
        h->zi_pm[i] = 0;
    }
    h->sat = false;
    h->sat_count = 0;
}

/* v clamped to [-lim, lim] (lim >= 0); a clamp sets h's flag and *sat
 * (may be NULL) and counts. */
static int32_t hyst_clamp(fw_hyst_t *h, int64_t v, int32_t lim, bool *sat)
{
    if (v >= -(int64_t)lim && v <= lim) {
        return (int32_t)v;
    }
    if (sat != NULL) {
        *sat = true;
    }
    h->sat = true;
    if (h->sat_count != UINT32_MAX) {
        h->sat_count++;
    }
    return (v < 0) ? -lim : lim;
}

/* One step of a PI model: every play moved by x (pm about the origin),
 * the weighted sum in 8.24 times pm, exact in int64 (fw_hyst.h's bounds). */
static int64_t hyst_pi_step(int32_t n, const int32_t *r_pm, const q24_t *w_q24, int32_t *z_pm, int32_t x)
{
    int64_t acc = 0;
    int32_t i;
    for (i = 0; i < n; i++) {
        int32_t z = z_pm[i];
        const int32_t lo = x - r_pm[i];
        const int32_t hi = x + r_pm[i];
        z = (z > hi) ? hi : ((z < lo) ? lo : z);
        z_pm[i] = z;
        acc += (int64_t)w_q24[i] * z;
    }
    return acc;
}

int32_t fw_hyst_direct_pm(fw_hyst_t *h, int32_t x_pm, bool *sat)
{
    const int32_t x = hyst_clamp(h, (int64_t)x_pm - h->p.origin_pm, h->p.range_pm, sat);
    const int64_t y = fw_math_rshift_round_i64(hyst_pi_step(h->p.n, h->p.r_pm, h->p.w_q24, h->z_pm, x), FW_Q24_FRAC);
    return (int32_t)(y + h->p.origin_pm);
}

int32_t fw_hyst_inverse_pm(fw_hyst_t *h, int32_t y_pm, bool *sat)
{
    const int32_t y = hyst_clamp(h, (int64_t)y_pm - h->p.origin_pm, h->y_max_pm, sat);
    const int64_t x = fw_math_rshift_round_i64(hyst_pi_step(h->p.n, h->ri_pm, h->wi_q24, h->zi_pm, y), FW_Q24_FRAC);
    return (int32_t)(hyst_clamp(h, x, h->p.range_pm, sat) + (int64_t)h->p.origin_pm);
}
