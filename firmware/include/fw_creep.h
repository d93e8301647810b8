/*
 * fw_creep.h - a scanner axis's creep, compensated by pre-shaping the
 * command (feed-forward).
 *
 * The law: after a step D of the command at time 0 the position keeps
 * moving as
 *
 *   y(t) = D (1 + gamma L(t)),   L(t) = log10(t / t0) for t >= t0, 0 before,
 *
 * gamma the creep per decade of time (a fraction of the step), and steps
 * add (a linear law: the creep of a command u(t) is the sum of its steps'
 * creeps). Approximated by FW_CREEP_TERMS first-order terms,
 *
 *   L(t) ~ sum_k c_k (1 - exp(-t / tau_k)),   tau_k = rho_k t0,
 *
 * (c_k, rho_k) the minimax fit of L over t in [t0, 10^3 t0], made once on
 * the host (analysis/scanner_fit.py, creep_terms) and kept here as
 * constants (fw_creep.c): there the sum is within 0.021 of L, i.e. the
 * modelled creep within 0.021 gamma D of the law's over 3 decades; before
 * t0, where the law is flat, within 0.23 gamma D; past 10^3 t0 the model
 * holds at gamma D sum c_k (3.08 gamma D) while the law grows on by gamma
 * D a decade, uncompensated.
 *
 * The scanner so modelled is y = u + sum_k a_k e_k, a_k = gamma c_k, e_k
 * the command's deviation from its first value low-passed with tau_k. The
 * feed-forward inverts it: for the wanted position r each period,
 *
 *   u = r - sum_k a_k e_k,   then e_k += alpha_k ((u - u_first) - e_k),
 *   alpha_k = 1 - exp(-T / tau_k)  (T the period: exact for a command held
 *   over the period),
 *
 * stable for every gamma in the domain (sum_k |a_k| <= 0.38 < 1: the loop
 * gain stays below 1). The first command is the rest position: no creep
 * is owed for it (the scanner is taken to have settled there).
 *
 * Units and formats: positions pm (int32); gamma ppm of the step per
 * decade; t0 and T microseconds; c_k 8.24, rho_k 16.16, a_k and alpha_k
 * 1.31; the states e_k pm with 16 fraction bits (int64). Domain, checked by
 * fw_creep_check: gamma in [0, FW_CREEP_GAMMA_MAX_PPM]; t0 in
 * [FW_CREEP_T0_MIN_US, FW_CREEP_T0_MAX_US]; 0 < T <= t0 / 16 (so T / tau_k
 * <= 0.73).
 *
 * Out of range: the command is saturated to int32 and its deviation from
 * the first command to +-FW_CREEP_DEV_MAX_PM (the instance's sticky flag
 * sat, the caller's *sat, sticky, the pointer may be NULL; sat_count,
 * saturating). Nothing counts time, so no time can wrap: at long times the
 * states converge to the deviation and stay there.
 */
#ifndef FW_CREEP_H
#define FW_CREEP_H

#include "fw_types.h"
#include "fw_rules.h"

#define FW_CREEP_TERMS 4
#define FW_CREEP_GAMMA_MAX_PPM 100000          /* 10 % of the step per decade */
#define FW_CREEP_T0_MIN_US 1000                /* 1 ms */
#define FW_CREEP_T0_MAX_US 100000000           /* 100 s */
#define FW_CREEP_DEV_MAX_PM ((int32_t)1 << 30) /* 1.07 mm */

typedef struct {
    int32_t gamma_ppm;   /* creep per decade of time, ppm of the step */
    int32_t t0_us;       /* the log law's time origin, us */
    int32_t period_us;   /* T: the time between two steps (the card's block), us */
} fw_creep_params_t;

typedef struct {
    fw_creep_params_t p;
    q31_t a_q31[FW_CREEP_TERMS];       /* a_k = gamma c_k, 1.31 */
    q31_t alpha_q31[FW_CREEP_TERMS];   /* 1 - exp(-T / tau_k), 1.31 */
    int64_t e_q16[FW_CREEP_TERMS];     /* the terms' states, pm with 16 fraction bits */
    int32_t first_pm;                  /* the first command since reset */
    bool primed;                       /* first_pm holds it */
    bool sat;                          /* sticky: a command or deviation was clamped since reset */
    uint32_t sat_count;                /* clamps since reset (saturating) */
} fw_creep_t;

/* FW_RULE_CREEP for parameters outside the domain above (NULL:
 * FW_RULE_NULL_POINTER). */
fw_rule_t fw_creep_check(const fw_creep_params_t *p);

/* Validates with fw_creep_check (its rule's status: FW_ERR_ARG); forms
 * a_k and alpha_k, and resets.
 * Scaling and overflow: a_k = round(gamma c_k 2^7 / 10^6): |gamma c_k 2^7|
 * <= 2^17 2^25 2^7 in int64, |a_k| <= 0.14 in 1.31. x = T / t0 =
 * round(T 2^31 / t0) (<= 2^27, T < 2^31 so T 2^31 < 2^62), x_k = x / rho_k
 * = round(x 2^16 / rho_k) (<= 0.73 in 1.31); alpha_k = 1 - exp(-x_k) by its
 * series, 12 terms, each x^n / n! formed in 1.31 (products < 2^62), error a
 * few 2^-31. */
fw_status_t fw_creep_init(fw_creep_t *c, const fw_creep_params_t *p);

/* No command seen yet, every state 0, flags cleared. */
void fw_creep_reset(fw_creep_t *c);

/* One period: the command u (pm) that puts the scanner at r_pm (pm), as
 * above; the first call after reset returns r_pm and takes it as the rest
 * position.
 * Scaling and overflow: each a_k e_k = round(e a / 2^31) from the 16-bit
 * halves of e (|e| <= 2^46: hi |a| < 2^61), summed in int64, rounded >> 16;
 * u = r - that in int64, saturated to int32 (sat); u - first in int64,
 * clamped to +-FW_CREEP_DEV_MAX_PM (sat); each state moves by round(
 * (dev 2^16 - e) alpha / 2^31), |dev 2^16 - e| <= 2^47 (hi alpha < 2^62). */
int32_t fw_creep_step_pm(fw_creep_t *c, int32_t r_pm, bool *sat);

/* One period of the modelled scanner itself (the host's de-warp follows
 * it: host/image/scan_dewarp.hpp): given the command u_pm over the period,
 * the creep the model puts on the position, sum_k a_k e_k (pm: the scanner
 * is at u_pm plus it), then the states move with u_pm, as
 * fw_creep_step_pm moves them with its command (so fw_creep_step_pm(c, r)
 * = r - that creep, and both leave the same states); the first call after
 * reset takes u_pm as the rest position.
 * Scaling and overflow: fw_creep_step_pm's; the creep saturated to int32
 * (sat), the deviation clamped as there (sat). */
int32_t fw_creep_follow_pm(fw_creep_t *c, int32_t u_pm, bool *sat);

#endif /* FW_CREEP_H */
