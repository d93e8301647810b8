/*
 * fw_kalman.c - see fw_kalman.h.
 */
#include "fw_kalman.h"
#include "fw_math.h"

#define KALMAN_US_PER_S 1000000
#define KALMAN_Q16_ONE ((int64_t)1 << FW_Q16_FRAC)
#define KALMAN_D_MAX_Q16 ((int64_t)INT32_MAX * KALMAN_Q16_ONE)
#define KALMAN_D_MIN_Q16 ((int64_t)INT32_MIN * KALMAN_Q16_ONE)

fw_rule_t fw_kalman_check(const fw_kalman_params_t *p)
{
    if (p == NULL) {
        return FW_RULE_NULL_POINTER;
    }
    if (p->period_us <= 0 || p->period_us > FW_KALMAN_PERIOD_MAX_US || p->walk_nm2_per_s < 0
        || p->vel_prior_nm2_per_s2 < 0) {
        return FW_RULE_DRIFT_KALMAN;
    }
    return FW_RULE_OK;
}

fw_status_t fw_kalman_init(fw_kalman_t *k, const fw_kalman_params_t *p)
{
    fw_rule_t rule = fw_kalman_check(p);
    if (k == NULL || rule != FW_RULE_OK) {
        return FW_ERR_ARG;
    }
    k->p = *p;
    fw_kalman_reset(k);
    return FW_OK;
}

void fw_kalman_reset(fw_kalman_t *k)
{
    k->d_pm_q16 = 0;
    k->v_pm_per_s = 0;
    k->gap_us = 0u;
    k->p_dd = 0;
    k->p_dv = 0;
    k->p_vv = k->p.vel_prior_nm2_per_s2;
    k->updates = 0u;
    k->refused = 0u;
    k->sat = false;
    k->sat_count = 0u;
}

static void kalman_saturated(fw_kalman_t *k)
{
    k->sat = true;
    if (k->sat_count != UINT32_MAX) {
        k->sat_count++;
    }
}

/* v clamped to [lo, hi], counted when it clamps. */
static int64_t kalman_clamp(fw_kalman_t *k, int64_t v, int64_t lo, int64_t hi)
{
    if (v < lo || v > hi) {
        kalman_saturated(k);
        return (v < lo) ? lo : hi;
    }
    return v;
}

static int kalman_bits(int64_t v)
{
    const uint64_t m = (v < 0) ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
    return 64 - fw_math_clz_u64(m);
}

/* round(a b / 2^16) for 48.16 operands within +-2^47. Scaling and
 * overflow: the 64-bit product when the operands' bit lengths sum to at
 * most 62 (|a b| < 2^62), else +-P_MAX (the product's sign), counted. */
static int64_t kalman_mul_q16(fw_kalman_t *k, int64_t a, int64_t b)
{
    if (a == 0 || b == 0) {
        return 0;
    }
    if (kalman_bits(a) + kalman_bits(b) > 62) {
        kalman_saturated(k);
        return ((a < 0) != (b < 0)) ? -FW_KALMAN_P_MAX : FW_KALMAN_P_MAX;
    }
    return fw_math_rshift_round_i64(a * b, FW_Q16_FRAC);
}

void fw_kalman_advance_us(fw_kalman_t *k, int32_t dt_us)
{
    uint32_t room;
    if (k == NULL || dt_us <= 0) {
        return;
    }
    room = FW_KALMAN_GAP_MAX_US - k->gap_us;
    if ((uint32_t)dt_us > room) {
        k->gap_us = FW_KALMAN_GAP_MAX_US;
        kalman_saturated(k);
        return;
    }
    k->gap_us += (uint32_t)dt_us;
}

void fw_kalman_predict(fw_kalman_t *k)
{
    if (k != NULL) {
        fw_kalman_advance_us(k, k->p.period_us);
    }
}

/* d + v gap in 48.16 pm, unclamped (|v gap / 10^6| < 2^46, |d| <= 2^47). */
static int64_t kalman_drift_q16(const fw_kalman_t *k)
{
    const int64_t moved = fw_math_div_round_i64((int64_t)k->v_pm_per_s * (int64_t)k->gap_us, KALMAN_US_PER_S);
    return k->d_pm_q16 + moved;
}

int32_t fw_kalman_drift_pm(fw_kalman_t *k)
{
    bool sat = false;
    int32_t d;
    if (k == NULL) {
        return 0;
    }
    d = fw_math_sat_i32(fw_math_rshift_round_i64(kalman_drift_q16(k), FW_Q16_FRAC), &sat);
    if (sat) {
        kalman_saturated(k);
    }
    return d;
}

void fw_kalman_covariance(fw_kalman_t *k, int64_t *dd, int64_t *dv, int64_t *vv)
{
    const int64_t pm = FW_KALMAN_P_MAX;
    int64_t t;
    int64_t tvv;
    int64_t inner;
    int64_t pdd;
    if (k == NULL) {
        return;
    }
    t = fw_math_div_round_i64((int64_t)k->gap_us << FW_Q16_FRAC, KALMAN_US_PER_S);   /* s, 16.16 */
    tvv = kalman_mul_q16(k, t, k->p_vv);                                              /* T P_vv */
    inner = kalman_clamp(k, 2 * k->p_dv + tvv, -pm, pm);                               /* 2 P_dv + T P_vv */
    pdd = kalman_clamp(k, k->p_dd + kalman_mul_q16(k, t, inner), 0, pm);
    pdd = kalman_clamp(k, pdd + kalman_mul_q16(k, t, k->p.walk_nm2_per_s), 0, pm);
    if (dd != NULL) {
        *dd = pdd;
    }
    if (dv != NULL) {
        *dv = kalman_clamp(k, k->p_dv + tvv, -pm, pm);
    }
    if (vv != NULL) {
        *vv = k->p_vv;
    }
}

fw_status_t fw_kalman_update(fw_kalman_t *k, int32_t z_pm, q16_t r_nm2)
{
    const int64_t pm = FW_KALMAN_P_MAX;
    int64_t pdd, pdv, pvv, s, kd, kv, y, d;
    if (k == NULL) {
        return FW_ERR_ARG;
    }
    if (r_nm2 < 0) {
        if (k->refused != UINT32_MAX) {
            k->refused++;
        }
        return FW_ERR_ARG;
    }
    fw_kalman_covariance(k, &pdd, &pdv, &pvv);
    d = kalman_drift_q16(k);
    y = (int64_t)z_pm - fw_math_rshift_round_i64(d, FW_Q16_FRAC);
    s = pdd + r_nm2;
    s = (s < 1) ? 1 : s;
    kd = fw_math_div_round_i64(pdd << FW_Q16_FRAC, s);
    kv = fw_math_div_round_i64(pdv * KALMAN_Q16_ONE, s);
    k->d_pm_q16 = kalman_clamp(k, d + kd * y, KALMAN_D_MIN_Q16, KALMAN_D_MAX_Q16);
    /* K_v y: gain 16.16 (1/s) times pm is pm/s in 16.16, as v */
    k->v_pm_per_s = (q16_t)kalman_clamp(k, (int64_t)k->v_pm_per_s + kalman_mul_q16(k, kv, y * KALMAN_Q16_ONE),
                                        INT32_MIN, INT32_MAX);
    k->p_dd = kalman_clamp(k, pdd - kalman_mul_q16(k, kd, pdd), 0, pm);
    k->p_dv = kalman_clamp(k, pdv - kalman_mul_q16(k, kd, pdv), -pm, pm);
    k->p_vv = kalman_clamp(k, pvv - kalman_mul_q16(k, kv, pdv), 0, pm);
    k->gap_us = 0u;
    if (k->updates != UINT32_MAX) {
        k->updates++;
    }
    return FW_OK;
}

void fw_kalman_shift_pm(fw_kalman_t *k, int32_t delta_pm)
{
    if (k != NULL) {
        k->d_pm_q16 = kalman_clamp(k, k->d_pm_q16 + (int64_t)delta_pm * KALMAN_Q16_ONE, KALMAN_D_MIN_Q16, KALMAN_D_MAX_Q16);
    }
}
