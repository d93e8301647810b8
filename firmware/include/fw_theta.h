/*
 * fw_theta.h - the tip's direction of motion theta (physics.md section 1:
 * eq. 1b needs it), estimated from the apex positions.
 *
 * theta is estimated from the apex positions (frame A, pm) of the last
 * FW_THETA_WINDOW samples: d = p_now - p_(now - WINDOW + 1), rotated into
 * frame C by R(-alpha). If |d| < min_disp_pm the direction is unknown and
 * the last known direction is held; before any is known, theta = 90 deg
 * (motion across the lever, F_x = 0) and FW_FLAG_THETA_UNKNOWN is set.
 * The length test is exact, on d in frame A (a rotation keeps lengths):
 * dx^2 + dy^2 >= min_disp_pm^2 in 64 bits (min_disp_pm^2 kept by init).
 *
 * The direction is kept as a frame-C vector (dir_x, dir_y) with
 * |dir_x|, |dir_y| <= FW_FORCE_DIR_MAX (2^15), the form the force solver
 * takes (fw_force.h); the unit vector (cos, sin theta) is formed only by
 * fw_theta_step, for callers that want it.
 *
 * Two pushes, one result: fw_theta_push_pm serves any apex; the card's
 * fast path (fw_board.c) uses fw_theta_push_fast_pm on a run's state kept
 * in locals (fw_theta_run_t) while every window stays within
 * FW_THETA_FAST_WINDOW_PM; tests/firmware/test_board_fast.c proves the two
 * identical over its sweep.
 */
#ifndef FW_THETA_H
#define FW_THETA_H

#include "fw_types.h"
#include "fw_math.h"
#include "fw_rules.h"
#include "fw_force.h"

#define FW_THETA_WINDOW 16
#define FW_THETA_MIN_DISP_DEFAULT_PM 1000

typedef struct {
    int32_t x_pm[FW_THETA_WINDOW];
    int32_t y_pm[FW_THETA_WINDOW];
    int32_t pos;            /* where the next apex goes */
    int32_t fill;           /* 0 after reset, FW_THETA_WINDOW once primed */
    int32_t min_disp_pm;
    uint64_t min_disp2_pm2; /* min_disp_pm^2 */
    int32_t dir_x;          /* latest direction, frame C, pm (|x|, |y| <= 2^15, */
    int32_t dir_y;          /*   scaled down above); (0, 1) before any */
    q15_t cos_theta;        /* latest direction, frame C, 1.15 (fw_theta_step only) */
    q15_t sin_theta;
    bool known;
} fw_theta_t;

/* FW_RULE_THETA_MIN_DISP for min_disp_pm < 0 (0 selects the default). */
fw_rule_t fw_theta_check(int32_t min_disp_pm);
fw_status_t fw_theta_init(fw_theta_t *t, int32_t min_disp_pm);
void fw_theta_reset(fw_theta_t *t);

/* Fill the whole window with the first apex after a reset (fill = WINDOW).
 * Then the oldest entry is always the one after pos, and until
 * FW_THETA_WINDOW samples have been pushed it still holds the first apex:
 * d = p_now - p_first, as the window's definition asks, with no count kept
 * per sample. Called by the pushes when fill is 0. */
void fw_theta_prime(fw_theta_t *t, const int32_t apex_pm[2]);

/* Push the apex (frame A) and update the direction vector (dir_x, dir_y)
 * only: the checked per-sample path, inline. Returns true when the
 * direction was updated this sample. Sets FW_FLAG_THETA_UNKNOWN in *flags
 * while no direction is known. cos_a, sin_a: alpha in 2.30, as
 * fw_math_sincos_q30 returns them (|cos_a|, |sin_a| <= 2^30, not checked).
 * Scaling and overflow: d in 64 bits, |dx|, |dy| < 2^32; the length test
 * squares components in [-2^31, 2^31) (sum <= 2^63 in uint64); a d with a
 * larger component has moved anyway (min_disp_pm < 2^31) and is halved
 * (floor), which keeps its direction; the rotation c dx + s dy is formed in
 * 64 bits (|c dx| + |s dy| <= 2^62) and rounded (half up) to pm. If a
 * component then exceeds 2^15 pm, the unrounded vector is instead shifted
 * right so that the larger component lies in [2^13, 2^15] (one rounding,
 * the direction kept to 2^-13). So |dir_x|, |dir_y| <= 2^15 always, and
 * max(|dir_x|, |dir_y|) >= 1 (|d| >= 1 pm). */
static inline bool fw_theta_push_pm(fw_theta_t *t, const int32_t apex_pm[2], q30_t cos_a,
                                    q30_t sin_a, uint32_t *flags)
{
    int32_t oldest;
    int64_t dx;
    int64_t dy;
    int64_t px;
    int64_t py;
    int64_t cx;
    int64_t cy;
    if (t->fill == 0) {
        fw_theta_prime(t, apex_pm);
    }
    t->x_pm[t->pos] = apex_pm[0];
    t->y_pm[t->pos] = apex_pm[1];
    oldest = (t->pos + 1) & (FW_THETA_WINDOW - 1);
    t->pos = oldest;
    dx = (int64_t)apex_pm[0] - t->x_pm[oldest];
    dy = (int64_t)apex_pm[1] - t->y_pm[oldest];
    if ((((uint64_t)dx + ((uint64_t)1 << 31)) | ((uint64_t)dy + ((uint64_t)1 << 31))) <= UINT32_MAX) {
        if ((uint64_t)(dx * dx) + (uint64_t)(dy * dy) < t->min_disp2_pm2) {
            if (!t->known) {
                *flags |= FW_FLAG_THETA_UNKNOWN;
            }
            return false;
        }
    } else {
        /* |d| >= 2^31 pm > min_disp_pm: halved, direction kept */
        dx = fw_math_asr_i64(dx, 1);
        dy = fw_math_asr_i64(dy, 1);
    }
    /* into frame C: R(-alpha), 2^-30 pm, then rounded to pm */
    px = (int64_t)cos_a * dx + (int64_t)sin_a * dy;
    py = (int64_t)cos_a * dy - (int64_t)sin_a * dx;
    cx = fw_math_rshift_round_i64(px, FW_Q30_FRAC);
    cy = fw_math_rshift_round_i64(py, FW_Q30_FRAC);
    if ((uint64_t)(cx + FW_FORCE_DIR_MAX) > (uint64_t)(2 * FW_FORCE_DIR_MAX)
        || (uint64_t)(cy + FW_FORCE_DIR_MAX) > (uint64_t)(2 * FW_FORCE_DIR_MAX)) {
        /* over 2^15 pm: shift the unrounded vector, one rounding */
        uint64_t m = (uint64_t)(px < 0 ? -px : px) | (uint64_t)(py < 0 ? -py : py);
        int sh = 49 - fw_math_clz_u64(m);   /* m >> sh in [2^14, 2^15), sh > 30 */
        cx = fw_math_rshift_round_i64(px, sh);
        cy = fw_math_rshift_round_i64(py, sh);
    }
    t->dir_x = (int32_t)cx;
    t->dir_y = (int32_t)cy;
    t->known = true;
    return true;
}

/* The fast window: |dx|, |dy| <= 2^14 pm over the window (16 nm; the
 * paper's 200 nm/s at 10 kHz moves 0.3 nm). Inside it the squares sum to
 * <= 2^29 and the rotation's |c dx + s dy| <= 2^30 (|dx| + |dy|) <= 2^45,
 * so |dir_x|, |dir_y| <= 2^15 after rounding and fw_theta_push_pm's range
 * test and scaling cannot act. */
#define FW_THETA_FAST_WINDOW_PM ((int64_t)1 << 14)

/* A run of fast samples keeps the window's position and direction in
 * locals (fw_theta_run_begin, fw_theta_run_end store them back). */
typedef struct {
    uint32_t pos;
    int32_t dir_x;
    int32_t dir_y;
    bool known;
} fw_theta_run_t;

static FW_ALWAYS_INLINE fw_theta_run_t fw_theta_run_begin(const fw_theta_t *t)
{
    fw_theta_run_t r;
    r.pos = (uint32_t)t->pos;
    r.dir_x = t->dir_x;
    r.dir_y = t->dir_y;
    r.known = t->known;
    return r;
}

static FW_ALWAYS_INLINE void fw_theta_run_end(fw_theta_t *t, const fw_theta_run_t *r)
{
    t->pos = (int32_t)r->pos;
    t->dir_x = r->dir_x;
    t->dir_y = r->dir_y;
    t->known = r->known;
}

/* fw_theta_push_pm for a primed window (fill = FW_THETA_WINDOW) and an apex
 * (ax, ay) within int32, on the run's state r: stores the apex in its slot
 * and, when the window's displacement lies within FW_THETA_FAST_WINDOW_PM,
 * moves the window on, updates the direction and returns true with its
 * squares (*x2, *y2: of the frame-C direction in force, the new one or the
 * one held) for the force solver. Otherwise returns false with the window's
 * position unmoved: the slot then holds the apex that fw_theta_push_pm,
 * which the caller hands the sample to, stores there again. aligned: alpha
 * = 0 exactly (cos_a, sin_a unused). Raises FW_FLAG_THETA_UNKNOWN in
 * *flags while no direction is known.
 * Scaling and overflow: as FW_THETA_FAST_WINDOW_PM: |dx|, |dy| <= 2^14, so
 * the squares and their sum < 2^29, the rotation's products < 2^45 and the
 * direction |dir| <= 2^15 with no scaling. */
static FW_ALWAYS_INLINE bool fw_theta_push_fast_pm(fw_theta_t *t, fw_theta_run_t *r, int64_t ax, int64_t ay,
                                                   q30_t cos_a, q30_t sin_a, bool aligned, int64_t *x2,
                                                   int64_t *y2, uint32_t *flags)
{
    uint32_t next;
    int64_t dx;
    int64_t dy;
    t->x_pm[r->pos] = (int32_t)ax;
    t->y_pm[r->pos] = (int32_t)ay;
    next = (r->pos + 1u) & (FW_THETA_WINDOW - 1u);
    dx = ax - t->x_pm[next];
    dy = ay - t->y_pm[next];
    if (FW_UNLIKELY((((uint64_t)dx + (uint64_t)FW_THETA_FAST_WINDOW_PM)
                     | ((uint64_t)dy + (uint64_t)FW_THETA_FAST_WINDOW_PM)) > (uint64_t)(2 * FW_THETA_FAST_WINDOW_PM))) {
        return false;
    }
    r->pos = next;
    *x2 = dx * dx;
    *y2 = dy * dy;
    if (FW_LIKELY((uint64_t)(*x2 + *y2) >= t->min_disp2_pm2)) {
        if (!aligned) {
            int64_t rx = fw_math_rshift_round_i64((int64_t)cos_a * dx + (int64_t)sin_a * dy, FW_Q30_FRAC);
            dy = fw_math_rshift_round_i64((int64_t)cos_a * dy - (int64_t)sin_a * dx, FW_Q30_FRAC);
            dx = rx;
            *x2 = dx * dx;
            *y2 = dy * dy;
        }
        r->dir_x = (int32_t)dx;
        r->dir_y = (int32_t)dy;
        r->known = true;
    } else {
        *x2 = (int64_t)r->dir_x * r->dir_x;
        *y2 = (int64_t)r->dir_y * r->dir_y;
        if (!r->known) {
            *flags |= FW_FLAG_THETA_UNKNOWN;
        }
    }
    return true;
}

/* Push the apex (frame A) and update the direction: fw_theta_push_pm, then
 * (cos_theta, sin_theta) = fw_math_unit_q15(dir_x, dir_y) when it moved.
 * Sets FW_FLAG_THETA_UNKNOWN in *flags while no direction is known.
 * Any cos_a, sin_a (clamped to [-1, 1]). */
void fw_theta_step(fw_theta_t *t, const int32_t apex_pm[2], q30_t cos_a, q30_t sin_a,
                   uint32_t *flags);

#endif /* FW_THETA_H */
