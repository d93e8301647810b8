/*
 * fw_hyst.h - a scanner axis's hysteresis as a Prandtl-Ishlinskii (PI)
 * model, and its inverse, the card's hysteresis compensation.
 *
 * The direct model maps the piezo's command x to the position y the
 * scanner reaches (both pm, relative to the model's origin):
 *
 *   y = P[x] = sum_i w_i F_{r_i}[x],   i = 0 .. n-1,
 *   F_r[x](k) = max(x(k) - r, min(x(k) + r, F_r[x](k-1))),   F_r[x](-1) = 0,
 *
 * n play operators F with thresholds 0 = r_0 < r_1 < ... < r_{n-1} and
 * weights w_i (the play of threshold 0 is the identity). Every branch of a
 * loop has a slope among the partial sums W_i = w_0 + ... + w_i, so the
 * model is invertible when every W_i > 0, and its inverse is a PI model
 * again (K. Kuhnen, "Modeling, identification and compensation of complex
 * hysteretic nonlinearities: a modified Prandtl-Ishlinskii approach",
 * European Journal of Control 9 (2003) 407-418; thresholds and weights as
 * Kuhnen and Janocha give them for the classical PI operator):
 *
 *   r'_i = sum_{j<=i} w_j (r_i - r_j),
 *   w'_0 = 1 / w_0,   w'_i = -w_i / (W_i W_{i-1}) = 1/W_i - 1/W_{i-1},
 *   x = P^-1[y] = sum_i w'_i F_{r'_i}[y],
 *
 * both models starting with every play at 0 (the virgin state at the
 * origin): then P^-1[P[x]] = x for every sequence x in real arithmetic.
 * The card is given the direct model (fitted on the host by
 * analysis/scanner_fit.py from a measured loop, ./afm calib scanner) and
 * forms the inverse here, in fw_hyst_init, in integer arithmetic.
 *
 * Units and formats: positions and thresholds pm (int32); weights 8.24
 * (q24_t) dimensionless. Domain, checked by fw_hyst_check: 1 <= n <=
 * FW_HYST_N_MAX; r_0 = 0, r strictly increasing, r_{n-1} <= range_pm;
 * 0 < range_pm <= FW_HYST_RANGE_MAX_PM; |origin_pm| <= FW_HYST_ORIGIN_MAX_PM;
 * every partial sum W_i in [FW_HYST_SLOPE_MIN_Q24, FW_HYST_SLOPE_MAX_Q24]
 * (so w_0 > 0; a single w_i may be 0 or negative: |w_i| <= 2). Then
 * 1/W_i lies in [1/2, 2] too, |w'_i| <= 2, 0 <= r'_i <= 2 r_i <= 2^29 pm,
 * and every play stays within 2^30 pm of the origin: nothing in the
 * per-step functions can leave its word.
 *
 * Out of range: the direct model's input is clamped to origin +- range_pm;
 * the inverse's input to origin +- y_max_pm (the direct model's output at
 * the range's edge after a full sweep: the largest it can give) and its
 * output to origin +- range_pm. A clamp is not an error: it sets the
 * instance's sticky flag sat and the caller's *sat (sticky; the pointer
 * may be NULL), and counts in sat_count (saturating).
 *
 * Error of the inverse (tests/firmware/test_hyst.c asserts and prints it):
 * the inverse's weights are rounded to 2^-24 once at init and each model's
 * sum once per step, so P^-1[P[x]] returns x within a few pm over a loop
 * at full range of a 2^24 pm (16.8 um) axis.
 */
#ifndef FW_HYST_H
#define FW_HYST_H

#include "fw_types.h"
#include "fw_rules.h"

#define FW_HYST_N_MAX 16
/* 2^28 pm (268 um): the largest half range of an axis. */
#define FW_HYST_RANGE_MAX_PM ((int32_t)1 << 28)
/* 2^30 pm: the origin's bound (origin +- 2^30 pm stays within int32). */
#define FW_HYST_ORIGIN_MAX_PM ((int32_t)1 << 30)
/* Every branch's slope W_i lies in [1/2, 2]: a scanner whose position
 * moves between half and twice its command's step. */
#define FW_HYST_SLOPE_MIN_Q24 ((q24_t)1 << (FW_Q24_FRAC - 1))
#define FW_HYST_SLOPE_MAX_Q24 ((q24_t)2 << FW_Q24_FRAC)

/* The direct model of one axis, as the host fits it. */
typedef struct {
    int32_t n;                        /* play operators, 1 .. FW_HYST_N_MAX */
    int32_t r_pm[FW_HYST_N_MAX];      /* thresholds, pm: r_0 = 0 < r_1 < ... <= range_pm */
    q24_t w_q24[FW_HYST_N_MAX];       /* weights, 8.24 */
    int32_t range_pm;                 /* the command's half range about the origin, pm */
    int32_t origin_pm;                /* the position where every play is 0 (virgin state), pm */
} fw_hyst_params_t;

typedef struct {
    fw_hyst_params_t p;               /* the direct model, as given */
    int32_t ri_pm[FW_HYST_N_MAX];     /* the inverse's thresholds r'_i, pm */
    q24_t wi_q24[FW_HYST_N_MAX];      /* the inverse's weights w'_i, 8.24 */
    int32_t y_max_pm;                 /* the direct model's largest output about the origin, pm */
    int32_t z_pm[FW_HYST_N_MAX];      /* the direct model's plays, pm about the origin */
    int32_t zi_pm[FW_HYST_N_MAX];     /* the inverse's plays, pm about the origin */
    bool sat;                         /* sticky: an input or output was clamped since reset */
    uint32_t sat_count;               /* clamps since reset (saturating) */
} fw_hyst_t;

/* FW_RULE_HYST for parameters outside the domain above (NULL included:
 * FW_RULE_NULL_POINTER). */
fw_rule_t fw_hyst_check(const fw_hyst_params_t *p);

/* Validates with fw_hyst_check (its rule's status: FW_ERR_ARG); forms
 * the inverse's thresholds, weights and y_max, and resets.
 * Scaling and overflow: the partial sums W_i (8.24, <= 2^25) in int64;
 * 1/W_i = round(2^48 / W_i) in 8.24 (<= 2^25); w'_i = that difference,
 * exact in int32; r'_i = r'_{i-1} + W_{i-1} (r_i - r_{i-1}) (the same
 * sum, term by term): products <= 2^25 2^29 in int64, rounded (half up)
 * >> 24 once per threshold from the exact int64 sum; y_max likewise. */
fw_status_t fw_hyst_init(fw_hyst_t *h, const fw_hyst_params_t *p);

/* Every play back to 0 (the virgin state at the origin); flags cleared. */
void fw_hyst_reset(fw_hyst_t *h);

/* One step of the direct model: the position P[x] (pm, absolute) for the
 * command x_pm (pm, absolute).
 * Scaling and overflow: x - origin in int64, clamped to +-range_pm (sat);
 * plays in int32 (|x| + r <= 2^29); sum of w_i z_i: each product <= 2^25
 * 2^29 = 2^54, n <= 16 of them <= 2^58 in int64, rounded (half up) >> 24;
 * |y| <= y_max + 1 <= 2^29 + 1 (every branch lies inside the outer loop),
 * plus the origin: fits int32 (no clamp needed, none done). */
int32_t fw_hyst_direct_pm(fw_hyst_t *h, int32_t x_pm, bool *sat);

/* One step of the inverse: the command P^-1[y] (pm, absolute) that makes
 * the direct model reach y_pm (pm, absolute).
 * Scaling and overflow: y - origin in int64, clamped to +-y_max_pm (sat);
 * plays in int32 (|y| + r' <= 2^30); sum of w'_i z'_i: |w'| <= 2^25
 * (2.0), products <= 2^55, n <= 16 of them <= 2^59 in int64, rounded
 * (half up) >> 24, clamped to +-range_pm (sat), plus the origin. */
int32_t fw_hyst_inverse_pm(fw_hyst_t *h, int32_t y_pm, bool *sat);

#endif /* FW_HYST_H */
