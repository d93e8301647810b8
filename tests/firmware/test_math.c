/* test_math.c - fw_math: saturation, roots, angles, CORDIC trig. */
#include "unity.h"
#include "fw_math.h"
#include "test_util.h"

void setUp(void) {}
void tearDown(void) {}

/* ---- saturation at every format's MAXPOS / MAXNEG ---------------------- */

typedef struct { int line; int32_t a; int32_t b; int32_t expect; bool sat; } sat_row_t;

static void test_math_add_q31_saturates_exactly_at_maxpos_maxneg(void)
{
    static const sat_row_t rows[] = {
        { __LINE__, FW_Q31_MAX, 1, FW_Q31_MAX, true },
        { __LINE__, FW_Q31_MAX, FW_Q31_MAX, FW_Q31_MAX, true },
        { __LINE__, FW_Q31_MIN, -1, FW_Q31_MIN, true },
        { __LINE__, FW_Q31_MIN, FW_Q31_MIN, FW_Q31_MIN, true },
        { __LINE__, FW_Q31_MAX, 0, FW_Q31_MAX, false },
        { __LINE__, FW_Q31_MAX, FW_Q31_MIN, -1, false },
        { __LINE__, FW_Q31_MAX - 1, 1, FW_Q31_MAX, false },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        bool sat = false;
        int32_t r = fw_math_add_q31(rows[i].a, rows[i].b, &sat);
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].expect, r, rows[i].line, "add_q31");
        UNITY_TEST_ASSERT(rows[i].sat == sat, rows[i].line, "add_q31 flag");
    }
}

static void test_math_sub_q31_saturates_exactly(void)
{
    bool sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q31_MIN, fw_math_sub_q31(FW_Q31_MIN, 1, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q31_MAX, fw_math_sub_q31(0, FW_Q31_MIN, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT32(-FW_Q31_MAX, fw_math_sub_q31(0, FW_Q31_MAX, &sat));
    TEST_ASSERT_FALSE(sat);
}

static void test_math_mul_minus_one_squared_saturates_to_maxpos(void)
{
    bool sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q31_MAX, fw_math_mul_q31(FW_Q31_MIN, FW_Q31_MIN, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT16(FW_Q15_MAX, fw_math_mul_q15(FW_Q15_MIN, FW_Q15_MIN, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    /* 2.30: (-2) * (-2) = 4 does not fit, nor (-2) * 2 = -4 */
    TEST_ASSERT_EQUAL_INT32(FW_Q30_MAX, fw_math_mul_q30(FW_Q30_MIN, FW_Q30_MIN, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q30_MIN, fw_math_mul_q30(FW_Q30_MIN, FW_Q30_MAX, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    /* in-range products do not touch the flag */
    TEST_ASSERT_EQUAL_INT32(FW_Q31_MIN + 1, fw_math_mul_q31(FW_Q31_MIN, FW_Q31_MAX, &sat));
    TEST_ASSERT_EQUAL_INT16(-FW_Q15_MAX, fw_math_mul_q15(FW_Q15_MIN, FW_Q15_MAX, &sat));
    TEST_ASSERT_EQUAL_INT32(FW_Q30_ONE, fw_math_mul_q30(FW_Q30_ONE, FW_Q30_ONE, &sat));
    TEST_ASSERT_FALSE(sat);
}

static void test_math_scale_and_shift_saturate_q24_q23_q16(void)
{
    bool sat = false;
    /* q24 max times 2.0 (q24 gain) */
    TEST_ASSERT_EQUAL_INT32(FW_Q24_MAX, fw_math_scale_i32(FW_Q24_MAX, 2 * FW_Q24_ONE, FW_Q24_FRAC, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q23_MIN, fw_math_scale_i32(FW_Q23_MIN, 2 * FW_Q23_ONE, FW_Q23_FRAC, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q16_MAX, fw_math_shift_i32(FW_Q16_MAX, 1, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q16_MIN, fw_math_shift_i32(FW_Q16_MIN, 40, &sat));
    TEST_ASSERT_TRUE(sat);
    sat = false;
    TEST_ASSERT_EQUAL_INT32(FW_Q16_MIN, fw_math_shift_i32(FW_Q16_MIN, 0, &sat));
    TEST_ASSERT_EQUAL_INT32(-(1 << 15), fw_math_shift_i32(FW_Q16_MIN, -16, &sat));
    TEST_ASSERT_EQUAL_INT32(0, fw_math_shift_i32(FW_Q16_MIN, -63, &sat));
    /* symmetric rounding: -1.5 -> -2, 1.5 -> 2, -0.5 -> -1 */
    TEST_ASSERT_EQUAL_INT32(-2, fw_math_scale_i32(-3, 1, 1, &sat));
    TEST_ASSERT_EQUAL_INT32(2, fw_math_scale_i32(3, 1, 1, &sat));
    TEST_ASSERT_EQUAL_INT32(-1, fw_math_scale_i32(-1, 1, 1, &sat));
    TEST_ASSERT_FALSE(sat);
}

static void test_math_div_round_half_away_and_zero_den(void)
{
    TEST_ASSERT_EQUAL_INT64(2, fw_math_div_round_i64(3, 2));
    TEST_ASSERT_EQUAL_INT64(-2, fw_math_div_round_i64(-3, 2));
    TEST_ASSERT_EQUAL_INT64(-2, fw_math_div_round_i64(3, -2));
    TEST_ASSERT_EQUAL_INT64(1, fw_math_div_round_i64(4, 3));
    TEST_ASSERT_EQUAL_INT64(0, fw_math_div_round_i64(5, 0));
    TEST_ASSERT_EQUAL_INT64(INT64_MAX, fw_math_div_round_i64(INT64_MIN, -1));
}

/* A signed value of random width (0 to 63 bits) and sign: every path of
 * the divisions below (the extremes are among their fixed cases). */
static int64_t random_width_i64(tu_rng_t *rng)
{
    const int64_t v = (int64_t)(tu_rng_u64(rng) >> (1u + tu_rng_u32(rng) % 63u));
    return (tu_rng_u32(rng) & 1u) ? -v : v;
}

/* The division as it was written first (64-bit only): the reference the
 * fast paths (a power-of-two den, 32-bit operands) must equal everywhere. */
static int64_t div_round_reference(int64_t num, int64_t den)
{
    uint64_t un, ud, q;
    bool neg;
    if (den == 0) {
        return 0;
    }
    neg = (num < 0) != (den < 0);
    un = (num < 0) ? (uint64_t)0 - (uint64_t)num : (uint64_t)num;
    ud = (den < 0) ? (uint64_t)0 - (uint64_t)den : (uint64_t)den;
    q = un / ud;
    if ((un % ud) >= ud - (un % ud)) {
        q++;
    }
    if (q > (uint64_t)INT64_MAX) {
        return neg ? INT64_MIN : INT64_MAX;
    }
    return neg ? -(int64_t)q : (int64_t)q;
}

static void test_math_div_round_fast_paths_equal_the_64_bit_division(void)
{
    static const int64_t edge[] = {0, 1, -1, 2, -2, 3, 7, 8, 9, 15, 16, 17, 1023, 1024, 1025,
                                   INT32_MAX, INT32_MIN, (int64_t)INT32_MAX + 1, (int64_t)UINT32_MAX,
                                   (int64_t)UINT32_MAX + 1, -(int64_t)UINT32_MAX, -(int64_t)UINT32_MAX - 1,
                                   (int64_t)1 << 62, -((int64_t)1 << 62), INT64_MAX, INT64_MIN, INT64_MAX - 1,
                                   INT64_MIN + 1};
    tu_rng_t rng;
    size_t i, j;
    int k;
    for (i = 0; i < sizeof edge / sizeof edge[0]; i++) {
        for (j = 0; j < sizeof edge / sizeof edge[0]; j++) {
            TEST_ASSERT_EQUAL_INT64(div_round_reference(edge[i], edge[j]), fw_math_div_round_i64(edge[i], edge[j]));
        }
        for (k = 0; k < 63; k++) {   /* every power of two, both signs, and one off */
            int64_t p = (int64_t)1 << k;
            TEST_ASSERT_EQUAL_INT64(div_round_reference(edge[i], p), fw_math_div_round_i64(edge[i], p));
            TEST_ASSERT_EQUAL_INT64(div_round_reference(edge[i], -p), fw_math_div_round_i64(edge[i], -p));
            TEST_ASSERT_EQUAL_INT64(div_round_reference(edge[i], p + 1), fw_math_div_round_i64(edge[i], p + 1));
            TEST_ASSERT_EQUAL_INT64(div_round_reference(p + p / 2, p), fw_math_div_round_i64(p + p / 2, p));   /* ties */
            TEST_ASSERT_EQUAL_INT64(div_round_reference(-(p + p / 2), p), fw_math_div_round_i64(-(p + p / 2), p));
        }
    }
    tu_rng_seed(&rng, 17);
    for (i = 0; i < 200000u; i++) {   /* random operands of every width */
        const int64_t n = random_width_i64(&rng);
        const int64_t d = random_width_i64(&rng);
        TEST_ASSERT_EQUAL_INT64(div_round_reference(n, d), fw_math_div_round_i64(n, d));
    }
}

/* The 16-bit-divisor division equals C's 64-bit `/` (truncation toward
 * zero) for every divisor width around its limit, both signs, and 64-bit
 * dividends of every width; den 0 gives 0 and INT64_MIN / -1 saturates. */
static void test_math_div_trunc_by_small_equals_c_division(void)
{
    static const int32_t dens[] = {1, -1, 2, -2, 3, 7, -7, 255, 256, 32767, -32768, 32768, 65535, -65535,
                                   65536, -65536, 65537, 1000003, INT32_MAX, INT32_MIN};
    static const int64_t nums[] = {0, 1, -1, 65535, 65536, -65536, INT32_MAX, INT32_MIN, (int64_t)UINT32_MAX,
                                   (int64_t)1 << 47, -((int64_t)1 << 47), (int64_t)1 << 62, INT64_MAX,
                                   INT64_MIN + 1, INT64_MIN};
    tu_rng_t rng;
    size_t i, j;
    for (i = 0; i < sizeof nums / sizeof nums[0]; i++) {
        for (j = 0; j < sizeof dens / sizeof dens[0]; j++) {
            if (nums[i] == INT64_MIN && dens[j] == -1) {
                continue;   /* undefined in C; below */
            }
            TEST_ASSERT_EQUAL_INT64(nums[i] / dens[j], fw_math_div_trunc_i64_by_small(nums[i], dens[j]));
        }
    }
    TEST_ASSERT_EQUAL_INT64(0, fw_math_div_trunc_i64_by_small(12345, 0));
    TEST_ASSERT_EQUAL_INT64(INT64_MAX, fw_math_div_trunc_i64_by_small(INT64_MIN, -1));
    tu_rng_seed(&rng, 19);
    for (i = 0; i < 200000u; i++) {
        const int64_t n = random_width_i64(&rng);
        const int32_t m = (int32_t)(tu_rng_u32(&rng) >> (16u + tu_rng_u32(&rng) % 16u));   /* 0 to 2^16 - 1, of every width */
        const int32_t d = (tu_rng_u32(&rng) & 1u) ? -m : m;
        if (d == 0) {
            continue;
        }
        TEST_ASSERT_EQUAL_INT64(n / d, fw_math_div_trunc_i64_by_small(n, d));
    }
}

static void test_math_asr_floors_negative_values(void)
{
    TEST_ASSERT_EQUAL_INT64(-1, fw_math_asr_i64(-1, 5));
    TEST_ASSERT_EQUAL_INT64(-2, fw_math_asr_i64(-3, 1));
    TEST_ASSERT_EQUAL_INT64(INT64_MIN / 4, fw_math_asr_i64(INT64_MIN, 2));
    TEST_ASSERT_EQUAL_INT64(-1, fw_math_rshift_round_i64(-3, 1));
    TEST_ASSERT_EQUAL_INT64(2, fw_math_rshift_round_i64(3, 1));
}

/* ---- isqrt ------------------------------------------------------------- */

static void check_isqrt(uint64_t v)
{
    uint32_t r = fw_math_isqrt_u64(v);
    uint64_t r2 = (uint64_t)r * r;
    TEST_ASSERT_TRUE(r2 <= v);
    if (r != UINT32_MAX) {
        TEST_ASSERT_TRUE((uint64_t)(r + 1u) * (r + 1u) > v);
    }
}

static void test_math_isqrt_exact_at_edges_and_random(void)
{
    tu_rng_t rng;
    long i;
    check_isqrt(0);
    check_isqrt(1);
    check_isqrt(UINT64_MAX);
    check_isqrt((uint64_t)UINT32_MAX * UINT32_MAX);
    check_isqrt((uint64_t)UINT32_MAX * UINT32_MAX - 1u);
    /* both sides of the 32-bit path's edge, and squares at it */
    check_isqrt((uint64_t)UINT32_MAX);
    check_isqrt((uint64_t)UINT32_MAX + 1u);
    check_isqrt((uint64_t)UINT32_MAX + 2u);
    check_isqrt((uint64_t)65535u * 65535u);
    check_isqrt((uint64_t)65535u * 65535u - 1u);
    check_isqrt((uint64_t)65536u * 65536u);
    for (i = 0; i < 64; i++) {   /* every power of two, and one below */
        check_isqrt((uint64_t)1 << i);
        check_isqrt(((uint64_t)1 << i) - 1u);
    }
    TEST_ASSERT_EQUAL_UINT32(UINT32_MAX, fw_math_isqrt_u64(UINT64_MAX));
    TEST_ASSERT_EQUAL_UINT32(UINT32_MAX, fw_math_isqrt_round_u64(UINT64_MAX));
    TEST_ASSERT_EQUAL_UINT32(2, fw_math_isqrt_round_u64(5));  /* 2.236 */
    TEST_ASSERT_EQUAL_UINT32(3, fw_math_isqrt_round_u64(7));  /* 2.646 */
    TEST_ASSERT_EQUAL_UINT32(2, fw_math_isqrt_round_u64(6));  /* 2.449 */
    TEST_ASSERT_EQUAL_INT32(FW_Q30_ONE, fw_math_sqrt_q30(FW_Q30_ONE));
    TEST_ASSERT_EQUAL_INT32(0, fw_math_sqrt_q30(-5));
    tu_rng_seed(&rng, 11);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        uint64_t v = tu_rng_u64(&rng) >> (tu_rng_u32(&rng) % 64u);
        check_isqrt(v);
    }
}

/* ---- angles and trig --------------------------------------------------- */

static void test_math_bam_mdeg_round_trip(void)
{
    TEST_ASSERT_EQUAL_UINT32(0u, fw_math_bam_from_mdeg(0));
    TEST_ASSERT_EQUAL_UINT32(FW_BAM_QUARTER_TURN, fw_math_bam_from_mdeg(90000));
    TEST_ASSERT_EQUAL_UINT32(FW_BAM_HALF_TURN, fw_math_bam_from_mdeg(-180000));
    TEST_ASSERT_EQUAL_UINT32(0u - FW_BAM_QUARTER_TURN, fw_math_bam_from_mdeg(-90000));
    TEST_ASSERT_EQUAL_UINT32(FW_BAM_QUARTER_TURN, fw_math_bam_from_mdeg(90000 + 5 * FW_MDEG_PER_TURN));
    TEST_ASSERT_EQUAL_INT32(-180000, fw_math_mdeg_from_bam(FW_BAM_HALF_TURN));
    TEST_ASSERT_EQUAL_INT32(45000, fw_math_mdeg_from_bam(fw_math_bam_from_mdeg(45000)));
    TEST_ASSERT_EQUAL_INT32(-1, fw_math_mdeg_from_bam(fw_math_bam_from_mdeg(-1)));
    /* INT32 extremes do not overflow */
    (void)fw_math_bam_from_mdeg(INT32_MIN);
    (void)fw_math_bam_from_mdeg(INT32_MAX);
}

static void test_math_sincos_exact_at_right_angles(void)
{
    static const struct { int line; fw_bam_t a; q30_t s; q30_t c; } rows[] = {
        { __LINE__, 0u, 0, FW_Q30_ONE },
        { __LINE__, FW_BAM_QUARTER_TURN, FW_Q30_ONE, 0 },
        { __LINE__, FW_BAM_HALF_TURN, 0, -FW_Q30_ONE },
        { __LINE__, 3u * FW_BAM_QUARTER_TURN, -FW_Q30_ONE, 0 },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        q30_t s;
        q30_t c;
        fw_math_sincos_q30(rows[i].a, &s, &c);
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].s, s, rows[i].line, "sin");
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].c, c, rows[i].line, "cos");
    }
}

static void test_math_sincos_one_lsb_off_right_angles(void)
{
    /* one LSB of angle (1.46e-9 rad) either side of 0 and pi */
    static const fw_bam_t angles[] = { 1u, 0xFFFFFFFFu, FW_BAM_HALF_TURN - 1u, FW_BAM_HALF_TURN + 1u,
                                       FW_BAM_QUARTER_TURN - 1u, FW_BAM_QUARTER_TURN + 1u };
    size_t i;
    for (i = 0; i < sizeof angles / sizeof angles[0]; i++) {
        double a = tu_bam_rad(angles[i]);
        q30_t s;
        q30_t c;
        fw_math_sincos_q30(angles[i], &s, &c);
        TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(sin(a) * TU_TWO_POW(30)), s);
        TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(cos(a) * TU_TWO_POW(30)), c);
    }
}

static void test_math_sincos_sweep_within_1_lsb(void)
{
    tu_rng_t rng;
    tu_err_t es;
    tu_err_t ec;
    long i;
    tu_rng_seed(&rng, 1);
    tu_err_init(&es, "sin_q30", "(unit)", 1.0 / TU_TWO_POW(30));
    tu_err_init(&ec, "cos_q30", "(unit)", 1.0 / TU_TWO_POW(30));
    for (i = 0; i < AFM_SWEEP_N; i++) {
        fw_bam_t a = tu_rng_u32(&rng);
        q30_t s;
        q30_t c;
        double ar = tu_bam_rad(a);
        fw_math_sincos_q30(a, &s, &c);
        tu_err_add(&es, tu_q(s, 30) - sin(ar));
        tu_err_add(&ec, tu_q(c, 30) - cos(ar));
    }
    tu_err_print(&es);
    tu_err_print(&ec);
    TEST_ASSERT_TRUE(tu_err_worst_lsb(&es) <= 1.0);
    TEST_ASSERT_TRUE(tu_err_worst_lsb(&ec) <= 1.0);
}

static void test_math_atan2_axes_exact(void)
{
    TEST_ASSERT_EQUAL_UINT32(0u, fw_math_atan2_bam(0, 0));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_math_atan2_bam(0, 5));
    TEST_ASSERT_EQUAL_UINT32(FW_BAM_HALF_TURN, fw_math_atan2_bam(0, -5));
    TEST_ASSERT_EQUAL_UINT32(FW_BAM_QUARTER_TURN, fw_math_atan2_bam(7, 0));
    TEST_ASSERT_EQUAL_UINT32(0u - FW_BAM_QUARTER_TURN, fw_math_atan2_bam(-7, 0));
    TEST_ASSERT_EQUAL_UINT32(FW_BAM_HALF_TURN, fw_math_atan2_bam(0, INT32_MIN));
    TEST_ASSERT_UINT32_WITHIN(2u, FW_BAM_HALF_TURN + FW_BAM_QUARTER_TURN / 2u,
                              fw_math_atan2_bam(INT32_MIN, INT32_MIN));
}

static void test_math_atan2_sweep_within_1_lsb(void)
{
    tu_rng_t rng;
    tu_err_t e;
    long i;
    tu_rng_seed(&rng, 2);
    tu_err_init(&e, "atan2_bam", "rad", 2.0 * TU_PI / 4294967296.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        /* mix of magnitudes: full int32 and small vectors */
        int sh = (int)(tu_rng_u32(&rng) % 31u);
        int32_t y = (int32_t)tu_rng_u32(&rng) >> sh;
        int32_t x = (int32_t)tu_rng_u32(&rng) >> sh;
        fw_bam_t a = fw_math_atan2_bam(y, x);
        double ref = atan2((double)y, (double)x);
        tu_err_add(&e, tu_wrap_pi(tu_bam_rad(a) - ref));
    }
    tu_err_print(&e);
    TEST_ASSERT_TRUE(tu_err_worst_lsb(&e) <= 1.0);
}

static void test_math_rad_bam_conversions(void)
{
    /* 1 rad */
    fw_bam_t a = fw_math_bam_from_rad_q30(FW_Q30_ONE);
    TEST_ASSERT_UINT32_WITHIN(1u, (uint32_t)llround(4294967296.0 / (2.0 * TU_PI)), a);
    TEST_ASSERT_INT32_WITHIN(2, FW_Q30_ONE, fw_math_rad_q30_from_bam(a));
    /* -1 rad wraps */
    TEST_ASSERT_UINT32_WITHIN(1u, 0u - (uint32_t)llround(4294967296.0 / (2.0 * TU_PI)),
                              fw_math_bam_from_rad_q30(-FW_Q30_ONE));
    /* pi does not fit 2.30: saturates */
    TEST_ASSERT_EQUAL_INT32(FW_Q30_MIN, fw_math_rad_q30_from_bam(FW_BAM_HALF_TURN));
}

static void test_math_unit_q15_sweep_and_zero_vector(void)
{
    tu_rng_t rng;
    tu_err_t e;
    q15_t c;
    q15_t s;
    long i;
    TEST_ASSERT_FALSE(fw_math_unit_q15(0, 0, &c, &s));
    TEST_ASSERT_EQUAL_INT16(0, c);
    TEST_ASSERT_TRUE(fw_math_unit_q15(INT32_MIN, 0, &c, &s));
    TEST_ASSERT_EQUAL_INT16(-FW_Q15_MAX, c);
    TEST_ASSERT_EQUAL_INT16(0, s);
    TEST_ASSERT_TRUE(fw_math_unit_q15(0, 1, &c, &s));
    TEST_ASSERT_EQUAL_INT16(FW_Q15_MAX, s);
    tu_rng_seed(&rng, 3);
    tu_err_init(&e, "unit_q15", "(unit)", 1.0 / 32768.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        int sh = (int)(tu_rng_u32(&rng) % 31u);
        int32_t y = (int32_t)tu_rng_u32(&rng) >> sh;
        int32_t x = (int32_t)tu_rng_u32(&rng) >> sh;
        double len = sqrt((double)x * x + (double)y * y);
        if (!fw_math_unit_q15(x, y, &c, &s)) {
            continue;
        }
        tu_err_add(&e, tu_q(c, 15) - x / len);
        tu_err_add(&e, tu_q(s, 15) - y / len);
    }
    tu_err_print(&e);
    TEST_ASSERT_TRUE(tu_err_worst_lsb(&e) <= 2.0);
}

static void test_math_rotate_quarter_turn_exact_and_saturates(void)
{
    int32_t x;
    int32_t y;
    bool sat = false;
    fw_math_rotate_i32(1000, -7, 0, FW_Q30_ONE, &x, &y, &sat);
    TEST_ASSERT_EQUAL_INT32(7, x);
    TEST_ASSERT_EQUAL_INT32(1000, y);
    TEST_ASSERT_FALSE(sat);
    /* 45 deg of (MAX, MAX) has length sqrt2 MAX: saturates */
    fw_math_rotate_i32(INT32_MAX, INT32_MAX, fw_math_cos_q30(FW_BAM_QUARTER_TURN / 2u),
                       fw_math_sin_q30(FW_BAM_QUARTER_TURN / 2u), &x, &y, &sat);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, y);
    TEST_ASSERT_TRUE(sat);
}

static void test_math_rotate_unit_matches_rotate_and_clz(void)
{
    tu_rng_t rng;
    long i;
    tu_rng_seed(&rng, 4);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        fw_bam_t a = tu_rng_u32(&rng);
        int32_t x = (int32_t)tu_rng_u32(&rng);
        int32_t y = (int32_t)tu_rng_u32(&rng) >> (tu_rng_u32(&rng) % 32u);
        q30_t s;
        q30_t c;
        int32_t xr[2];
        int32_t yr[2];
        bool sat[2] = { false, false };
        fw_math_sincos_q30(a, &s, &c);
        fw_math_rotate_i32(x, y, c, s, &xr[0], &yr[0], &sat[0]);
        fw_math_rotate_unit_i32(x, y, c, s, &xr[1], &yr[1], &sat[1]);
        TEST_ASSERT_EQUAL_INT32(xr[0], xr[1]);
        TEST_ASSERT_EQUAL_INT32(yr[0], yr[1]);
        TEST_ASSERT_TRUE(sat[0] == sat[1]);
    }
    TEST_ASSERT_EQUAL_INT(63, fw_math_clz_u64(1u));
    TEST_ASSERT_EQUAL_INT(0, fw_math_clz_u64(UINT64_MAX));
    TEST_ASSERT_EQUAL_INT(31, fw_math_clz_u64((uint64_t)1 << 32));
    TEST_ASSERT_EQUAL_INT(64, fw_math_clz_u64(0u));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_math_add_q31_saturates_exactly_at_maxpos_maxneg);
    RUN_TEST(test_math_sub_q31_saturates_exactly);
    RUN_TEST(test_math_mul_minus_one_squared_saturates_to_maxpos);
    RUN_TEST(test_math_scale_and_shift_saturate_q24_q23_q16);
    RUN_TEST(test_math_div_round_half_away_and_zero_den);
    RUN_TEST(test_math_div_round_fast_paths_equal_the_64_bit_division);
    RUN_TEST(test_math_div_trunc_by_small_equals_c_division);
    RUN_TEST(test_math_asr_floors_negative_values);
    RUN_TEST(test_math_isqrt_exact_at_edges_and_random);
    RUN_TEST(test_math_bam_mdeg_round_trip);
    RUN_TEST(test_math_sincos_exact_at_right_angles);
    RUN_TEST(test_math_sincos_one_lsb_off_right_angles);
    RUN_TEST(test_math_sincos_sweep_within_1_lsb);
    RUN_TEST(test_math_atan2_axes_exact);
    RUN_TEST(test_math_atan2_sweep_within_1_lsb);
    RUN_TEST(test_math_rad_bam_conversions);
    RUN_TEST(test_math_unit_q15_sweep_and_zero_vector);
    RUN_TEST(test_math_rotate_quarter_turn_exact_and_saturates);
    RUN_TEST(test_math_rotate_unit_matches_rotate_and_clz);
    return UNITY_END();
}
