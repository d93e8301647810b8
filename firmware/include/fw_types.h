/*
 * fw_types.h - status codes, board flags and the fixed-point formats used by
 * every firmware module. Each Q format is defined here once and nowhere else.
 *
 * Q formats are written m.n: m bits before the binary point (sign included),
 * n bits after it, m + n = word width. A value v is stored as round(v * 2^n).
 *
 *   format   type      range                 LSB           used for
 *   1.15     q15_t     [-1, 1 - 2^-15]       3.05e-5       joystick, unit vectors
 *   1.31     q31_t     [-1, 1 - 2^-31]       4.66e-10      fractions of full scale
 *   2.30     q30_t     [-2, 2 - 2^-30]       9.31e-10      sin, cos, unit gains, mu
 *   8.24     q24_t     [-128, 128 - 2^-24]   5.96e-8       dimensionless ratios (slopes)
 *   9.23     q23_t     [-256, 256 - 2^-23]   1.19e-7       photodiode signals in volts
 *   16.16    q16_t     [-32768, 32768-2^-16] 1.53e-5       gains such as kappa
 *   0.32     fw_bam_t  one turn = 2^32       1.46e-9 rad   angles (binary angle,
 *                                                           wraps modulo one turn)
 *
 * Physical quantities that need no fraction are plain int32 in the unit their
 * name carries: _pm (picometre), _pn (piconewton), _uv (microvolt), _mdeg
 * (millidegree), _ppm (parts per million).
 *
 * Saturation is not an error: functions that clamp say so under "Scaling and
 * overflow" and report it through flags; errors are negative fw_status_t.
 */
#ifndef FW_TYPES_H
#define FW_TYPES_H

#include <stdint.h>
#include <stddef.h>
#include <stdbool.h>

typedef int16_t q15_t;   /* 1.15 */
typedef int32_t q31_t;   /* 1.31 */
typedef int32_t q30_t;   /* 2.30 */
typedef int32_t q24_t;   /* 8.24 */
typedef int32_t q23_t;   /* 9.23 */
typedef int32_t q16_t;   /* 16.16 */
typedef uint32_t fw_bam_t; /* 0.32 turn: 2^32 per full turn, wraps */

#define FW_Q15_FRAC 15
#define FW_Q31_FRAC 31
#define FW_Q30_FRAC 30
#define FW_Q24_FRAC 24
#define FW_Q23_FRAC 23
#define FW_Q16_FRAC 16

#define FW_Q15_MAX ((q15_t)INT16_MAX)
#define FW_Q15_MIN ((q15_t)INT16_MIN)
#define FW_Q31_MAX ((q31_t)INT32_MAX)
#define FW_Q31_MIN ((q31_t)INT32_MIN)
#define FW_Q30_MAX ((q30_t)INT32_MAX)
#define FW_Q30_MIN ((q30_t)INT32_MIN)
#define FW_Q24_MAX ((q24_t)INT32_MAX)
#define FW_Q24_MIN ((q24_t)INT32_MIN)
#define FW_Q23_MAX ((q23_t)INT32_MAX)
#define FW_Q23_MIN ((q23_t)INT32_MIN)
#define FW_Q16_MAX ((q16_t)INT32_MAX)
#define FW_Q16_MIN ((q16_t)INT32_MIN)

#define FW_Q30_ONE ((q30_t)1 << FW_Q30_FRAC)
#define FW_Q24_ONE ((q24_t)1 << FW_Q24_FRAC)
#define FW_Q23_ONE ((q23_t)1 << FW_Q23_FRAC)
#define FW_Q16_ONE ((q16_t)1 << FW_Q16_FRAC)

/* A static function that must be inlined: the per-sample fast paths are
 * written once with a constant selecting a specialisation (fw_board.c), and
 * only inlining makes the constant fold. GCC and Clang are told so;
 * elsewhere it stays a hint. */
#if defined(__GNUC__)
#define FW_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define FW_ALWAYS_INLINE inline
#endif

/* A function kept out of line: the rare branches of a per-sample fast path
 * (fw_board.c), so that the hot function stays a leaf that needs no
 * callee-saved registers and reaches them by a tail call. A hint only
 * where the compiler has no attribute. */
#if defined(__GNUC__)
#define FW_NOINLINE __attribute__((noinline))
#else
#define FW_NOINLINE
#endif

/* Branch hints for the per-sample fast paths: the common case stays on the
 * straight line. Plain expressions where the compiler has no builtin. */
#if defined(__GNUC__)
#define FW_LIKELY(x) __builtin_expect(!!(x), 1)
#define FW_UNLIKELY(x) __builtin_expect(!!(x), 0)
#else
#define FW_LIKELY(x) (x)
#define FW_UNLIKELY(x) (x)
#endif

/* Angles. */
#define FW_BAM_HALF_TURN ((fw_bam_t)0x80000000u)
#define FW_BAM_QUARTER_TURN ((fw_bam_t)0x40000000u)
#define FW_MDEG_PER_TURN 360000

/* Unit ratios. */
#define FW_PPM_PER_ONE 1000000
#define FW_PM_PER_NM 1000
#define FW_UV_PER_V 1000000

/* Status: zero for success, negative for errors. */
typedef enum {
    FW_OK = 0,
    FW_ERR_ARG = -1,       /* a NULL pointer or an argument outside its documented set */
    FW_ERR_DOMAIN = -2,    /* arguments valid but the model has no (finite) answer there */
    FW_ERR_CAPACITY = -3,  /* caller-owned storage is full */
    FW_ERR_STATE = -4      /* called before the data it needs exists */
} fw_status_t;

/* Per-sample flags (uint32_t bit set), published by fw_board_step and
 * consumed by the object models. */
#define FW_FLAG_SAT_SN          (1u << 0)  /* normal ADC input at or past +-10 V this sample */
#define FW_FLAG_SAT_SL          (1u << 1)  /* lateral ADC input at or past +-10 V this sample */
#define FW_FLAG_FX_UNOBSERVABLE (1u << 2)  /* |sin theta| below the cot threshold: friction fallback (partly) used */
#define FW_FLAG_VIRTUAL_SN      (1u << 3)  /* S_n' = S_n,ref + dz / K_n replaces the saturated S_n */
#define FW_FLAG_SAT_FORCE       (1u << 4)  /* a force output was clamped to int32 */
#define FW_FLAG_CONTACT         (1u << 5)  /* a particle is being pushed */
#define FW_FLAG_THETA_UNKNOWN   (1u << 6)  /* apex has not moved enough yet: theta is a default */
#define FW_FLAG_SAT_POS         (1u << 7)  /* a position output was clamped to int32 */
#define FW_FLAG_SQUEEZE         (1u << 8)  /* tip-wire contact past psi_max: the tip squeezes the wire */
#define FW_FLAG_INTERLOCK       (1u << 9)  /* the force interlock is latched: the block's command retracts the tip (fw_guard.h) */
#define FW_FLAG_RIDEOVER        (1u << 10) /* the tip rides over a wire it pushes (eq. 30: its load too small): the wire stays */
#define FW_FLAG_BLIND_PUSH      (1u << 11) /* F_x unobservable with the block's last apex more than FW_CARD_BLIND_DEPTH_PM inside a modelled object: a push the card cannot see (fw_card.h) */

#endif /* FW_TYPES_H */
