/*
 * fw_math.h - common fixed-point arithmetic: saturating add/sub/mul/shift,
 * integer square roots, sine/cosine and atan2 in integer arithmetic only.
 *
 * Formats are those of fw_types.h. All functions are pure (no state) and
 * total: every input, including INT32_MIN, has a defined result.
 *
 * Trigonometry is a 64-bit CORDIC: 34 micro-rotations on 4.60 coordinates,
 * angle accumulator in 2^-48 turn. Error bounds against the reference
 * formulas (tests/firmware/test_math.c asserts them over 10^6 random
 * inputs and prints the worst it meets):
 *   fw_math_sin_q30 / fw_math_cos_q30: at most 1 LSB of 2.30
 *   fw_math_atan2_bam:                 at most 1 LSB of 0.32 turn
 */
#ifndef FW_MATH_H
#define FW_MATH_H

#include "fw_types.h"

/* ---- saturation ------------------------------------------------------ */

/* Tiny helpers are static inline: the per-sample chain (fw_board_step)
 * calls them a dozen times a sample, and an out-of-line call costs more
 * than the operation. */

/* Where converting an out-of-range integer to int32 keeps the low 32 bits
 * (C99 leaves it implementation-defined; GCC and Clang document modulo
 * 2^32 on every target), v fits int32 <=> (int32_t)v == v: a sign
 * extension and a compare. Tested by a constant expression, folded at
 * compile time; elsewhere the explicit range test is used. */
#define FW_MATH_WRAP_NATIVE ((int32_t)(uint32_t)0x80000001u == -INT32_MAX)

/* Clamp a 64-bit value to int32. *sat (may be NULL) is set true when it
 * clamped and left untouched otherwise (sticky across calls). */
static inline int32_t fw_math_sat_i32(int64_t v, bool *sat)
{
    if (FW_MATH_WRAP_NATIVE ? ((int64_t)(int32_t)v == v) : (v >= INT32_MIN && v <= INT32_MAX)) {
        return (int32_t)v;
    }
    if (sat != NULL) {
        *sat = true;
    }
    return (v < 0) ? INT32_MIN : INT32_MAX;
}

/* a + b, 1.31 (or any int32 format). Scaling and overflow: exact sum in
 * 64 bits, saturated to [Q31_MIN, Q31_MAX]. */
q31_t fw_math_add_q31(q31_t a, q31_t b, bool *sat);

/* a - b, as fw_math_add_q31. */
q31_t fw_math_sub_q31(q31_t a, q31_t b, bool *sat);

/* a * b in 1.31. Scaling and overflow: 2.62 product in 64 bits, rounded
 * (half up) and shifted right by 31; the only overflow, (-1)*(-1), saturates
 * to Q31_MAX. */
q31_t fw_math_mul_q31(q31_t a, q31_t b, bool *sat);

/* a * b in 2.30. Scaling and overflow: 4.60 product, rounded, >> 30,
 * saturated to int32. */
q30_t fw_math_mul_q30(q30_t a, q30_t b, bool *sat);

/* a * b in 1.15. Scaling and overflow: 2.30 product in 32 bits, rounded,
 * >> 15; (-1)*(-1) saturates to Q15_MAX. */
q15_t fw_math_mul_q15(q15_t a, q15_t b, bool *sat);

/* An integer x (any unit) times a gain in m.n (n = frac bits, 0..62):
 * round(x * g / 2^n), rounding half away from zero, saturated to int32.
 * Scaling and overflow: 64-bit product (|x*g| < 2^63 always holds for
 * int32 operands), symmetric rounding, clamp. */
int32_t fw_math_scale_i32(int32_t x, int32_t g, int32_t frac, bool *sat);

/* x << n (n >= 0) or x >> -n (rounded half up) for n < 0, saturated to
 * int32. n is clamped to [-63, 63]. */
int32_t fw_math_shift_i32(int32_t x, int32_t n, bool *sat);

/* Arithmetic shift right of a 64-bit value, defined for negative values
 * (C99 leaves >> of a negative value implementation-defined):
 * fw_math_asr_i64 = floor(v / 2^n), fw_math_rshift_round_i64 =
 * floor(v / 2^n + 1/2). n in 0..62; v + 2^(n-1) must fit int64 for the
 * rounded form (|v| <= 2^62 always does; n <= 0 returns v).
 * Where the compiler's >> of a negative int64 is the arithmetic shift
 * (tested by a constant expression, folded at compile time: GCC and Clang
 * on every target) it is one instruction; elsewhere the floor is formed
 * from a shift of the non-negative -(v + 1). */
#define FW_MATH_ASR_NATIVE (((int64_t)-5 >> 1) == (int64_t)-3)

static inline int64_t fw_math_asr_i64(int64_t v, int n)
{
    if (FW_MATH_ASR_NATIVE) {
        return v >> n;
    }
    return (v >= 0) ? (v >> n) : -(int64_t)(((uint64_t)(-(v + 1)) >> n) + 1u);
}

/* The same for int32 (the 16-bit path's accumulator): floor(v / 2^n),
 * n in 0..31. */
static inline int32_t fw_math_asr_i32(int32_t v, int n)
{
    if (FW_MATH_ASR_NATIVE) {
        return v >> n;
    }
    return (v >= 0) ? (v >> n) : -(int32_t)(((uint32_t)(-(v + 1)) >> n) + 1u);
}

static inline int64_t fw_math_rshift_round_i64(int64_t v, int n)
{
    if (n <= 0) {
        return v;
    }
    return fw_math_asr_i64(v + ((int64_t)1 << (n - 1)), n);
}

/* round(num / den) for 64-bit operands, half away from zero. den == 0
 * returns 0 (callers check den first; this keeps the function total).
 * Cost: a power-of-two |den| is a shift, operands that fit 32 bits a
 * 32-bit division (one UDIV on the Cortex-M4), others the 64-bit library
 * division (__aeabi_uldivmod, hundreds of instructions); the result is
 * the same whichever path. Out of range: INT64_MIN / -1 saturates to
 * INT64_MAX. */
int64_t fw_math_div_round_i64(int64_t num, int64_t den);

/* num / den truncated toward zero, as C99's `/` on int64. On a 32-bit
 * machine, for a divisor that fits 16 bits (0 < |den| < 2^16): three
 * 32-bit divisions of 16-bit digits (the Cortex-M4's UDIV) instead of the
 * 64-bit library division; a 64-bit machine uses its own division (the
 * unit tests run both, on the host and on the emulated Cortex-M4).
 * Scaling and overflow: |num| <= 2^63; each partial dividend (remainder <
 * |den| < 2^16, shifted up 16 bits, plus a 16-bit digit) is below 2^32;
 * the quotient's magnitude is at most |num|. Out of range: den == 0
 * returns 0, INT64_MIN / -1 saturates to INT64_MAX; a wider |den| takes
 * C's 64-bit division (the same result). */
static inline int64_t fw_math_div_trunc_i64_by_small(int64_t num, int32_t den)
{
    if (den == 0) {
        return 0;
    }
    if (num == INT64_MIN && den == -1) {
        return INT64_MAX;
    }
#if UINTPTR_MAX > 0xFFFFFFFFu
    return num / den;   /* a 64-bit machine divides 64-bit integers in one instruction */
#else
    uint64_t un;
    uint32_t d;
    uint32_t hi;
    uint32_t lo;
    uint32_t r;
    uint32_t t;
    uint64_t q;
    bool neg;
    if (den >= 65536 || den <= -65536) {
        return num / den;
    }
    neg = (num < 0) != (den < 0);
    un = (num < 0) ? (uint64_t)0 - (uint64_t)num : (uint64_t)num;
    d = (den < 0) ? (uint32_t)(-(int64_t)den) : (uint32_t)den;
    hi = (uint32_t)(un >> 32);
    lo = (uint32_t)un;
    q = (uint64_t)(hi / d) << 32;
    r = hi % d;
    t = (r << 16) | (lo >> 16);
    q |= (uint64_t)(t / d) << 16;
    r = t % d;
    t = (r << 16) | (lo & 0xFFFFu);
    q |= t / d;
    if (q > (uint64_t)INT64_MAX) {
        return neg ? INT64_MIN : INT64_MAX;
    }
    return neg ? -(int64_t)q : (int64_t)q;
#endif
}

/* Number of leading zero bits of a nonzero uint64 (v = 0 is a caller bug:
 * the result is 64). One instruction where the compiler has the builtin
 * (GCC, Clang: x86 BSR/LZCNT, Cortex-M CLZ twice); a loop elsewhere. */
static inline int fw_math_clz_u64(uint64_t v)
{
#if defined(__GNUC__)
    return (v == 0u) ? 64 : __builtin_clzll(v);
#else
    int n = 0;
    if (v == 0u) {
        return 64;
    }
    while ((v & ((uint64_t)1 << 63)) == 0u) {
        v <<= 1;
        n++;
    }
    return n;
#endif
}

/* ---- roots -------------------------------------------------------------- */

/* floor(sqrt(v)), exact, for all uint64. */
uint32_t fw_math_isqrt_u64(uint64_t v);

/* round(sqrt(v)) (nearest integer), exact. */
uint32_t fw_math_isqrt_round_u64(uint64_t v);

/* sqrt of a 2.30 value >= 0, in 2.30: round(sqrt(x * 2^30)). Negative
 * input returns 0. Error <= 0.5 LSB. */
q30_t fw_math_sqrt_q30(q30_t x);

/* ---- angles ------------------------------------------------------------- */

/* Millidegrees to binary angle (2^32 per turn), rounded; any int32 input,
 * wraps modulo one turn. */
fw_bam_t fw_math_bam_from_mdeg(int32_t mdeg);

/* Binary angle to millidegrees in [-180000, 180000), rounded. */
int32_t fw_math_mdeg_from_bam(fw_bam_t a);

/* sin and cos of a binary angle, 2.30, both from one CORDIC run.
 * Scaling and overflow: |result| <= 1.0 = 2^30 exactly representable;
 * results at multiples of 90 deg are exact (0 or +-2^30). */
void fw_math_sincos_q30(fw_bam_t a, q30_t *s, q30_t *c);
q30_t fw_math_sin_q30(fw_bam_t a);
q30_t fw_math_cos_q30(fw_bam_t a);

/* atan2(y, x) as a binary angle (int32 view: [-half turn, half turn)).
 * Any int32 y, x; atan2(0, 0) = 0. Exact at the axes and diagonals'
 * quadrant boundaries (x or y zero). */
fw_bam_t fw_math_atan2_bam(int32_t y, int32_t x);

/* Radians in 2.30 to binary angle and back (for small angle increments).
 * Scaling and overflow: multiply by 2^32/(2 pi) in 64 bits; wraps. */
fw_bam_t fw_math_bam_from_rad_q30(q30_t rad);
q30_t fw_math_rad_q30_from_bam(fw_bam_t a);

/* Unit vector of (x, y) in 1.15: (c, s) with c^2 + s^2 = 1 within 2 LSB.
 * Returns false (and c = s = 0) for the zero vector. Uses only 32x32
 * multiplies, a 32-bit isqrt of a normalised length and two divisions.
 * Scaling and overflow: inputs are shifted right so both fit 15 bits
 * before squaring; the result is rounded and clamped to [-Q15_MAX, Q15_MAX]. */
bool fw_math_unit_q15(int32_t x, int32_t y, q15_t *c, q15_t *s);

/* Rotate (x, y) by the angle whose cos/sin are given in 2.30 (clamped to
 * [-1, 1]):
 * x' = c x - s y, y' = s x + c y, integer units kept.
 * Scaling and overflow: 64-bit products, sum rounded >> 30, saturated. */
void fw_math_rotate_i32(int32_t x, int32_t y, q30_t c, q30_t s,
                        int32_t *xr, int32_t *yr, bool *sat);

/* fw_math_rotate_i32 without the clamp, for coefficients already in
 * [-1, 1] (2.30), as fw_math_sincos_q30 returns them; the per-sample paths
 * clamp once at init. Precondition |c|, |s| <= 2^30 (not checked).
 * Scaling and overflow: |c x|, |s y| <= 2^61, so each 4.60 sum is
 * < 2^62 and cannot wrap; rounded (half up) >> 30, saturated to int32
 * (*sat, sticky; may be NULL). Same results as fw_math_rotate_i32. */
static inline void fw_math_rotate_unit_i32(int32_t x, int32_t y, q30_t c, q30_t s,
                                           int32_t *xr, int32_t *yr, bool *sat)
{
    int64_t px = (int64_t)c * x - (int64_t)s * y;
    int64_t py = (int64_t)s * x + (int64_t)c * y;
    *xr = fw_math_sat_i32(fw_math_rshift_round_i64(px, FW_Q30_FRAC), sat);
    *yr = fw_math_sat_i32(fw_math_rshift_round_i64(py, FW_Q30_FRAC), sat);
}

/* fw_math_rotate_unit_i32 for inputs whose result is known to fit: the
 * per-sample fast paths, where init has bounded the inputs.
 * Precondition |c|, |s| <= 2^30 and |x|, |y| < 2^30 (not checked).
 * Scaling and overflow: 4.60 sums as in fw_math_rotate_unit_i32, rounded
 * (half up) >> 30; |x'|, |y'| <= sqrt(2) 2^30 + 1 < 2^31, so no clamp is
 * needed and none is done. Same results as fw_math_rotate_unit_i32 there. */
static inline void fw_math_rotate_unit_fit_i32(int32_t x, int32_t y, q30_t c, q30_t s,
                                               int32_t *xr, int32_t *yr)
{
    int64_t px = (int64_t)c * x - (int64_t)s * y;
    int64_t py = (int64_t)s * x + (int64_t)c * y;
    *xr = (int32_t)fw_math_rshift_round_i64(px, FW_Q30_FRAC);
    *yr = (int32_t)fw_math_rshift_round_i64(py, FW_Q30_FRAC);
}

#endif /* FW_MATH_H */
