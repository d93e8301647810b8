/*
 * fw_guard.h - the force interlock: the card protects the tip and the
 * sample (issue 14). Per sample the card's measured forces are compared
 * with two limits; above either the interlock trips and latches, the
 * card's command for the next block retracts the tip, and it holds until
 * the operator's set point moves away.
 *
 * The forces: the firmware's own, per sample, pN.
 *   normal   F_z of eq. 1c, the sample's force_pn[2] (frame A's z is frame
 *            C's), as FW_STATE publishes it;
 *   lateral  F_y of eq. 1a on the lever's lateral channel (frame C),
 *            round(k_theta K_l / h S_l) with S_l the sample's lateral ADC
 *            code as a signal (fw_guard_lateral_pn): what saturates that
 *            channel, whatever the scan angle and the direction of motion.
 *            The card compares it without rounding it (fw_guard_over_q23,
 *            the same causes).
 * Trip: |F| > limit, strictly: a force exactly at the limit does not trip,
 * one pN over does. A saturated ADC sample (FW_FLAG_SAT_SN, FW_FLAG_SAT_SL)
 * trips its channel whatever its force: the force is unknown and at least
 * full scale (fw_guard_over).
 *
 * Limits: each lies in (0, full scale) of its channel, full scale = the
 * channel's gain x the ADC's 10 V (FW_ACQ_FS_UV): k_n K_n 10 V normal,
 * k_theta K_l / h 10 V lateral (FW_RULE_INTERLOCK_NORMAL,
 * FW_RULE_INTERLOCK_LATERAL). Default (the host takes it where the scene
 * names none, fw_guard_default_limit_pn): FW_GUARD_DEFAULT_PERCENT (80) %
 * of full scale, below saturation; the paper's lever: 85440 pN normal
 * (k_n K_n = 10680 pN/V), 303200 pN lateral (37900 pN/V).
 *
 * Latch and release (fw_guard_step, once per block, given the OR of the
 * block's samples' causes and the operator's pose given with the block):
 *   - a block with any cause trips: the interlock latches (TRIPPED; again
 *     if it was latched: the causes add up) and records the pose's load and
 *     xy set point as the set point at the trip; the block's command
 *     retracts the tip;
 *   - latched from an earlier block, the command retracts (HOLDING) until
 *     the operator's set point has moved away, and then follows the pose
 *     again from that block's command on (RELEASED):
 *       a. the operator lifts the tip (the pose is not engaged);
 *       b. any trip: the load set point falls below
 *          R = min(limit_n, load at the trip) - limit_n / 8
 *          (fw_guard_release_load_pn; the hysteresis limit_n / 8 is
 *          FW_GUARD_HYST_SHIFT): load = R holds, R - 1 pN releases. The
 *          load at the trip enters so that a trip the set point did not
 *          cause (the tip run into something at a light load) holds until
 *          the operator backs off, instead of re-engaging at once;
 *       c. a lateral trip alone (no normal cause while latched): the xy set
 *          point lies at least FW_GUARD_RELEASE_MOVE_PM (50 nm) from where
 *          it was at the trip (fw_guard_moved; 50 nm - 1 pm holds). Moving
 *          on into what stopped the tip trips it again at once.
 *   A block that trips never releases in the same block.
 *
 * The retract: the card's command (tip_cmd_t) for the next block has
 * engaged = false; the xy set point follows the operator. The simulator
 * lifts the tip at once, the z piezo kRetractLift_nm (100 nm) above the
 * height where the tip touches at zero load, and keeps it there while
 * disengaged (sim_afm/world.hpp). On release the z servo lands it again.
 *
 * The bound. The card checks every sample and answers at its block's end;
 * the retract takes effect from the next block's first sample. With a z
 * servo that moves the piezo at most v_z (afm.z_speed_nm_per_s) towards
 * its set point, a pressing set point raises the normal force by at most
 * k_n v_z T_s per sample (k_n the lever's normal stiffness, T_s = 1 /
 * sample rate). The last sample the card measured at or below the limit is
 * at latest the last sample of the block before the tripping block (else
 * that block had tripped); its true force is at most the limit plus half
 * the normal channel's LSB (q / 2, q = k_n K_n 20 V / 2^adc_bits: 1.6 pN
 * at 16 bits on the paper's lever). The tripping block has N = samples per
 * block samples after it, the crossing sample's own rise among them, so
 * the true normal force never exceeds the limit by more than
 *     k_n v_z T_block + q / 2,   T_block = N T_s = N / sample rate
 * (the measured one by k_n v_z T_block + q), plus the photodiode noise if
 * the scene has it. It holds for a set point pressing on a still or flat
 * surface (F_x constant); a tip moved onto rising topography adds k_n
 * times the rise in that block. scenes/interlock.yaml: 0.12 nN/nm x 20000
 * nm/s x 1 ms = 2.4 nN over the 85.44 nN limit (tests/e2e/test_interlock.py
 * measures it sample by sample, also with the limit placed so that the
 * crossing is a block's first sample, the worst case). With the ideal
 * servo (v_z = 0) the force steps to the set point within one sample and
 * nothing bounds the overshoot.
 *
 * C99, fixed point, no heap, no I/O. Units: forces pN, positions pm.
 */
#ifndef FW_GUARD_H
#define FW_GUARD_H

#include "fw_types.h"
#include "fw_math.h"
#include "fw_rules.h"
#include "fw_acq.h"

/* The default limit: this percentage of the channel's full scale. */
#define FW_GUARD_DEFAULT_PERCENT 80
/* The load hysteresis of the release: limit_n >> 3 (limit_n / 8, floor). */
#define FW_GUARD_HYST_SHIFT 3
/* A lateral trip releases once the xy set point is this far from the trip's. */
#define FW_GUARD_RELEASE_MOVE_PM 50000

/* A sample's causes (bits of fw_guard_over): the bits of the saturation
 * flags themselves, so that a sample's saturation flags are its
 * saturation causes as they stand. */
#define FW_GUARD_CAUSE_NORMAL FW_FLAG_SAT_SN    /* |F_z| > limit_n, or S_n saturated */
#define FW_GUARD_CAUSE_LATERAL FW_FLAG_SAT_SL   /* |F_y| > limit_l, or S_l saturated */

/* What a block's step did (fw_guard_step). The command retracts for
 * TRIPPED and HOLDING. */
typedef enum {
    FW_GUARD_ARMED = 0,     /* not latched: the command follows the operator */
    FW_GUARD_TRIPPED = 1,   /* a sample of this block was over a limit: latched, retract */
    FW_GUARD_HOLDING = 2,   /* latched from an earlier block, the set point has not moved away: retract */
    FW_GUARD_RELEASED = 3   /* was latched; the set point moved away: the command follows again */
} fw_guard_state_t;

/* The operator's set point for a block, as the release sees it. */
typedef struct {
    int32_t load_pn;        /* normal load set point, pN */
    int32_t xy_pm[2];       /* apex target, frame A, pm */
    bool engaged;           /* the operator wants the tip in contact */
} fw_guard_pose_t;

typedef struct {
    int32_t normal_limit_pn;     /* limit_n */
    int32_t lateral_limit_pn;    /* limit_l */
    int32_t lateral_gain_pn_per_v;  /* k_theta K_l / h, for fw_guard_over_q23 */
    int64_t lateral_over_q23;    /* (2 limit_l + 1) 2^22: gain S_l (9.23) at or past it rounds past limit_l */
    bool latched;
    uint32_t causes;             /* FW_GUARD_CAUSE_* since the latch (0 when not latched) */
    int32_t release_load_pn;     /* R of the latest trip (release b.) */
    int32_t trip_xy_pm[2];       /* the xy set point at the latest trip (release c.) */
    uint32_t trips;              /* blocks that tripped since reset (saturating) */
} fw_guard_t;

/* A channel's full scale, gain x 10 V (the ADC's range), pN.
 * Scaling and overflow: |gain| < 2^31, x 10 in 64 bits: < 2^34.4, exact. */
int64_t fw_guard_full_scale_pn(int32_t gain_pn_per_v);

/* The default limit of a channel: floor(FW_GUARD_DEFAULT_PERCENT % of its
 * full scale), below it for every gain > 0; 0 for a gain <= 0 (which the
 * check refuses). Scaling and overflow: full scale < 2^34.4, x 80 < 2^40.8
 * in 64 bits, / 100 truncated; saturated to INT32_MAX (gains above
 * 268435455 pN/V), which stays below full scale. */
int32_t fw_guard_default_limit_pn(int32_t gain_pn_per_v);

/* The first rule broken: the normal limit outside (0, k_n K_n 10 V)
 * (FW_RULE_INTERLOCK_NORMAL), then the lateral one outside (0, k_theta K_l
 * / h 10 V) (FW_RULE_INTERLOCK_LATERAL). Scaling and overflow: the full
 * scales in 64 bits (fw_guard_full_scale_pn); no narrowing. */
fw_rule_t fw_guard_check(int32_t normal_limit_pn, int32_t lateral_limit_pn, int32_t normal_gain_pn_per_v,
                         int32_t lateral_gain_pn_per_v);

/* Validates with fw_guard_check (its rule's status; FW_ERR_ARG for a NULL
 * g; the instance untouched on failure), sets the limits (and the lateral
 * gain with its threshold for fw_guard_over_q23), resets. */
fw_status_t fw_guard_init(fw_guard_t *g, int32_t normal_limit_pn, int32_t lateral_limit_pn,
                          int32_t normal_gain_pn_per_v, int32_t lateral_gain_pn_per_v);

/* Not latched, no causes, no trip recorded, counter zero; keeps the limits
 * and the gain. */
void fw_guard_reset(fw_guard_t *g);

/* F_y of eq. 1a from a lateral signal: round(gain s / 2^23), half up
 * (fw_math_rshift_round_i64), pN. gain: k_theta K_l / h, pN/V; s: S_l in 9.23 V (the
 * sample's code as a signal, fw_acq_signal_of_code_q23).
 * Scaling and overflow: |gain| < 2^31, |s| <= 20 V < 2^27.33 in 9.23: the
 * product < 2^58.4 in 64 bits; >> 23 rounded (< 2^35.4), saturated to
 * int32 (only for gains above 2^27 pN/V). Inline (per sample). */
static inline int32_t fw_guard_lateral_pn(int32_t gain_pn_per_v, q23_t s_v)
{
    return fw_math_sat_i32(fw_math_rshift_round_i64((int64_t)gain_pn_per_v * s_v, FW_Q23_FRAC), NULL);
}

/* A sample's causes: FW_GUARD_CAUSE_NORMAL when normal_pn > limit_n or
 * normal_pn < -limit_n or the sample's flags hold FW_FLAG_SAT_SN; the
 * lateral likewise with lateral_pn, limit_l and FW_FLAG_SAT_SL. 0: none.
 * Scaling and overflow: compares only; the limits are > 0, so -limit is an
 * int32 and no |F| is formed (INT32_MIN trips, INT32_MAX trips any limit
 * below it). Inline (per sample). */
static inline uint32_t fw_guard_over(const fw_guard_t *g, int32_t normal_pn, int32_t lateral_pn,
                                     uint32_t sample_flags)
{
    uint32_t c = 0u;
    if (normal_pn > g->normal_limit_pn || normal_pn < -g->normal_limit_pn
        || (sample_flags & FW_FLAG_SAT_SN) != 0u) {
        c |= FW_GUARD_CAUSE_NORMAL;
    }
    if (lateral_pn > g->lateral_limit_pn || lateral_pn < -g->lateral_limit_pn
        || (sample_flags & FW_FLAG_SAT_SL) != 0u) {
        c |= FW_GUARD_CAUSE_LATERAL;
    }
    return c;
}

/* fw_guard_over with the lateral force given as its signal: s_v = S_l
 * (9.23 V), F_y = round(gain s_v / 2^23) half up with the gain given to
 * init, compared without forming it: round(x) > L <=> x >= L + 1/2 and
 * round(x) < -L <=> x < -L - 1/2, so with p = gain s_v the lateral cause is
 * p >= (2 L + 1) 2^22 or p < -(2 L + 1) 2^22 (lateral_over_q23). The same
 * causes as fw_guard_over on fw_guard_lateral_pn(gain, s_v) wherever that
 * does not saturate (|F_y| < 2^31 pN: always for gains below 2^27 pN/V);
 * past it, the cause of the exact force. The card's per-sample check: one
 * multiply and two unsigned compares, no branch: a value v lies in
 * [-a, b] exactly when (unsigned)(v + a) <= a + b, as fw_acq's saturation
 * test (tests/firmware/test_guard.c proves the causes equal).
 * Scaling and overflow: |gain| < 2^31, |s_v| <= 20 V < 2^27.33: |p| <
 * 2^58.4; (2 L + 1) 2^22 < 2^54 in 64 bits, p + that formed in uint64
 * (modulo 2^64, exact as the test needs); the normal test in uint32:
 * 2 limit_n <= 2^32 - 2. Inline (per sample). */
static inline uint32_t fw_guard_over_q23(const fw_guard_t *g, int32_t normal_pn, q23_t sl_v, uint32_t sample_flags)
{
    uint64_t p = (uint64_t)((int64_t)g->lateral_gain_pn_per_v * sl_v);
    uint32_t ln = (uint32_t)g->normal_limit_pn;
    uint64_t ll = (uint64_t)g->lateral_over_q23;
    uint32_t n_over = (uint32_t)((uint32_t)normal_pn + ln > 2u * ln);
    uint32_t l_over = (uint32_t)(p + ll >= 2u * ll);
    return (sample_flags & (FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL)) | n_over * FW_GUARD_CAUSE_NORMAL
           | l_over * FW_GUARD_CAUSE_LATERAL;
}

/* The release load R = min(limit_n, load at the trip) - (limit_n >> 3):
 * a load below it releases (rule b. above).
 * Scaling and overflow: the difference in 64 bits (>= -2^31 - 2^28),
 * saturated to int32: a saturated R is INT32_MIN, below which no int32
 * load lies, exactly as below the true R. */
int32_t fw_guard_release_load_pn(int32_t normal_limit_pn, int32_t load_at_trip_pn);

/* Whether to_pm lies at least dist_pm from from_pm (dist_pm >= 0).
 * Scaling and overflow: 64-bit differences (|d| <= 2^32); a component of
 * at least dist decides alone; otherwise both are below dist <= 2^31 - 1,
 * so dx^2 + dy^2 < 2^63 and dist^2 < 2^62 in 64 bits, exact. */
bool fw_guard_moved(const int32_t from_pm[2], const int32_t to_pm[2], int32_t dist_pm);

/* One block (above): causes is the OR of the block's fw_guard_over,
 * pose the operator's set point given with the block. Returns what it did;
 * a NULL g or pose returns FW_GUARD_ARMED and changes nothing.
 * Scaling and overflow: fw_guard_release_load_pn's and fw_guard_moved's;
 * the trip counter saturates at UINT32_MAX. */
fw_guard_state_t fw_guard_step(fw_guard_t *g, uint32_t causes, const fw_guard_pose_t *pose);

/* Whether the command retracts for a step's result (TRIPPED, HOLDING). */
static inline bool fw_guard_retracts(fw_guard_state_t s)
{
    return s == FW_GUARD_TRIPPED || s == FW_GUARD_HOLDING;
}

#endif /* FW_GUARD_H */
