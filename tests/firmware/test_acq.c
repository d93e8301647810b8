/* test_acq.c - fw_acq: ADC quantisation, saturation, filter, baseline, S_n'. */
#include "unity.h"
#include "fw_acq.h"
#include "test_util.h"

void setUp(void) {}
void tearDown(void) {}

static int32_t ref_code(int32_t bits, int32_t uv)
{
    double c = (double)uv * TU_TWO_POW(bits - 1) / 1e7;
    double top = TU_TWO_POW(bits - 1);
    c = (c < 0) ? -floor(-c + 0.5) : floor(c + 0.5);
    if (c > top - 1.0) {
        c = top - 1.0;
    }
    if (c < -top) {
        c = -top;
    }
    return (int32_t)c;
}

typedef struct { int line; int32_t bits; int32_t uv; int32_t code; bool sat; } q_row_t;

static void test_acq_rails_at_just_past_and_far_past_10v(void)
{
    static const q_row_t rows[] = {
        { __LINE__, 16, 10000000, 32767, true },       /* at +10 V */
        { __LINE__, 16, 10000001, 32767, true },       /* just past */
        { __LINE__, 16, INT32_MAX, 32767, true },      /* far past */
        { __LINE__, 16, 9999999, 32767, false },       /* just inside: top code, not saturated */
        { __LINE__, 16, -10000000, -32768, true },
        { __LINE__, 16, -10000001, -32768, true },
        { __LINE__, 16, INT32_MIN, -32768, true },
        { __LINE__, 16, -9999999, -32768, false },
        { __LINE__, 14, 10000000, 8191, true },
        { __LINE__, 14, -10000000, -8192, true },
        { __LINE__, 14, INT32_MIN, -8192, true },
        { __LINE__, 12, 10000001, 2047, true },
        { __LINE__, 12, -10000001, -2048, true },
        { __LINE__, 12, 0, 0, false },
        { __LINE__, 12, 2441, 0, false },              /* 0.49995 LSB of 4882.8 uV */
        { __LINE__, 12, 2442, 1, false },
        { __LINE__, 12, -2442, -1, false },
        { __LINE__, 16, 152, 0, false },               /* LSB 305.18 uV */
        { __LINE__, 16, 153, 1, false },
        { __LINE__, 15, 1000, 2, false },              /* LSB 610.35 uV: 1.64 LSB */
        { __LINE__, 8, 39062, 0, false },              /* LSB 78125 uV: 0.49999 LSB */
        { __LINE__, 8, 39063, 1, false },
        { __LINE__, 8, 10000000, 127, true },
        { __LINE__, 7, 1000, 0, false },               /* unsupported width: 0 */
        { __LINE__, 17, 1000, 0, false },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        bool sat = !rows[i].sat;
        int32_t c = fw_acq_quantize_code(rows[i].bits, rows[i].uv, &sat);
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].code, c, rows[i].line, "code");
        UNITY_TEST_ASSERT(rows[i].sat == sat, rows[i].line, "saturation flag");
    }
}

static void test_acq_quantize_sweep_matches_double_exactly(void)
{
    tu_rng_t rng;
    long i;
    tu_rng_seed(&rng, 21);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        int32_t bits = FW_ACQ_BITS_MIN + (int32_t)(i % (FW_ACQ_BITS_MAX - FW_ACQ_BITS_MIN + 1));
        int32_t uv = tu_rng_range(&rng, -12000000, 12000000);
        TEST_ASSERT_EQUAL_INT32(ref_code(bits, uv), fw_acq_quantize_code(bits, uv, NULL));
    }
    printf("SWEEP acq_quantize n=%ld worst=0 LSB (exact)\n", (long)AFM_SWEEP_N);
}

/* The reciprocal quantiser (fw_acq.h): exact at every code boundary, one
 * microvolt either side, for every width; on the host (10^6 sweeps) also at
 * every input from -10 V to +10 V. The step path uses the same kernel
 * behind its own fast range test: checked at the boundaries too. */
static void test_acq_quantize_reciprocal_exact_at_every_code_boundary(void)
{
    static const int32_t widths[] = { 8, 9, 10, 11, 12, 13, 14, 15, 16 };
    size_t w;
    for (w = 0; w < sizeof widths / sizeof widths[0]; w++) {
        int32_t bits = widths[w];
        int32_t half = (int32_t)1 << (bits - 1);
        int32_t k;
        fw_acq_t a;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&a, bits, 0));
        for (k = -half; k <= half; k++) {
            /* first uv with round(uv 2^(bits-1) / 1e7) >= k (k > 0) */
            int32_t b = (int32_t)ceil((k - 0.5) * 1e7 / TU_TWO_POW(bits - 1));
            int32_t d;
            for (d = -1; d <= 1; d++) {
                int32_t uv = b + d;
                int32_t code;
                q23_t v;
                bool sat;
                TEST_ASSERT_EQUAL_INT32(ref_code(bits, uv), fw_acq_quantize_code(bits, uv, NULL));
                TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_step_q23(&a, uv, &code, &v, &sat));
                TEST_ASSERT_EQUAL_INT32(ref_code(bits, uv), code);
                TEST_ASSERT_EQUAL_INT32(code * a.lsb_v, v);
                TEST_ASSERT_TRUE(sat == (uv >= 10000000 || uv <= -10000000));
            }
        }
    }
#if AFM_SWEEP_N >= 1000000
    for (w = 0; w < sizeof widths / sizeof widths[0]; w++) {
        int32_t uv;
        for (uv = -10000000; uv <= 10000000; uv++) {
            if (fw_acq_quantize_code(widths[w], uv, NULL) != ref_code(widths[w], uv)) {
                TEST_ASSERT_EQUAL_INT32(ref_code(widths[w], uv), fw_acq_quantize_code(widths[w], uv, NULL));
            }
        }
    }
    printf("EXHAUSTIVE acq_quantize 3 x 20000001 inputs: exact\n");
#endif
}

/* The fast range (fw_acq_in_fast_range) ends one microvolt either side of
 * its documented edges, and the fast kernel and step give the checked
 * ones' code, signal and state for every input inside it (host: all
 * 2 10^7 inputs per width; cross: a stride). */
static void test_acq_fast_range_edges_and_fast_step_exact(void)
{
    static const struct { int line; int32_t bits; int32_t hi_uv; } rows[] = {
        { __LINE__, 16, 9999847 },   /* 9999848 rounds to 2^15: clamped */
        { __LINE__, 14, 9999389 },
        { __LINE__, 12, 9997558 },
        { __LINE__, 10, 9990234 },   /* 10^7 - 5 10^6 / 2^9 = 9990234.4 rounds to 2^9 */
        { __LINE__, 8, 9960937 },
    };
    size_t w;
    for (w = 0; w < sizeof rows / sizeof rows[0]; w++) {
        int32_t bits = rows[w].bits;
        int32_t half = (int32_t)1 << (bits - 1);
        int32_t hi = rows[w].hi_uv;
        int32_t stride = (AFM_SWEEP_N >= 1000000) ? 1 : 997;
        fw_acq_t a;
        fw_acq_t c;
        int32_t uv;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&a, bits, 0));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&c, bits, 0));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&a, -7 * FW_Q23_ONE));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&c, -7 * FW_Q23_ONE));
        UNITY_TEST_ASSERT(fw_acq_in_fast_range(&a, -9999999), rows[w].line, "-(FS - 1) inside");
        UNITY_TEST_ASSERT(!fw_acq_in_fast_range(&a, -10000000), rows[w].line, "-FS outside");
        UNITY_TEST_ASSERT(fw_acq_in_fast_range(&a, hi), rows[w].line, "top edge inside");
        UNITY_TEST_ASSERT(!fw_acq_in_fast_range(&a, hi + 1), rows[w].line, "top edge + 1 outside");
        UNITY_TEST_ASSERT(!fw_acq_in_fast_range(&a, INT32_MIN), rows[w].line, "INT32_MIN outside");
        UNITY_TEST_ASSERT(!fw_acq_in_fast_range(&a, INT32_MAX), rows[w].line, "INT32_MAX outside");
        /* the edge is where the clamp starts: hi + 1 rounds to 2^(bits-1) */
        UNITY_TEST_ASSERT_EQUAL_INT32(half - 1, fw_acq_code_fast(&a, hi), rows[w].line, "top code");
        UNITY_TEST_ASSERT_EQUAL_INT32(half, fw_acq_code_fast(&a, hi + 1), rows[w].line, "clamp due");
        UNITY_TEST_ASSERT_EQUAL_INT32(-half, fw_acq_code_fast(&a, -9999999), rows[w].line, "bottom code");
        for (uv = -9999999;; uv = (hi - uv > stride) ? uv + stride : hi) {
            int32_t code_c;
            int32_t code_f;
            q23_t v_c;
            q23_t v_f;
            bool sat;
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_step_q23(&c, uv, &code_c, &v_c, &sat));
            code_f = fw_acq_code_fast(&a, uv);
            v_f = fw_acq_take_code_q23(&a, code_f);
            if (code_c != code_f || v_c != v_f || a.last_v != c.last_v || sat) {
                UNITY_TEST_ASSERT_EQUAL_INT32(code_c, code_f, rows[w].line, "code");
                UNITY_TEST_ASSERT_EQUAL_INT32(v_c, v_f, rows[w].line, "signal");
                UNITY_TEST_ASSERT_EQUAL_INT32(c.last_v, a.last_v, rows[w].line, "last_v");
                UNITY_TEST_ASSERT(!sat, rows[w].line, "saturated inside the fast range");
            }
            if (uv == hi) {
                break;
            }
        }
        TEST_ASSERT_EQUAL_UINT32(0u, c.sat_count);
    }
    printf("EXHAUSTIVE acq fast range: step and fast step identical (stride %d)\n",
           (AFM_SWEEP_N >= 1000000) ? 1 : 997);
}

static void test_acq_code_to_volts_exact(void)
{
    /* 16 bit: one code = 20 V / 65536 = 305.17578125 uV = 2560 LSB of 9.23 */
    TEST_ASSERT_EQUAL_INT32(2560, fw_acq_code_to_q23(16, 1));
    TEST_ASSERT_EQUAL_INT32(-32768 * 2560, fw_acq_code_to_q23(16, -32768));
    TEST_ASSERT_EQUAL_INT32(-10 * FW_Q23_ONE, fw_acq_code_to_q23(12, -2048));
    TEST_ASSERT_EQUAL_INT32(-10 * FW_Q23_ONE, fw_acq_code_to_q23(14, -8192));
}

static void test_acq_init_rejects_bad_bits_and_filter(void)
{
    fw_acq_t a;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_init(&a, 7, 0));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_init(&a, 17, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&a, 13, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&a, 8, 0));
    TEST_ASSERT_EQUAL_INT32(-128, fw_acq_quantize_code(8, -10000000, NULL));
    TEST_ASSERT_EQUAL_INT32(127, fw_acq_quantize_code(8, 10000000, NULL));
    TEST_ASSERT_EQUAL_INT32(0, fw_acq_quantize_code(7, 5000000, NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_init(&a, 16, 5));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_init(&a, 16, -1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_init(NULL, 16, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&a, 14, 4));
}

static void test_acq_step_sticky_flag_and_counter(void)
{
    fw_acq_t a;
    int32_t code;
    q23_t v;
    bool sat;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&a, 16, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_step_q23(&a, 11000000, &code, &v, &sat));
    TEST_ASSERT_TRUE(sat);
    TEST_ASSERT_EQUAL_INT32(32767, code);
    TEST_ASSERT_EQUAL_INT32(32767 * 2560, v);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_step_q23(&a, 1000000, &code, &v, &sat));
    TEST_ASSERT_FALSE(sat);
    TEST_ASSERT_TRUE(a.sat_sticky);
    TEST_ASSERT_EQUAL_UINT32(1u, a.sat_count);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_step_q23(&a, -10000000, &code, &v, &sat));
    TEST_ASSERT_TRUE(sat);
    TEST_ASSERT_EQUAL_UINT32(2u, a.sat_count);
    fw_acq_reset(&a);
    TEST_ASSERT_FALSE(a.sat_sticky);
    TEST_ASSERT_EQUAL_UINT32(0u, a.sat_count);
    a.sat_count = UINT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_step_q23(&a, -20000000, &code, &v, &sat));
    TEST_ASSERT_EQUAL_UINT32(UINT32_MAX, a.sat_count);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_step_q23(&a, 0, NULL, &v, &sat));
}

static void test_acq_filter_averages_and_baseline_subtracts(void)
{
    fw_acq_t a;
    int32_t code;
    q23_t v;
    bool sat;
    int i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_init(&a, 16, 2));
    /* codes 100, 200 -> mean 150 codes while filling */
    (void)fw_acq_step_q23(&a, 30518, &code, &v, &sat);
    TEST_ASSERT_EQUAL_INT32(100, code);
    (void)fw_acq_step_q23(&a, 61035, &code, &v, &sat);
    TEST_ASSERT_EQUAL_INT32(200, code);
    TEST_ASSERT_EQUAL_INT32(150 * 2560, v);
    for (i = 0; i < 4; i++) {
        (void)fw_acq_step_q23(&a, 61035, &code, &v, &sat);
    }
    TEST_ASSERT_EQUAL_INT32(200 * 2560, v);
    fw_acq_record_baseline(&a);
    (void)fw_acq_step_q23(&a, 61035, &code, &v, &sat);
    TEST_ASSERT_EQUAL_INT32(0, v);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_set_baseline_q23(&a, 11 * FW_Q23_ONE));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&a, -10 * FW_Q23_ONE));
    (void)fw_acq_step_q23(&a, 61035, &code, &v, &sat);
    TEST_ASSERT_EQUAL_INT32(200 * 2560 + 10 * FW_Q23_ONE, v);
}

static void test_acq_virtual_sn_paper_depth_2000nm(void)
{
    /* 2000 nm down from the last unsaturated sample at 0 V, K_n = 89 nm/V:
     * S_n' = 22.472 V */
    q23_t v;
    bool sat = false;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_virtual_sn_q23(0, 0, -2000000, 89000, &v, &sat));
    TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(2000.0 / 89.0 * TU_TWO_POW(23)), v);
    TEST_ASSERT_FALSE(sat);
    /* continuity with the reference */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_virtual_sn_q23(9 * FW_Q23_ONE, 5000, 5000, 89000, &v, &sat));
    TEST_ASSERT_EQUAL_INT32(9 * FW_Q23_ONE, v);
    /* 9.23 saturates at 256 V: 2^31 pm / 1 pm/V */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_virtual_sn_q23(0, INT32_MAX, INT32_MIN, 1, &v, &sat));
    TEST_ASSERT_EQUAL_INT32(FW_Q23_MAX, v);
    TEST_ASSERT_TRUE(sat);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_acq_virtual_sn_q23(0, 0, 0, 0, &v, &sat));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_acq_rails_at_just_past_and_far_past_10v);
    RUN_TEST(test_acq_quantize_sweep_matches_double_exactly);
    RUN_TEST(test_acq_quantize_reciprocal_exact_at_every_code_boundary);
    RUN_TEST(test_acq_fast_range_edges_and_fast_step_exact);
    RUN_TEST(test_acq_code_to_volts_exact);
    RUN_TEST(test_acq_init_rejects_bad_bits_and_filter);
    RUN_TEST(test_acq_step_sticky_flag_and_counter);
    RUN_TEST(test_acq_filter_averages_and_baseline_subtracts);
    RUN_TEST(test_acq_virtual_sn_paper_depth_2000nm);
    return UNITY_END();
}
