/* test_hyst.c - fw_hyst: the Prandtl-Ishlinskii model of a scanner axis,
 * its inverse formed at init, their composition, clamps and refusals.
 * References in C's double precision (test_util.h). */
#include <math.h>
#include <string.h>
#include "unity.h"
#include "fw_hyst.h"
#include "test_util.h"
#include "cost_util.h"

#define R_PM 10000000          /* a 20 um axis: +-10 um about its origin */
#define ORIGIN_PM 3000000
#define LOOP_STEPS 4000        /* steps a period of the test loops */
/* P^-1[P[x]] returns x within this (pm) on a +-10 um axis: the inverse's
 * weights rounded to 2^-24 (8 of them, 2^-25 R each: 0.3 pm), its
 * thresholds and each model's sum rounded (0.5 pm each), the direct
 * output's rounding passed on with a slope up to 2. Measured: 1 pm. */
#define ROUND_TRIP_TOL_PM 2

static fw_hyst_t h;

void setUp(void) {}
void tearDown(void) {}

/* A loop about 10 % of the range wide at full range (test_direct_loop...),
 * thresholds equally spaced, weights falling off. */
static fw_hyst_params_t lab_params(void)
{
    static const double w[8] = { 0.56, 0.13, 0.09, 0.07, 0.055, 0.045, 0.035, 0.025 };
    fw_hyst_params_t p;
    int i;
    memset(&p, 0, sizeof p);
    p.n = 8;
    for (i = 0; i < p.n; i++) {
        p.r_pm[i] = (int32_t)((int64_t)R_PM * i / p.n);
        p.w_q24[i] = (q24_t)lround(w[i] * TU_TWO_POW(24));
    }
    p.range_pm = R_PM;
    p.origin_pm = ORIGIN_PM;
    return p;
}

/* The PI model in double: plays z, thresholds r, weights w. */
static double ref_pi(int n, const double *r, const double *w, double *z, double x)
{
    double y = 0.0;
    int i;
    for (i = 0; i < n; i++) {
        z[i] = fmax(x - r[i], fmin(x + r[i], z[i]));
        y += w[i] * z[i];
    }
    return y;
}

static void test_init_forms_kuhnens_inverse_within_one_lsb(void)
{
    const fw_hyst_params_t p = lab_params();
    double W = 0.0, Wprev = 0.0, acc = 0.0;
    int i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    for (i = 0; i < p.n; i++) {
        const double wi = p.w_q24[i] / TU_TWO_POW(24);
        double want_w;
        if (i > 0) {
            acc += W * (p.r_pm[i] - p.r_pm[i - 1]);
        }
        Wprev = W;
        W += wi;
        want_w = (i == 0) ? 1.0 / wi : -wi / (W * Wprev);
        TEST_ASSERT_DOUBLE_WITHIN(2.0, want_w * TU_TWO_POW(24), (double)h.wi_q24[i]);
        TEST_ASSERT_DOUBLE_WITHIN(1.0, acc, (double)h.ri_pm[i]);
    }
    TEST_ASSERT_DOUBLE_WITHIN(1.0, acc + W * (R_PM - p.r_pm[p.n - 1]), (double)h.y_max_pm);
}

static void test_direct_model_follows_the_double_reference_and_its_loop_is_about_10_percent_wide(void)
{
    const fw_hyst_params_t p = lab_params();
    double r[8], w[8], z[8] = { 0 };
    double up = 0.0, down = 0.0, worst = 0.0;
    int k, i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    for (i = 0; i < p.n; i++) {
        r[i] = p.r_pm[i];
        w[i] = p.w_q24[i] / TU_TWO_POW(24);
    }
    for (k = 0; k < 2 * LOOP_STEPS; k++) {
        const int32_t x = (int32_t)lround(R_PM * sin(2.0 * TU_PI * k / LOOP_STEPS));
        const int32_t y = fw_hyst_direct_pm(&h, ORIGIN_PM + x, NULL);
        const double yr = ref_pi(p.n, r, w, z, x);
        worst = fmax(worst, fabs(y - ORIGIN_PM - yr));
        if (k == LOOP_STEPS + LOOP_STEPS / 2 - 1 || k == LOOP_STEPS + LOOP_STEPS / 2 + 1) {
            down += (y - ORIGIN_PM) / 2.0;   /* x = 0 falling (second period) */
        }
        if (k == LOOP_STEPS || k == 2 * LOOP_STEPS - 1) {
            up += (y - ORIGIN_PM) / 2.0;     /* about x = 0 rising */
        }
    }
    printf("direct model: worst %.2f pm from the double reference; loop width at x = 0: %.1f %% of the range 2R\n",
           worst, 100.0 * fabs(down - up) / (2.0 * R_PM));
    TEST_ASSERT_TRUE(worst <= 0.5 + 1e-9);
    TEST_ASSERT_TRUE(fabs(down - up) > 0.08 * 2.0 * R_PM && fabs(down - up) < 0.3 * 2.0 * R_PM);
    TEST_ASSERT_FALSE(h.sat);
}

/* P^-1[P[x]] over `periods` of x = origin + centre + amp sin; the worst
 * |error| in pm. */
static int32_t round_trip_worst_pm(int32_t centre, int32_t amp, int periods)
{
    int32_t worst = 0;
    int k;
    for (k = 0; k < periods * LOOP_STEPS; k++) {
        const int32_t x = ORIGIN_PM + centre + (int32_t)lround(amp * sin(2.0 * TU_PI * k / LOOP_STEPS));
        const int32_t back = fw_hyst_inverse_pm(&h, fw_hyst_direct_pm(&h, x, NULL), NULL);
        const int32_t e = (back > x) ? back - x : x - back;
        worst = (e > worst) ? e : worst;
    }
    return worst;
}

static void test_inverse_of_direct_returns_x_at_full_range_and_small_amplitude(void)
{
    const fw_hyst_params_t p = lab_params();
    int32_t full, small, offcentre;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    full = round_trip_worst_pm(0, R_PM, 3);
    fw_hyst_reset(&h);
    small = round_trip_worst_pm(0, R_PM / 50, 3);           /* 2 % of the range */
    fw_hyst_reset(&h);
    offcentre = round_trip_worst_pm(R_PM / 2, R_PM / 20, 3);   /* a minor loop away from the origin */
    printf("P^-1[P[x]] - x: worst %ld pm at full range (+-%d pm), %ld pm at 2 %% amplitude, %ld pm in a minor loop "
           "off centre\n", (long)full, R_PM, (long)small, (long)offcentre);
    TEST_ASSERT_INT32_WITHIN(ROUND_TRIP_TOL_PM, 0, full);
    TEST_ASSERT_INT32_WITHIN(ROUND_TRIP_TOL_PM, 0, small);
    TEST_ASSERT_INT32_WITHIN(ROUND_TRIP_TOL_PM, 0, offcentre);
    TEST_ASSERT_FALSE(h.sat);
}

/* A random walk through the range: every kind of minor loop. */
static void test_inverse_of_direct_holds_for_a_random_walk(void)
{
    const fw_hyst_params_t p = lab_params();
    tu_rng_t rng;
    int32_t x = ORIGIN_PM, worst = 0;
    int k;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    tu_rng_seed(&rng, 48);
    for (k = 0; k < AFM_SWEEP_N / 10; k++) {
        int32_t back, e;
        x += tu_rng_range(&rng, -R_PM / 20, R_PM / 20);
        x = (x > ORIGIN_PM + R_PM) ? ORIGIN_PM + R_PM : ((x < ORIGIN_PM - R_PM) ? ORIGIN_PM - R_PM : x);
        back = fw_hyst_inverse_pm(&h, fw_hyst_direct_pm(&h, x, NULL), NULL);
        e = (back > x) ? back - x : x - back;
        worst = (e > worst) ? e : worst;
    }
    printf("P^-1[P[x]] - x: worst %ld pm over a random walk of %d steps\n", (long)worst, AFM_SWEEP_N / 10);
    TEST_ASSERT_INT32_WITHIN(ROUND_TRIP_TOL_PM, 0, worst);
}

static void test_inputs_past_the_range_are_clamped_flagged_and_counted(void)
{
    const fw_hyst_params_t p = lab_params();
    bool sat = false;
    int32_t y_edge, y_past;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    y_edge = fw_hyst_direct_pm(&h, ORIGIN_PM + R_PM, &sat);
    TEST_ASSERT_FALSE(sat);
    TEST_ASSERT_EQUAL_INT32(ORIGIN_PM + h.y_max_pm, y_edge);   /* the edge after a sweep from the origin */
    y_past = fw_hyst_direct_pm(&h, INT32_MAX, &sat);
    TEST_ASSERT_TRUE(sat);
    TEST_ASSERT_EQUAL_INT32(y_edge, y_past);
    TEST_ASSERT_EQUAL_UINT32(1u, h.sat_count);
    /* the inverse: a position past y_max asks for the range's edge, exactly */
    sat = false;
    TEST_ASSERT_EQUAL_INT32(ORIGIN_PM + R_PM, fw_hyst_inverse_pm(&h, INT32_MAX, &sat));
    TEST_ASSERT_TRUE(sat);
    TEST_ASSERT_EQUAL_INT32(ORIGIN_PM - R_PM, fw_hyst_inverse_pm(&h, INT32_MIN, &sat));
    TEST_ASSERT_EQUAL_UINT32(3u, h.sat_count);
    TEST_ASSERT_TRUE(h.sat);
    fw_hyst_reset(&h);
    TEST_ASSERT_FALSE(h.sat);
    TEST_ASSERT_EQUAL_UINT32(0u, h.sat_count);
}

/* n = 1: the play of threshold 0 alone is the identity times w_0. */
static void test_a_single_play_of_threshold_0_is_a_gain_and_its_inverse_exact(void)
{
    fw_hyst_params_t p;
    int32_t x;
    memset(&p, 0, sizeof p);
    p.n = 1;
    p.w_q24[0] = FW_Q24_ONE;
    p.range_pm = R_PM;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    TEST_ASSERT_EQUAL_INT32(FW_Q24_ONE, h.wi_q24[0]);
    TEST_ASSERT_EQUAL_INT32(0, h.ri_pm[0]);
    for (x = -R_PM; x <= R_PM; x += R_PM / 7) {
        TEST_ASSERT_EQUAL_INT32(x, fw_hyst_direct_pm(&h, x, NULL));
        TEST_ASSERT_EQUAL_INT32(x, fw_hyst_inverse_pm(&h, x, NULL));
    }
}

/* A weight 0 is a play that does nothing: the same outputs as the model
 * without it, and the inverse's weight for it is 0 exactly. */
static void test_a_weight_0_play_changes_nothing(void)
{
    fw_hyst_params_t p = lab_params(), q;
    fw_hyst_t g;
    int i, k;
    p.w_q24[1] += p.w_q24[3];
    p.w_q24[3] = 0;
    q = p;
    for (i = 3; i < p.n - 1; i++) {
        q.r_pm[i] = p.r_pm[i + 1];
        q.w_q24[i] = p.w_q24[i + 1];
    }
    q.n = p.n - 1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&g, &q));
    TEST_ASSERT_EQUAL_INT32(0, h.wi_q24[3]);
    for (k = 0; k < 2 * LOOP_STEPS; k++) {
        const int32_t x = ORIGIN_PM + (int32_t)lround(0.9 * R_PM * sin(2.0 * TU_PI * k / LOOP_STEPS) * cos(k / 900.0));
        const int32_t y = fw_hyst_direct_pm(&h, x, NULL);
        TEST_ASSERT_EQUAL_INT32(fw_hyst_direct_pm(&g, x, NULL), y);
        TEST_ASSERT_EQUAL_INT32(fw_hyst_inverse_pm(&g, y, NULL), fw_hyst_inverse_pm(&h, y, NULL));
    }
}

typedef struct {
    int line;
    int field;      /* 0 n, 1 r_pm[at], 2 w_q24[at], 3 range, 4 origin */
    int at;
    int32_t value;
} refusal_row_t;

static void test_init_refuses_absurd_models_naming_the_rule(void)
{
    static const refusal_row_t rows[] = {
        { __LINE__, 0, 0, 0 },                               /* no play */
        { __LINE__, 0, 0, FW_HYST_N_MAX + 1 },               /* more plays than the instance holds */
        { __LINE__, 0, 0, -1 },
        { __LINE__, 1, 0, 1 },                               /* r_0 != 0 */
        { __LINE__, 1, 3, 2500000 },                         /* r_3 = r_2: not increasing */
        { __LINE__, 1, 7, R_PM + 1 },                        /* a threshold past the range */
        { __LINE__, 1, 5, -5 },
        { __LINE__, 2, 0, 0 },                               /* w_0 = 0: no slope after a reversal */
        { __LINE__, 2, 0, -FW_Q24_ONE },
        { __LINE__, 2, 0, FW_HYST_SLOPE_MIN_Q24 - 1 },       /* a branch's slope below 1/2 */
        { __LINE__, 2, 4, -FW_Q24_ONE / 2 },                 /* a partial sum falls below 1/2 */
        { __LINE__, 2, 2, 2 * FW_Q24_ONE },                  /* a partial sum above 2 */
        { __LINE__, 2, 7, INT32_MAX },
        { __LINE__, 3, 0, 0 },                               /* no range */
        { __LINE__, 3, 0, -R_PM },
        { __LINE__, 3, 0, FW_HYST_RANGE_MAX_PM + 1 },
        { __LINE__, 4, 0, FW_HYST_ORIGIN_MAX_PM + 1 },
        { __LINE__, 4, 0, INT32_MIN },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        fw_hyst_params_t p = lab_params();
        const refusal_row_t *row = &rows[i];
        switch (row->field) {
        case 0: p.n = row->value; break;
        case 1: p.r_pm[row->at] = row->value; break;
        case 2: p.w_q24[row->at] = row->value; break;
        case 3: p.range_pm = row->value; break;
        default: p.origin_pm = row->value; break;
        }
        UNITY_TEST_ASSERT_EQUAL_INT(FW_RULE_HYST, fw_hyst_check(&p), row->line, "rule");
        UNITY_TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_hyst_init(&h, &p), row->line, "status");
    }
    TEST_ASSERT_EQUAL_INT(FW_RULE_NULL_POINTER, fw_hyst_check(NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_hyst_init(NULL, NULL));
    {
        fw_hyst_params_t p = lab_params();   /* at the domain's ends: accepted */
        p.range_pm = FW_HYST_RANGE_MAX_PM;
        p.origin_pm = -FW_HYST_ORIGIN_MAX_PM;
        p.r_pm[7] = FW_HYST_RANGE_MAX_PM;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
        /* the edges of the inverse's input give the range's edges, within
         * the inverse's rounding at 2^28 pm (2^-25 of it per weight) */
        TEST_ASSERT_INT32_WITHIN(16, -FW_HYST_ORIGIN_MAX_PM + FW_HYST_RANGE_MAX_PM,
                                 fw_hyst_inverse_pm(&h, INT32_MAX, NULL));
        TEST_ASSERT_INT32_WITHIN(16, -FW_HYST_ORIGIN_MAX_PM - FW_HYST_RANGE_MAX_PM,
                                 fw_hyst_inverse_pm(&h, INT32_MIN, NULL));
    }
}

/* The largest model at the ends of its domain: slopes 2 and 1/2, range
 * 2^28 pm; every step stays within its words (the round trip still holds). */
static void test_the_domains_ends_keep_every_word(void)
{
    fw_hyst_params_t p;
    int i, k;
    int32_t worst = 0;
    memset(&p, 0, sizeof p);
    p.n = FW_HYST_N_MAX;
    p.range_pm = FW_HYST_RANGE_MAX_PM;
    p.origin_pm = FW_HYST_ORIGIN_MAX_PM;
    for (i = 0; i < p.n; i++) {
        p.r_pm[i] = (int32_t)((int64_t)FW_HYST_RANGE_MAX_PM * i / p.n);
        /* slopes alternate between 2 and 1/2 */
        p.w_q24[i] = (i == 0) ? FW_HYST_SLOPE_MAX_Q24
                               : ((i % 2 == 1) ? FW_HYST_SLOPE_MIN_Q24 - FW_HYST_SLOPE_MAX_Q24
                                               : FW_HYST_SLOPE_MAX_Q24 - FW_HYST_SLOPE_MIN_Q24);
    }
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    for (k = 0; k < 3 * LOOP_STEPS; k++) {
        const int32_t x = p.origin_pm + (int32_t)lround(FW_HYST_RANGE_MAX_PM * sin(2.0 * TU_PI * k / LOOP_STEPS));
        const int32_t y = fw_hyst_direct_pm(&h, x, NULL);
        const int32_t back = fw_hyst_inverse_pm(&h, y, NULL);
        const int32_t e = (back > x) ? back - x : x - back;
        TEST_ASSERT_TRUE((int64_t)y - p.origin_pm <= h.y_max_pm + 1 && (int64_t)p.origin_pm - y <= h.y_max_pm + 1);
        worst = (e > worst) ? e : worst;
    }
    printf("at the domain's ends (range 2^28 pm, slopes 2 and 1/2, 16 plays): worst round trip %ld pm\n", (long)worst);
    TEST_ASSERT_INT32_WITHIN(64, 0, worst);
}

static void test_cost_on_the_board(void)
{
    fw_hyst_params_t p = lab_params();
    uint32_t t;
    uint32_t acc = 0u;   /* wraps by definition: only keeps the calls */
    int k;
    cost_start_timer();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    t = cost_ticks();
    for (k = 0; k < 1000; k++) {
        acc += (uint32_t)fw_hyst_inverse_pm(&h, ORIGIN_PM + k * 7919, NULL);
    }
    cost_print("fw_hyst_inverse_pm, 8 plays", t - cost_ticks(), 1000u);
    p.n = FW_HYST_N_MAX;
    for (k = 8; k < p.n; k++) {
        p.r_pm[k] = p.r_pm[7] + (k - 7) * 1000;
        p.w_q24[k] = 0;
    }
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    t = cost_ticks();
    for (k = 0; k < 1000; k++) {
        acc += (uint32_t)fw_hyst_inverse_pm(&h, ORIGIN_PM + k * 7919, NULL);
    }
    cost_print("fw_hyst_inverse_pm, 16 plays", t - cost_ticks(), 1000u);
    t = cost_ticks();
    for (k = 0; k < 1000; k++) {   /* the card's apex, each sample and axis (fw_card.c, card_scanner_apex) */
        acc += (uint32_t)fw_hyst_direct_pm(&h, ORIGIN_PM + k * 7919, NULL);
    }
    cost_print("fw_hyst_direct_pm, 16 plays", t - cost_ticks(), 1000u);
    t = cost_ticks();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_hyst_init(&h, &p));
    cost_print("fw_hyst_init, 16 plays", t - cost_ticks(), 1u);
    TEST_ASSERT_TRUE(acc != 1);   /* keeps the calls */
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_init_forms_kuhnens_inverse_within_one_lsb);
    RUN_TEST(test_direct_model_follows_the_double_reference_and_its_loop_is_about_10_percent_wide);
    RUN_TEST(test_inverse_of_direct_returns_x_at_full_range_and_small_amplitude);
    RUN_TEST(test_inverse_of_direct_holds_for_a_random_walk);
    RUN_TEST(test_inputs_past_the_range_are_clamped_flagged_and_counted);
    RUN_TEST(test_a_single_play_of_threshold_0_is_a_gain_and_its_inverse_exact);
    RUN_TEST(test_a_weight_0_play_changes_nothing);
    RUN_TEST(test_init_refuses_absurd_models_naming_the_rule);
    RUN_TEST(test_the_domains_ends_keep_every_word);
    RUN_TEST(test_cost_on_the_board);
    return UNITY_END();
}
