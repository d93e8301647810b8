/*
 * fw_kalman.h - the drift of one axis as a Kalman filter on a
 * constant-velocity state (physics.md section 10; card.md, "The drift
 * estimate"), updated by each local scan's registration.
 *
 * The model: the sample's drift d(t) against the scanner moves at a
 * constant velocity v plus a random walk,
 *
 *   d(t + T) = d(t) + v T + w,   w ~ N(0, q T),   v(t + T) = v(t),
 *
 * so over a gap T the state x = (d, v) and its covariance P predict as
 *
 *   d' = d + v T,   P'_dd = P_dd + 2 T P_dv + T^2 P_vv + q T,
 *   P'_dv = P_dv + T P_vv,   P'_vv = P_vv,
 *
 * closed form, so the gap is one step however long (no per-block
 * covariance work). A registration z (the drift a local scan measured, pm)
 * with variance r updates it (H = [1 0]):
 *
 *   S = P'_dd + r,  K_d = P'_dd / S,  K_v = P'_dv / S,  y = z - d',
 *   d = d' + K_d y,  v = v + K_v y,
 *   P_dd = P'_dd - K_d P'_dd,  P_dv = P'_dv - K_d P'_dv,  P_vv = P'_vv - K_v P'_dv.
 *
 * At reset the drift is 0 exactly (the models start registered to the
 * sample): d = 0, v = 0, P_dd = P_dv = 0, P_vv the velocity's prior
 * variance. So the first registration gives the velocity too, as the
 * displacement over the time since reset.
 *
 * Units and formats: d pm in 48.16 (int64), v pm/s in 16.16 (int32, so
 * |v| < 32768 pm/s = 1966 nm/min); covariances in nm (P_dd nm^2, P_dv
 * nm^2/s, P_vv nm^2/s^2), each 48.16 in int64, clamped to
 * [-FW_KALMAN_P_MAX, FW_KALMAN_P_MAX] (P_dd, P_vv to [0, P_MAX]); q nm^2/s
 * and r nm^2 16.16 (int32); times us; gains 16.16 (K_d in [0, 1], K_v 1/s).
 *
 * Out of range is not an error: the gap stops at FW_KALMAN_GAP_MAX_US,
 * covariances at P_MAX, v at +-(2^31 - 1) 2^-16 pm/s, d at the int32 pm
 * range; each clamp sets the sticky flag sat and counts in sat_count
 * (saturating). A negative variance r is refused (FW_ERR_ARG, nothing
 * changed, counted in refused).
 */
#ifndef FW_KALMAN_H
#define FW_KALMAN_H

#include "fw_types.h"
#include "fw_rules.h"

#define FW_KALMAN_GAP_MAX_US ((uint32_t)INT32_MAX)        /* 35.8 min without a registration */
#define FW_KALMAN_P_MAX ((int64_t)1 << 46)                 /* 2^30 nm^2: a 32.8 um sigma, 48.16 */
#define FW_KALMAN_PERIOD_MAX_US 1000000                    /* 1 s a block */

typedef struct {
    int32_t period_us;               /* the time fw_kalman_predict advances (the card's block), (0, 1 s] */
    q16_t walk_nm2_per_s;            /* q: the random walk's variance a second, nm^2/s, 16.16, >= 0 */
    q16_t vel_prior_nm2_per_s2;      /* P_vv at reset, (nm/s)^2, 16.16, >= 0 */
} fw_kalman_params_t;

typedef struct {
    fw_kalman_params_t p;
    int64_t d_pm_q16;        /* the drift at the last registration, pm, 48.16 */
    q16_t v_pm_per_s;        /* its velocity, pm/s, 16.16 */
    uint32_t gap_us;         /* since the last registration (or reset), us */
    int64_t p_dd;            /* the covariance at the last registration, 48.16: nm^2 */
    int64_t p_dv;            /* nm^2/s */
    int64_t p_vv;            /* nm^2/s^2 */
    uint32_t updates;        /* registrations taken since reset (saturating) */
    uint32_t refused;        /* negative variances refused since reset (saturating) */
    bool sat;                /* sticky: something was clamped since reset */
    uint32_t sat_count;      /* clamps since reset (saturating) */
} fw_kalman_t;

/* FW_RULE_DRIFT_KALMAN for parameters outside their domain above (NULL:
 * FW_RULE_NULL_POINTER). */
fw_rule_t fw_kalman_check(const fw_kalman_params_t *p);

/* Validates with fw_kalman_check (its rule's status: FW_ERR_ARG), then
 * resets. */
fw_status_t fw_kalman_init(fw_kalman_t *k, const fw_kalman_params_t *p);

/* The drift 0, known exactly; the velocity 0 with its prior variance;
 * counters and flags cleared. */
void fw_kalman_reset(fw_kalman_t *k);

/* One period passes (the card's block): the gap grows by period_us.
 * Scaling and overflow: the gap in uint32, stopped at
 * FW_KALMAN_GAP_MAX_US (sat). */
void fw_kalman_predict(fw_kalman_t *k);

/* dt_us passes at once (dt_us >= 0; a negative dt is taken as 0). Scaling
 * and overflow: as fw_kalman_predict. */
void fw_kalman_advance_us(fw_kalman_t *k, int32_t dt_us);

/* The drift predicted now, d + v gap, pm, rounded half away from zero.
 * Scaling and overflow: v gap < 2^31 2^31 = 2^62 in int64, divided by
 * 10^6 (fw_math_div_round_i64), added to d (|d| < 2^47) in int64, rounded
 * >> 16 and saturated to int32 (the flag sat when it clamps). */
int32_t fw_kalman_drift_pm(fw_kalman_t *k);

/* The covariance predicted now (P' above), 48.16, into dd, dv, vv (any may
 * be NULL). Scaling and overflow: T = gap 2^16 / 10^6 in 16.16 (< 2^28);
 * each product of two 48.16 values through a 64-bit product when their
 * magnitudes' bit lengths sum to at most 62, else P_MAX with the product's
 * sign (a product that large is at least P_MAX / 2: P_MAX's bound, half
 * the true value at worst); sums in int64 from operands within +-2^47;
 * each result clamped (sat). */
void fw_kalman_covariance(fw_kalman_t *k, int64_t *dd, int64_t *dv, int64_t *vv);

/* A registration: the drift a local scan measured, z_pm, with variance
 * r_nm2 (16.16, nm^2, >= 0: FW_ERR_ARG for a negative one or a NULL k,
 * nothing changed). The gap restarts at 0. Returns FW_OK.
 * Scaling and overflow: y = z - d' in int64 (|y| < 2^33); S = P'_dd + r
 * (<= 2^46 + 2^31), at least 1 LSB (2^-16 nm^2), so a zero variance with
 * P'_dd = 0 divides by 1 LSB and takes nothing (K_d = 0), and with P'_dd >
 * 0 takes z whole (K_d = 1); K_d = P'_dd 2^16 / S in [0, 2^16] and K_v =
 * P'_dv 2^16 / S (|P'_dv 2^16| <= 2^62; fw_math_div_round_i64); K_d y <
 * 2^16 2^33 exact; K_v y and the covariance's products as
 * fw_kalman_covariance's (saturating); d to the int32 pm range, v to
 * int32 (sat). */
fw_status_t fw_kalman_update(fw_kalman_t *k, int32_t z_pm, q16_t r_nm2);

/* The drift jumps by delta_pm (a landmark after a lever change: a step,
 * not drift): d moves whole, v and P stay. Scaling and overflow: d
 * clamped to the int32 pm range (sat). */
void fw_kalman_shift_pm(fw_kalman_t *k, int32_t delta_pm);

#endif /* FW_KALMAN_H */
