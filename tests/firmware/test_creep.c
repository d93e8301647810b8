/* test_creep.c - fw_creep: the feed-forward of a log-law creep, its
 * constants formed at init, a step's creep cancelled over 3 decades,
 * saturation at long times, and the model followed (the de-warp's) against
 * the feed-forward and the law. References in C's double precision. */
#include <math.h>
#include <string.h>
#include "unity.h"
#include "fw_creep.h"
#include "test_util.h"
#include "cost_util.h"

#define STEP_PM 10000000   /* a 10 um step */
/* Over [t0, 10^3 t0] after the step the compensated position stays within
 * this fraction of gamma D (the terms' fit is within 0.021, fw_creep.h; the
 * period's discretisation and the small steps' own creep add the rest). */
#define CANCEL_TOL_GAMMA 0.03
/* Before t0, where the law is flat: the fit's 0.23 and the same margin. */
#define EARLY_TOL_GAMMA 0.24

static fw_creep_t c;

void setUp(void) {}
void tearDown(void) {}

static double law(double t, double t0)
{
    return (t >= t0) ? log10(t / t0) : 0.0;
}

static void test_init_forms_the_terms_as_the_double_formulas(void)
{
    static const double cc[FW_CREEP_TERMS] = { -0.3407586, 1.03125433, 1.039514, 1.34550801 };
    static const double rho[FW_CREEP_TERMS] = { 0.0857847915, 2.66674108, 28.7394886, 379.255674 };
    const fw_creep_params_t p = { 15000, 100000, 1000 };
    int k;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p));
    for (k = 0; k < FW_CREEP_TERMS; k++) {
        const double alpha = 1.0 - exp(-1000.0 / (100000.0 * rho[k]));
        /* rho_k is kept in 16.16 (relative 2^-17 / rho_k), the series to a few 2^-31 */
        TEST_ASSERT_DOUBLE_WITHIN(alpha * TU_TWO_POW(31) * 1e-4 + 8.0, alpha * TU_TWO_POW(31), (double)c.alpha_q31[k]);
        TEST_ASSERT_DOUBLE_WITHIN(2.0, 0.015 * cc[k] * TU_TWO_POW(31), (double)c.a_q31[k]);
    }
}

/* The plant of fw_creep.h's law: y(t) = u(t) + gamma sum_j D_j L(t - t_j),
 * D_j the command's steps, at the start of period n (u_n just applied). */
static double plant_pm(const int32_t *u, int n, double gamma, double t0, double period)
{
    double y = u[n];
    int j;
    for (j = 1; j <= n; j++) {
        if (u[j] != u[j - 1]) {
            y += gamma * (u[j] - u[j - 1]) * law((n - j) * period, t0);
        }
    }
    return y;
}

typedef struct {
    int line;
    int32_t gamma_ppm;
    int32_t t0_us;
    int32_t period_us;
} creep_case_t;

/* A step from rest, pre-shaped; the plant's position checked at points
 * spread over 3 decades. u holds the commands (length n_max). */
static void check_step_cancelled(const creep_case_t *cs, int32_t *u, int n_max)
{
    const fw_creep_params_t p = { cs->gamma_ppm, cs->t0_us, cs->period_us };
    const double gamma = cs->gamma_ppm * 1e-6, t0 = cs->t0_us, T = cs->period_us;
    const int n = (int)(1000.0 * t0 / T) + 2;
    double worst = 0.0, worst_early = 0.0, raw = 0.0;
    int i, m;
    TEST_ASSERT_TRUE(n <= n_max);
    UNITY_TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p), cs->line, "init");
    u[0] = fw_creep_step_pm(&c, 0, NULL);   /* rest */
    UNITY_TEST_ASSERT_EQUAL_INT32(0, u[0], cs->line, "rest");
    for (i = 1; i < n; i++) {
        u[i] = fw_creep_step_pm(&c, STEP_PM, NULL);
    }
    /* 40 points a decade from T to 10^3 t0 after the step (made at period 1) */
    for (m = 0; ; m++) {
        const double t = T * pow(10.0, m / 40.0);
        const int k = 1 + (int)lround(t / T);
        double e;
        if (k >= n) {
            break;
        }
        e = fabs(plant_pm(u, k, gamma, t0, T) - STEP_PM) / (gamma * STEP_PM);
        if ((k - 1) * T >= t0) {
            worst = fmax(worst, e);
        } else {
            worst_early = fmax(worst_early, e);
        }
    }
    raw = law(1000.0 * t0, t0) * gamma * STEP_PM;
    printf("creep, gamma %.1f %%/decade, t0 %.0f ms, period %.2f ms: residual over [t0, 1e3 t0] %.4f gamma D "
           "(%.2f nm of a %d nm step; uncompensated %.0f nm at 1e3 t0), before t0 %.3f gamma D\n",
           gamma * 100.0, t0 / 1000.0, T / 1000.0, worst, worst * gamma * STEP_PM / 1000.0, STEP_PM / 1000,
           raw / 1000.0, worst_early);
    UNITY_TEST_ASSERT(worst <= CANCEL_TOL_GAMMA, cs->line, "residual over 3 decades");
    UNITY_TEST_ASSERT(worst_early <= EARLY_TOL_GAMMA, cs->line, "residual before t0");
    UNITY_TEST_ASSERT(!c.sat, cs->line, "no clamp");
}

static void test_the_feed_forward_of_a_step_cancels_a_log_creep_over_3_decades(void)
{
    static const creep_case_t cases[] = {
        { __LINE__, 15000, 100000, 6250 },     /* the lab's 1.5 %/decade, the coarsest period allowed */
        { __LINE__, 100000, 16000, 1000 },     /* the largest gamma */
#if !defined(__arm__)
        { __LINE__, 15000, 100000, 1000 },     /* the card's 1 ms block (10^5 periods: the host only) */
#endif
    };
    static int32_t u[102000];
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        check_step_cancelled(&cases[i], u, (int)(sizeof u / sizeof u[0]));
    }
}

static void test_gamma_0_passes_the_command_unchanged(void)
{
    const fw_creep_params_t p = { 0, 100000, 1000 };
    tu_rng_t rng;
    int k;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p));
    tu_rng_seed(&rng, 7);
    for (k = 0; k < 10000; k++) {
        const int32_t r = (int32_t)tu_rng_u32(&rng);
        TEST_ASSERT_EQUAL_INT32(r, fw_creep_step_pm(&c, r, NULL));
    }
}

/* Long times at the ends of every word: the first command INT32_MIN, then
 * INT32_MAX held for 2^21 periods (35 min at 1 ms, 10^4.3 t0): the
 * deviation is clamped to 2^30 pm, the command saturates while the fast
 * term's negative weight pushes it up, and nothing wraps: every command
 * stays at the top of int32, and the states converge to the clamped
 * deviation. */
static void test_long_times_saturate_and_never_wrap(void)
{
    const fw_creep_params_t p = { FW_CREEP_GAMMA_MAX_PPM, 100000, 1000 };
    const int32_t n = (int32_t)1 << 21;
    int64_t sum_a = 0;
    int32_t out = 0, lowest = INT32_MAX;
    bool sat = false;
    int32_t k;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p));
    TEST_ASSERT_EQUAL_INT32(INT32_MIN, fw_creep_step_pm(&c, INT32_MIN, &sat));
    TEST_ASSERT_FALSE(sat);
    for (k = 0; k < n; k++) {
        out = fw_creep_step_pm(&c, INT32_MAX, &sat);
        lowest = (out < lowest) ? out : lowest;
    }
    for (k = 0; k < FW_CREEP_TERMS; k++) {
        sum_a += c.a_q31[k];
        /* converged to within 1 pm (a state stops where its step rounds to 0) */
        TEST_ASSERT_TRUE(c.e_q16[k] <= (int64_t)FW_CREEP_DEV_MAX_PM * 65536
                         && c.e_q16[k] >= ((int64_t)FW_CREEP_DEV_MAX_PM - 1) * 65536);
    }
    TEST_ASSERT_TRUE(sat);
    TEST_ASSERT_TRUE(c.sat);
    TEST_ASSERT_EQUAL_UINT32((uint32_t)n, c.sat_count);   /* every period's deviation was clamped */
    /* the settled command: r - sum_k a_k 2^30, within the sums' rounding */
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)(INT32_MAX - ((sum_a + 1) >> 1)), out);
    TEST_ASSERT_TRUE(lowest >= INT32_MAX - (int32_t)(sum_a / 2) - 2);
    printf("long times: settled at INT32_MAX - %ld pm after 2^21 periods; the lowest command INT32_MAX - %ld\n",
           (long)(INT32_MAX - out), (long)(INT32_MAX - lowest));
}

static void test_the_first_command_is_the_rest_and_reset_forgets_it(void)
{
    const fw_creep_params_t p = { 15000, 100000, 1000 };
    int32_t a, b;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p));
    TEST_ASSERT_EQUAL_INT32(5000000, fw_creep_step_pm(&c, 5000000, NULL));
    TEST_ASSERT_EQUAL_INT32(5000000, fw_creep_step_pm(&c, 5000000, NULL));   /* no creep owed at rest */
    a = fw_creep_step_pm(&c, 6000000, NULL);
    b = fw_creep_step_pm(&c, 6000000, NULL);
    TEST_ASSERT_EQUAL_INT32(6000000, a);   /* the step itself: no state has moved yet */
    TEST_ASSERT_TRUE(b != 6000000);        /* then the pre-shaping starts */
    fw_creep_reset(&c);
    TEST_ASSERT_EQUAL_INT32(-7, fw_creep_step_pm(&c, -7, NULL));
    TEST_ASSERT_EQUAL_INT32(-7, fw_creep_step_pm(&c, -7, NULL));
}

/* The model followed (fw_creep_follow_pm) and the feed-forward agree:
 * the feed-forward's command for r is r less the creep the followed model
 * gives for that command, and both leave the same states, over random
 * commands and at the words' ends. */
static void test_follow_is_the_model_the_feed_forward_inverts(void)
{
    const fw_creep_params_t p = { 15000, 100000, 1000 };
    fw_creep_t f;
    tu_rng_t rng;
    int k, i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&f, &p));
    tu_rng_seed(&rng, 11);
    for (k = 0; k < 20000; k++) {
        const int32_t r = (k % 500 < 3) ? ((k % 2) ? INT32_MAX : INT32_MIN) : (int32_t)(tu_rng_u32(&rng) % 20000001u) - 10000000;
        const int32_t u = fw_creep_step_pm(&c, r, NULL);
        const int32_t off = fw_creep_follow_pm(&f, u, NULL);
        if ((int64_t)r - off != u) {   /* only where the command saturated */
            TEST_ASSERT_TRUE(u == INT32_MAX || u == INT32_MIN);
        }
        for (i = 0; i < FW_CREEP_TERMS; i++) {
            TEST_ASSERT_TRUE(c.e_q16[i] == f.e_q16[i]);
        }
        TEST_ASSERT_EQUAL_INT32(c.first_pm, f.first_pm);
    }
}

/* A step of D followed: the model's creep at t0 10^k after it is gamma D k
 * within the terms' fit (0.021 gamma D) and the period's discretisation. */
static void test_a_followed_step_creeps_by_the_log_law(void)
{
    const fw_creep_params_t p = { 15000, 100000, 6250 };   /* the coarsest period: 16 a t0 */
    int32_t off = 0;
    int32_t n, next = 16, k = 0;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p));
    TEST_ASSERT_EQUAL_INT32(0, fw_creep_follow_pm(&c, 0, NULL));   /* the rest */
    for (n = 1; n <= 16001; n++) {
        off = fw_creep_follow_pm(&c, STEP_PM, NULL);
        if (n == next + 1) {   /* the step came at period 1 */
            const double want = 0.015 * STEP_PM * k;
            printf("creep followed: %.1f s after a %d nm step: %.2f nm (law %.2f nm)\n", next * 6.25e-3, STEP_PM / 1000,
                   off / 1000.0, want / 1000.0);
            TEST_ASSERT_DOUBLE_WITHIN(CANCEL_TOL_GAMMA * 0.015 * STEP_PM, want, (double)off);
            next *= 10;
            k++;
        }
    }
    TEST_ASSERT_EQUAL_INT(4, k);
}

typedef struct {
    int line;
    int32_t gamma_ppm;
    int32_t t0_us;
    int32_t period_us;
} creep_refusal_t;

static void test_init_refuses_absurd_laws_naming_the_rule(void)
{
    static const creep_refusal_t rows[] = {
        { __LINE__, -1, 100000, 1000 },
        { __LINE__, FW_CREEP_GAMMA_MAX_PPM + 1, 100000, 1000 },
        { __LINE__, INT32_MIN, 100000, 1000 },
        { __LINE__, 15000, FW_CREEP_T0_MIN_US - 1, 10 },
        { __LINE__, 15000, FW_CREEP_T0_MAX_US + 1, 1000 },
        { __LINE__, 15000, 0, 0 },
        { __LINE__, 15000, 100000, 0 },
        { __LINE__, 15000, 100000, -1000 },
        { __LINE__, 15000, 100000, 6251 },     /* period > t0 / 16 */
        { __LINE__, 15000, 100000, INT32_MAX },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        const fw_creep_params_t p = { rows[i].gamma_ppm, rows[i].t0_us, rows[i].period_us };
        UNITY_TEST_ASSERT_EQUAL_INT(FW_RULE_CREEP, fw_creep_check(&p), rows[i].line, "rule");
        UNITY_TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_creep_init(&c, &p), rows[i].line, "status");
    }
    TEST_ASSERT_EQUAL_INT(FW_RULE_NULL_POINTER, fw_creep_check(NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_creep_init(NULL, NULL));
    {
        const fw_creep_params_t ends[] = { { 0, FW_CREEP_T0_MIN_US, 1 }, { FW_CREEP_GAMMA_MAX_PPM, FW_CREEP_T0_MAX_US,
                                                                          FW_CREEP_T0_MAX_US / 16 } };
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &ends[0]));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &ends[1]));
    }
}

static void test_cost_on_the_board(void)
{
    const fw_creep_params_t p = { 15000, 100000, 1000 };
    uint32_t acc = 0u;   /* wraps by definition: only keeps the calls */
    uint32_t t;
    int k;
    cost_start_timer();
    t = cost_ticks();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_creep_init(&c, &p));
    cost_print("fw_creep_init", t - cost_ticks(), 1u);
    t = cost_ticks();
    for (k = 0; k < 1000; k++) {
        acc += (uint32_t)fw_creep_step_pm(&c, k * 7919, NULL);
    }
    cost_print("fw_creep_step_pm", t - cost_ticks(), 1000u);
    t = cost_ticks();
    for (k = 0; k < 1000; k++) {
        acc += (uint32_t)fw_creep_follow_pm(&c, k * 7919, NULL);
    }
    cost_print("fw_creep_follow_pm", t - cost_ticks(), 1000u);
    TEST_ASSERT_TRUE(acc != 1);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_init_forms_the_terms_as_the_double_formulas);
    RUN_TEST(test_the_feed_forward_of_a_step_cancels_a_log_creep_over_3_decades);
    RUN_TEST(test_gamma_0_passes_the_command_unchanged);
    RUN_TEST(test_long_times_saturate_and_never_wrap);
    RUN_TEST(test_the_first_command_is_the_rest_and_reset_forgets_it);
    RUN_TEST(test_follow_is_the_model_the_feed_forward_inverts);
    RUN_TEST(test_a_followed_step_creeps_by_the_log_law);
    RUN_TEST(test_init_refuses_absurd_laws_naming_the_rule);
    RUN_TEST(test_cost_on_the_board);
    return UNITY_END();
}
