/*
 * fw_math.c - see fw_math.h.
 */
#include "fw_math.h"

/* CORDIC: atan(2^-i) in 2^-48 turn, i = 0..FW_CORDIC_ITERS-1, generated as
 * round(atan(2^-i) / (2 pi) * 2^48). */
#define FW_CORDIC_ITERS 34
#define FW_CORDIC_ANGLE_FRAC 48          /* accumulator: 2^48 per turn */
#define FW_CORDIC_XY_FRAC 60             /* coordinates: 4.60 */
#define FW_CORDIC_BAM_SHIFT (FW_CORDIC_ANGLE_FRAC - 32)
static const int64_t fw_cordic_atan_t48[FW_CORDIC_ITERS] = {
    35184372088832LL, 20770547670515LL, 10974586953444LL, 5570871696862LL,
    2796246208089LL, 1399486241028LL, 699913886760LL, 349978300884LL,
    174991820497LL, 87496244017LL, 43748163730LL, 21874087080LL,
    10937044192LL, 5468522177LL, 2734261099LL, 1367130551LL,
    683565276LL, 341782638LL, 170891319LL, 85445659LL,
    42722830LL, 21361415LL, 10680707LL, 5340354LL,
    2670177LL, 1335088LL, 667544LL, 333772LL,
    166886LL, 83443LL, 41722LL, 20861LL,
    10430LL, 5215LL
};
/* CORDIC gain of FW_CORDIC_ITERS rotations, prod 1/sqrt(1 + 2^-2i), in 4.60:
 * round(0.6072529350088813 * 2^60). */
static const int64_t fw_cordic_gain_q60 = 700114967507363328LL;

/* 2/pi in 0.32 (rad 2.30 -> bam) and pi/2 in 2.30 (bam -> rad 2.30). */
static const int64_t fw_two_over_pi_u32 = 2734261102LL;
static const int64_t fw_pi_over_2_q30 = 1686629713LL;

/* uint32 angle as signed int64 in [-2^31, 2^31). */
static int64_t bam_signed(fw_bam_t a)
{
    return (a < FW_BAM_HALF_TURN) ? (int64_t)a : (int64_t)a - ((int64_t)1 << 32);
}

static fw_bam_t bam_wrap(int64_t v)
{
    return (fw_bam_t)((uint64_t)v & 0xFFFFFFFFu);
}

q31_t fw_math_add_q31(q31_t a, q31_t b, bool *sat)
{
    return fw_math_sat_i32((int64_t)a + (int64_t)b, sat);
}

q31_t fw_math_sub_q31(q31_t a, q31_t b, bool *sat)
{
    return fw_math_sat_i32((int64_t)a - (int64_t)b, sat);
}

q31_t fw_math_mul_q31(q31_t a, q31_t b, bool *sat)
{
    return fw_math_sat_i32(fw_math_rshift_round_i64((int64_t)a * b, FW_Q31_FRAC), sat);
}

q30_t fw_math_mul_q30(q30_t a, q30_t b, bool *sat)
{
    return fw_math_sat_i32(fw_math_rshift_round_i64((int64_t)a * b, FW_Q30_FRAC), sat);
}

q15_t fw_math_mul_q15(q15_t a, q15_t b, bool *sat)
{
    int32_t p = (int32_t)fw_math_rshift_round_i64((int64_t)a * b, FW_Q15_FRAC);
    if (p > INT16_MAX) {
        if (sat != NULL) {
            *sat = true;
        }
        return FW_Q15_MAX;
    }
    return (q15_t)p;
}

int64_t fw_math_div_round_i64(int64_t num, int64_t den)
{
    uint64_t un;
    uint64_t ud;
    uint64_t q;
    bool neg;
    if (den == 0) {
        return 0;
    }
    neg = (num < 0) != (den < 0);
    un = (num < 0) ? (uint64_t)0 - (uint64_t)num : (uint64_t)num;
    ud = (den < 0) ? (uint64_t)0 - (uint64_t)den : (uint64_t)den;
    if ((ud & (ud - 1u)) == 0u) {
        /* a power of two: (un + ud/2) >> log2(ud), the same quotient and
         * rounding as below without a division (un + ud/2 cannot wrap:
         * un <= 2^63 and ud/2 <= 2^62) */
        q = (un + (ud >> 1)) >> (63 - fw_math_clz_u64(ud));
    } else if ((un >> 32) == 0u && (ud >> 32) == 0u) {
        /* both fit 32 bits: the hardware's 32-bit division (the Cortex-M4
         * has one, its 64-bit division is a library call), exact alike */
        uint32_t n32 = (uint32_t)un;
        uint32_t d32 = (uint32_t)ud;
        uint32_t r32 = n32 % d32;
        q = n32 / d32;
        if (r32 >= d32 - r32) {
            q++;
        }
    } else {
        q = un / ud;
        if ((un % ud) >= ud - (un % ud)) {
            q++;
        }
    }
    if (q > (uint64_t)INT64_MAX) {
        return neg ? INT64_MIN : INT64_MAX;
    }
    return neg ? -(int64_t)q : (int64_t)q;
}

int32_t fw_math_scale_i32(int32_t x, int32_t g, int32_t frac, bool *sat)
{
    int64_t p = (int64_t)x * g;
    uint64_t m;
    if (frac <= 0) {
        return fw_math_sat_i32(p, sat);
    }
    if (frac > 62) {
        frac = 62;
    }
    m = (p < 0) ? (uint64_t)0 - (uint64_t)p : (uint64_t)p;
    m = (m + ((uint64_t)1 << (frac - 1))) >> frac;
    return fw_math_sat_i32((p < 0) ? -(int64_t)m : (int64_t)m, sat);
}

int32_t fw_math_shift_i32(int32_t x, int32_t n, bool *sat)
{
    if (n > 63) {
        n = 63;
    }
    if (n < -63) {
        n = -63;
    }
    if (n >= 0) {
        if (x == 0) {
            return 0;
        }
        if (n >= 32) {
            return fw_math_sat_i32(x > 0 ? INT64_MAX : INT64_MIN, sat);
        }
        return fw_math_sat_i32((int64_t)x * ((int64_t)1 << n), sat);
    }
    return (int32_t)fw_math_rshift_round_i64(x, -n);
}

uint32_t fw_math_isqrt_u64(uint64_t v)
{
    uint64_t res = 0;
    uint64_t bit;
    if (v == 0u) {
        return 0u;
    }
    if ((v >> 32) == 0u) {
        /* the same digit-by-digit root in 32-bit words (one instruction an
         * operation on the Cortex-M4, not two or three) */
        uint32_t v32 = (uint32_t)v;
        uint32_t r32 = 0u;
        uint32_t b32 = (uint32_t)1 << ((31 - (fw_math_clz_u64(v) - 32)) & ~1);
        while (b32 != 0u) {
            if (v32 >= r32 + b32) {
                v32 -= r32 + b32;
                r32 = (r32 >> 1) + b32;
            } else {
                r32 >>= 1;
            }
            b32 >>= 2;
        }
        return r32;
    }
    /* the highest power of four not above v, from its leading zeros */
    bit = (uint64_t)1 << ((63 - fw_math_clz_u64(v)) & ~1);
    while (bit != 0) {
        if (v >= res + bit) {
            v -= res + bit;
            res = (res >> 1) + bit;
        } else {
            res >>= 1;
        }
        bit >>= 2;
    }
    return (uint32_t)res;
}

uint32_t fw_math_isqrt_round_u64(uint64_t v)
{
    uint32_t r = fw_math_isqrt_u64(v);
    /* round up when v - r^2 > r, i.e. v >= (r + 1/2)^2 = r^2 + r + 1/4 */
    if (r != UINT32_MAX && v - (uint64_t)r * r > (uint64_t)r) {
        r++;
    }
    return r;
}

q30_t fw_math_sqrt_q30(q30_t x)
{
    uint32_t r;
    if (x <= 0) {
        return 0;
    }
    r = fw_math_isqrt_round_u64((uint64_t)x << FW_Q30_FRAC);
    return (q30_t)r;
}

fw_bam_t fw_math_bam_from_mdeg(int32_t mdeg)
{
    int64_t m = (int64_t)mdeg % FW_MDEG_PER_TURN;
    uint64_t t;
    if (m < 0) {
        m += FW_MDEG_PER_TURN;
    }
    t = ((uint64_t)m << 32) + (uint64_t)(FW_MDEG_PER_TURN / 2);
    return bam_wrap((int64_t)(t / (uint64_t)FW_MDEG_PER_TURN));
}

int32_t fw_math_mdeg_from_bam(fw_bam_t a)
{
    int64_t v = fw_math_div_round_i64(bam_signed(a) * FW_MDEG_PER_TURN, (int64_t)1 << 32);
    if (v >= FW_MDEG_PER_TURN / 2) {
        v -= FW_MDEG_PER_TURN;
    }
    return (int32_t)v;
}

void fw_math_sincos_q30(fw_bam_t a, q30_t *s, q30_t *c)
{
    bool flip = false;
    fw_bam_t r = a;
    int64_t x;
    int64_t y;
    int64_t z;
    int i;
    q30_t so;
    q30_t co;

    if ((a & (FW_BAM_QUARTER_TURN - 1u)) == 0u) {
        /* exact at multiples of 90 deg */
        static const q30_t tab_s[4] = { 0, FW_Q30_ONE, 0, -FW_Q30_ONE };
        static const q30_t tab_c[4] = { FW_Q30_ONE, 0, -FW_Q30_ONE, 0 };
        uint32_t q = a >> 30;
        if (s != NULL) {
            *s = tab_s[q];
        }
        if (c != NULL) {
            *c = tab_c[q];
        }
        return;
    }
    /* fold into [-90, 90) deg: the CORDIC converges within +-99.9 deg */
    if ((fw_bam_t)(a - FW_BAM_QUARTER_TURN) < FW_BAM_HALF_TURN) {
        r = a - FW_BAM_HALF_TURN;
        flip = true;
    }
    z = bam_signed(r) * ((int64_t)1 << FW_CORDIC_BAM_SHIFT);
    x = fw_cordic_gain_q60;
    y = 0;
    for (i = 0; i < FW_CORDIC_ITERS; i++) {
        int64_t xs = fw_math_asr_i64(x, i);
        int64_t ys = fw_math_asr_i64(y, i);
        if (z >= 0) {
            x -= ys;
            y += xs;
            z -= fw_cordic_atan_t48[i];
        } else {
            x += ys;
            y -= xs;
            z += fw_cordic_atan_t48[i];
        }
    }
    co = fw_math_sat_i32(fw_math_rshift_round_i64(x, FW_CORDIC_XY_FRAC - FW_Q30_FRAC), NULL);
    so = fw_math_sat_i32(fw_math_rshift_round_i64(y, FW_CORDIC_XY_FRAC - FW_Q30_FRAC), NULL);
    if (co > FW_Q30_ONE) {
        co = FW_Q30_ONE;
    }
    if (so > FW_Q30_ONE) {
        so = FW_Q30_ONE;
    }
    if (so < -FW_Q30_ONE) {
        so = -FW_Q30_ONE;
    }
    if (flip) {
        co = -co;
        so = -so;
    }
    if (s != NULL) {
        *s = so;
    }
    if (c != NULL) {
        *c = co;
    }
}

q30_t fw_math_sin_q30(fw_bam_t a)
{
    q30_t s;
    fw_math_sincos_q30(a, &s, NULL);
    return s;
}

q30_t fw_math_cos_q30(fw_bam_t a)
{
    q30_t c;
    fw_math_sincos_q30(a, NULL, &c);
    return c;
}

fw_bam_t fw_math_atan2_bam(int32_t y, int32_t x)
{
    int64_t xx = x;
    int64_t yy = y;
    int64_t z = 0;
    uint64_t m;
    fw_bam_t base = 0;
    int sh;
    int i;

    if (y == 0) {
        return (x < 0) ? FW_BAM_HALF_TURN : 0u;
    }
    if (x == 0) {
        return (y > 0) ? FW_BAM_QUARTER_TURN : (fw_bam_t)(0u - FW_BAM_QUARTER_TURN);
    }
    if (xx < 0) {
        xx = -xx;
        yy = -yy;
        base = FW_BAM_HALF_TURN;
    }
    /* normalise so max(|x|, |y|) lies in [2^58, 2^59): growth 1.65*sqrt2 stays < 2^61 */
    m = (uint64_t)((yy < 0) ? -yy : yy);
    if ((uint64_t)xx > m) {
        m = (uint64_t)xx;
    }
    sh = fw_math_clz_u64(m) - 5;
    xx *= ((int64_t)1 << sh);
    yy *= ((int64_t)1 << sh);
    for (i = 0; i < FW_CORDIC_ITERS; i++) {
        int64_t xs = fw_math_asr_i64(xx, i);
        int64_t ys = fw_math_asr_i64(yy, i);
        if (yy > 0) {
            xx += ys;
            yy -= xs;
            z += fw_cordic_atan_t48[i];
        } else {
            xx -= ys;
            yy += xs;
            z -= fw_cordic_atan_t48[i];
        }
    }
    return base + bam_wrap(fw_math_rshift_round_i64(z, FW_CORDIC_BAM_SHIFT));
}

fw_bam_t fw_math_bam_from_rad_q30(q30_t rad)
{
    return bam_wrap(fw_math_rshift_round_i64((int64_t)rad * fw_two_over_pi_u32, 32));
}

q30_t fw_math_rad_q30_from_bam(fw_bam_t a)
{
    return fw_math_sat_i32(fw_math_rshift_round_i64(bam_signed(a) * fw_pi_over_2_q30, FW_Q30_FRAC), NULL);
}

bool fw_math_unit_q15(int32_t x, int32_t y, q15_t *c, q15_t *s)
{
    int64_t xx = x;
    int64_t yy = y;
    int64_t m;
    int32_t len;
    int64_t cv;
    int64_t sv;
    int sh = 0;
    if (x == 0 && y == 0) {
        *c = 0;
        *s = 0;
        return false;
    }
    m = (xx < 0 ? -xx : xx);
    if ((yy < 0 ? -yy : yy) > m) {
        m = (yy < 0 ? -yy : yy);
    }
    /* bring max(|x|, |y|) into [2^14, 2^15): squares sum < 2^31 */
    while (m >= ((int64_t)1 << 15)) {
        m >>= 1;
        sh--;
    }
    while (m < ((int64_t)1 << 14)) {
        m <<= 1;
        sh++;
    }
    if (sh < 0) {
        xx = fw_math_rshift_round_i64(xx, -sh);
        yy = fw_math_rshift_round_i64(yy, -sh);
    } else {
        xx *= ((int64_t)1 << sh);
        yy *= ((int64_t)1 << sh);
    }
    len = (int32_t)fw_math_isqrt_round_u64((uint64_t)(xx * xx + yy * yy));
    cv = fw_math_div_round_i64(xx * ((int64_t)1 << FW_Q15_FRAC), len);
    sv = fw_math_div_round_i64(yy * ((int64_t)1 << FW_Q15_FRAC), len);
    if (cv > FW_Q15_MAX) {
        cv = FW_Q15_MAX;
    }
    if (cv < -FW_Q15_MAX) {
        cv = -FW_Q15_MAX;
    }
    if (sv > FW_Q15_MAX) {
        sv = FW_Q15_MAX;
    }
    if (sv < -FW_Q15_MAX) {
        sv = -FW_Q15_MAX;
    }
    *c = (q15_t)cv;
    *s = (q15_t)sv;
    return true;
}

void fw_math_rotate_i32(int32_t x, int32_t y, q30_t c, q30_t s,
                        int32_t *xr, int32_t *yr, bool *sat)
{
    c = (c > FW_Q30_ONE) ? FW_Q30_ONE : ((c < -FW_Q30_ONE) ? -FW_Q30_ONE : c);
    s = (s > FW_Q30_ONE) ? FW_Q30_ONE : ((s < -FW_Q30_ONE) ? -FW_Q30_ONE : s);
    fw_math_rotate_unit_i32(x, y, c, s, xr, yr, sat);
}
