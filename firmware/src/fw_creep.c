/*
 * fw_creep.c - see fw_creep.h.
 */
#include "fw_creep.h"
#include "fw_math.h"

/* The terms of L(t) = log10(t / t0), t >= t0: weights c_k (8.24) and time
 * constants rho_k = tau_k / t0 (16.16), the minimax fit over [t0, 10^3 t0]
 * printed by analysis/scanner_fit.py creep_terms(4): c = -0.34076,
 * 1.03125, 1.03951, 1.34551; rho = 0.085785, 2.6667, 28.739, 379.26. */
static const q24_t creep_c_q24[FW_CREEP_TERMS] = { -5716981, 17301577, 17440151, 22573879 };
static const int32_t creep_rho_q16[FW_CREEP_TERMS] = { 5622, 174768, 1883471, 24854900 };

/* alpha_k's series: 1 - exp(-x) = x - x^2/2 + x^3/6 - ..., 12 terms. */
#define CREEP_SERIES_TERMS 12

fw_rule_t fw_creep_check(const fw_creep_params_t *p)
{
    if (p == NULL) {
        return FW_RULE_NULL_POINTER;
    }
    if (p->gamma_ppm < 0 || p->gamma_ppm > FW_CREEP_GAMMA_MAX_PPM || p->t0_us < FW_CREEP_T0_MIN_US
        || p->t0_us > FW_CREEP_T0_MAX_US || p->period_us <= 0 || p->period_us > p->t0_us / 16) {
        return FW_RULE_CREEP;
    }
    return FW_RULE_OK;
}

/* 1 - exp(-x) in 1.31 for x in [0, 1) in 1.31 (fw_creep_init's series). */
static q31_t creep_one_minus_exp_q31(int64_t x)
{
    int64_t term = x;   /* x^n / n!, 1.31 */
    int64_t sum = 0;
    int32_t n;
    for (n = 1; n <= CREEP_SERIES_TERMS; n++) {
        sum += (n % 2 == 1) ? term : -term;
        term = fw_math_rshift_round_i64(term * x, FW_Q31_FRAC) / (n + 1);
    }
    return (q31_t)sum;
}

fw_status_t fw_creep_init(fw_creep_t *c, const fw_creep_params_t *p)
{
    fw_rule_t rule = fw_creep_check(p);
    int64_t x;
    int32_t k;
    if (c == NULL || rule != FW_RULE_OK) {
        return (c == NULL) ? FW_ERR_ARG : fw_rule_status(rule);
    }
    c->p = *p;
    x = fw_math_div_round_i64((int64_t)p->period_us << FW_Q31_FRAC, p->t0_us);   /* T / t0, 1.31 */
    for (k = 0; k < FW_CREEP_TERMS; k++) {
        const int64_t xk = fw_math_div_round_i64(x << FW_Q16_FRAC, creep_rho_q16[k]);
        c->alpha_q31[k] = creep_one_minus_exp_q31(xk);
        c->a_q31[k] = (q31_t)fw_math_div_round_i64((int64_t)p->gamma_ppm * creep_c_q24[k]
                                                       * ((int64_t)1 << (FW_Q31_FRAC - FW_Q24_FRAC)),
                                                   FW_PPM_PER_ONE);
    }
    fw_creep_reset(c);
    return FW_OK;
}

void fw_creep_reset(fw_creep_t *c)
{
    int32_t k;
    for (k = 0; k < FW_CREEP_TERMS; k++) {
        c->e_q16[k] = 0;
    }
    c->first_pm = 0;
    c->primed = false;
    c->sat = false;
    c->sat_count = 0;
}

/* round(e a / 2^31) for |e| <= 2^47, |a| <= 2^31, exactly: e = hi 2^16 +
 * lo (0 <= lo < 2^16), e a / 2^31 = (hi a + lo a / 2^16) / 2^15, and the
 * fraction of lo a / 2^16 cannot carry the floor past an integer. */
static int64_t creep_mul_q31(int64_t e, q31_t a)
{
    const int64_t hi = fw_math_asr_i64(e, 16);
    const int64_t lo = e - hi * 65536;
    const int64_t s = hi * a + fw_math_asr_i64(lo * a, 16);
    return fw_math_asr_i64(s + ((int64_t)1 << 14), 15);
}

static void creep_flag(fw_creep_t *c, bool *sat)
{
    if (sat != NULL) {
        *sat = true;
    }
    c->sat = true;
    if (c->sat_count != UINT32_MAX) {
        c->sat_count++;
    }
}

/* sum_k a_k e_k, pm with 16 fraction bits (fw_creep_step_pm's scaling). */
static int64_t creep_sum_q16(const fw_creep_t *c)
{
    int64_t corr = 0;
    int32_t k;
    for (k = 0; k < FW_CREEP_TERMS; k++) {
        corr += creep_mul_q31(c->e_q16[k], c->a_q31[k]);
    }
    return corr;
}

/* One period with the command u held: the first since reset is the rest
 * position; the states move towards u's deviation from it, clamped (sat). */
static void creep_advance(fw_creep_t *c, int32_t u_pm, bool clamped, bool *sat)
{
    int64_t dev = (int64_t)u_pm - c->first_pm;
    int32_t k;
    if (dev > FW_CREEP_DEV_MAX_PM || dev < -(int64_t)FW_CREEP_DEV_MAX_PM) {
        dev = (dev < 0) ? -(int64_t)FW_CREEP_DEV_MAX_PM : FW_CREEP_DEV_MAX_PM;
        clamped = true;
    }
    if (clamped) {
        creep_flag(c, sat);
    }
    for (k = 0; k < FW_CREEP_TERMS; k++) {
        c->e_q16[k] += creep_mul_q31(dev * 65536 - c->e_q16[k], c->alpha_q31[k]);
    }
}

static void creep_prime(fw_creep_t *c, int32_t pm)
{
    if (!c->primed) {
        c->first_pm = pm;
        c->primed = true;
    }
}

int32_t fw_creep_step_pm(fw_creep_t *c, int32_t r_pm, bool *sat)
{
    bool clamped = false;
    int32_t out;
    creep_prime(c, r_pm);
    out = fw_math_sat_i32((int64_t)r_pm - fw_math_rshift_round_i64(creep_sum_q16(c), 16), &clamped);
    creep_advance(c, out, clamped, sat);
    return out;
}

int32_t fw_creep_follow_pm(fw_creep_t *c, int32_t u_pm, bool *sat)
{
    bool clamped = false;
    int32_t off;
    creep_prime(c, u_pm);
    off = fw_math_sat_i32(fw_math_rshift_round_i64(creep_sum_q16(c), 16), &clamped);
    creep_advance(c, u_pm, clamped, sat);
    return off;
}
