/* test_wire_trench.c - fw_wire and trenches: the hold across a trench's
 * wall, which pieces of a rod a trench holds (fw_wire_hold), the static
 * point with held pieces (fw_wire_static_point_held) against a
 * double-precision solution of the same torque balance, and the push rule
 * of a held rod. A rod settling into a groove: test_wire_settle.c. */
#include "unity.h"
#include "fw_wire.h"
#include "fw_math.h"
#include "test_util.h"
#include "trench_util.h"

#define N_PIECES FW_WIRE_PIECES

void setUp(void) {}
void tearDown(void) {}

/* ---- the double-precision reference -------------------------------------- */

static double ref_weight(uint32_t held, double hold, int k)
{
    return ((held >> k) & 1u) ? hold : 1.0;
}

/* G(s) = sum_k w_k int_piece sign(x - s)(x - l) dx, rod of length 1. */
static double ref_torque(uint32_t held, double hold, double l, double s)
{
    double g = 0.0;
    int k;
    for (k = 0; k < N_PIECES; k++) {
        double a = (double)k / N_PIECES, b = (double)(k + 1) / N_PIECES, w = ref_weight(held, hold, k);
        double lo = s < a ? a : (s > b ? b : s);
        /* int_lo^b (x - l) - int_a^lo (x - l) */
        g += w * (0.5 * ((b - l) * (b - l) - (lo - l) * (lo - l)) - 0.5 * ((lo - l) * (lo - l) - (a - l) * (a - l)));
    }
    return g;
}

/* The root of G on the side where it changes sign, and k = |net| / (f L). */
static void ref_static(uint32_t held, double hold, double l, double *s_out, double *k_out)
{
    double g0 = ref_torque(held, hold, l, 0.0);
    int below = g0 < 0;
    double lo = below ? 0.0 : l, hi = below ? l : 1.0, net = 0.0;
    int i, k;
    for (i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if ((ref_torque(held, hold, l, mid) < 0) == below) lo = mid; else hi = mid;
    }
    *s_out = 0.5 * (lo + hi);
    for (k = 0; k < N_PIECES; k++) {
        double a = (double)k / N_PIECES, b = (double)(k + 1) / N_PIECES;
        double c = *s_out < a ? a : (*s_out > b ? b : *s_out);
        net += ref_weight(held, hold, k) * ((b - c) - (c - a));
    }
    *k_out = fabs(net);
}

/* The simulator's hold (World::trench_hold) in double. */
static double ref_hold(double gamma_deg, double mu)
{
    double tg = tan(gamma_deg * TU_PI / 180.0);
    double theta = TU_PI / 2 - atan(tg), beta = atan(mu);
    double h = theta + beta < TU_PI / 2 - 1e-3 ? tan(theta + beta) / tan(beta) : 1000.0;
    return h < 1000.0 ? h : 1000.0;
}

/* ---- the hold ----------------------------------------------------------- */

static void test_trench_hold_matches_the_simulators_formula(void)
{
    static const struct { int32_t gamma_mdeg, mu_ppm; } cases[] = {
        { 20000, 300000 }, { 20000, 100000 }, { 35000, 500000 }, { 10000, 50000 }, { 59000, 1500000 },
    };
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        fw_wire_tip_t tip;
        double ref = ref_hold(cases[i].gamma_mdeg / 1000.0, cases[i].mu_ppm / 1e6);
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(&tip, 10000, cases[i].gamma_mdeg, 20000, cases[i].mu_ppm, 0));
        TEST_ASSERT_DOUBLE_WITHIN(1e-4 * ref + 1e-4, ref, tu_q(tip.hold_q16, 16));
    }
}

static void test_trench_hold_caps_at_1000_when_the_wall_is_too_steep(void)
{
    fw_wire_tip_t tip;
    /* mu = 0: tan(beta) = 0, the hold is unbounded: capped */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(&tip, 10000, 20000, 20000, 0, 0));
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_HOLD_MAX_Q16, tip.hold_q16);
    /* beta = atan(1) = 45 deg >= gamma = 30 deg: theta + beta >= 90 deg */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(&tip, 10000, 30000, 20000, 1000000, 0));
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_HOLD_MAX_Q16, tip.hold_q16);
    /* gamma just above beta (within 1 mrad): capped; 2 mrad above: large,
     * not capped, as the simulator has it */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(&tip, 10000, 45050, 20000, 1000000, 0));
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_HOLD_MAX_Q16, tip.hold_q16);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(&tip, 10000, 46000, 20000, 1000000, 0));
    TEST_ASSERT_DOUBLE_WITHIN(0.1, ref_hold(46.0, 1.0), tu_q(tip.hold_q16, 16));
    TEST_ASSERT_TRUE(tip.hold_q16 < FW_WIRE_HOLD_MAX_Q16);
}

/* ---- the static point with held pieces ----------------------------------- */

static void test_trench_static_no_held_piece_is_the_closed_form(void)
{
    int32_t l;
    for (l = 0; l <= L_PM; l += L_PM / 13) {
        fw_wire_static_t a, b;
        int i;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point(L_PM, l, &a));
        for (i = 0; i < 2; i++) {
            /* field by field: the struct's padding is not compared */
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, l, i == 0 ? 0u : 0xffffffffu,
                                                                   i == 0 ? 50 << 16 : FW_WIRE_HOLD_ONE_Q16, &b));
            TEST_ASSERT_EQUAL_INT(a.regime, b.regime);
            TEST_ASSERT_EQUAL(a.s_defined, b.s_defined);
            TEST_ASSERT_EQUAL_INT32(a.s_pm, b.s_pm);
            TEST_ASSERT_EQUAL_INT32(a.k, b.k);
            TEST_ASSERT_EQUAL_INT32(a.k_q16, b.k_q16);
            TEST_ASSERT_EQUAL_INT32(a.u, b.u);
            TEST_ASSERT_EQUAL_INT32(a.lever_pm, b.lever_pm);
        }
        TEST_ASSERT_INT32_WITHIN(1, (int32_t)(a.k >> 14), a.k_q16);
    }
}

static void test_trench_static_all_held_is_the_uniform_rod_times_the_hold(void)
{
    /* a rod held along its whole length has the uniform rod's static point
     * and needs hold times its push */
    const int32_t hold = 58 << 16;
    int32_t l;
    for (l = 0; l <= L_PM; l += L_PM / 10) {
        fw_wire_static_t u, h;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point(L_PM, l, &u));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, l, 0xffffffffu, hold, &h));
        TEST_ASSERT_EQUAL_INT(u.regime, h.regime);
        if (u.s_defined) TEST_ASSERT_INT32_WITHIN(L_PM / 65536 + 2, u.s_pm, h.s_pm);
        TEST_ASSERT_DOUBLE_WITHIN(58.0 * 1e-4, 58.0 * tu_q(u.k, 30), tu_q(h.k_q16, 16));
        TEST_ASSERT_EQUAL_INT32(FW_Q30_ONE, h.k);
    }
}

static void test_trench_static_matches_double_over_masks_and_pushes(void)
{
    /* random masks (one end held, the other, a middle stretch, scattered),
     * holds from 1.5 to 1000, pushes anywhere: s within 2 / 65536 of L; k
     * within 10^-4 of it plus 4 w(s) / 65536 (k's slope in s is 2 w(s),
     * the density at the static point: large when S lies in a held piece) */
    /* 4000 cases on the host; on the emulated Cortex-M4, whose double
     * references run in software, the first 400 of the same sequence */
    const int cases = AFM_SWEEP_N / 50 < 4000 ? AFM_SWEEP_N / 50 : 4000;
    tu_rng_t rng;
    tu_err_t es, ek;
    int i;
    tu_rng_seed(&rng, 1813);
    tu_err_init(&es, "held static point s", "pm", 1.0);
    tu_err_init(&ek, "held k", "relative", 1.0);
    for (i = 0; i < cases; i++) {
        uint32_t held;
        int kind = i % 4;
        int n = tu_rng_range(&rng, 1, 16);
        int32_t hold = tu_rng_range(&rng, 3 << 15, FW_WIRE_HOLD_MAX_Q16);
        int32_t l = tu_rng_range(&rng, 0, L_PM);
        double s_ref, k_ref;
        fw_wire_static_t st;
        if (kind == 0) held = (1u << n) - 1u;                         /* end A */
        else if (kind == 1) held = ~((1u << (N_PIECES - n)) - 1u);    /* end B */
        else if (kind == 2) held = ((1u << n) - 1u) << 8;             /* a stretch */
        else held = tu_rng_u32(&rng);
        if (held == 0u) held = 1u;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, l, held, hold, &st));
        if (!st.s_defined) continue;
        /* the firmware solves for l rounded to L / 65536: where the density
         * at S is small against the net friction, s moves by net / (2 w(s)
         * |s - l|) per unit of l, so the reference takes the same l */
        ref_static(held, tu_q(hold, 16), floor((double)l * 65536.0 / L_PM + 0.5) / 65536.0, &s_ref, &k_ref);
        tu_err_add(&es, (double)st.s_pm - s_ref * L_PM);
        tu_err_add(&ek, tu_q(st.k_q16, 16) / k_ref - 1.0);
        TEST_ASSERT_DOUBLE_WITHIN(2.0 * L_PM / 65536 + 1, s_ref * L_PM, (double)st.s_pm);
        /* the blend's u: a uniform rod's with S as far from its nearest end */
        {
            double dend = fmin(s_ref, 1.0 - s_ref), m = 1.0 - 2.0 * dend, v = fmin(1.0, 0.5 * (1.0 / m - m));
            TEST_ASSERT_DOUBLE_WITHIN(1e-3 * v + 1e-4, v, fabs(tu_q(st.u, 30)));
        }
        {
            int piece = (int)(s_ref * N_PIECES);
            double ws = ref_weight(held, tu_q(hold, 16), piece < N_PIECES ? piece : N_PIECES - 1);
            TEST_ASSERT_DOUBLE_WITHIN(1e-4 * k_ref + 4.0 * ws / 65536, k_ref, tu_q(st.k_q16, 16));
        }
    }
    tu_err_print(&es);
    tu_err_print(&ek);
}

static void test_trench_static_held_end_is_the_pivot(void)
{
    /* the first 4 of 32 pieces (end A) in a trench, hold 58: a push near B
     * turns the rod about the held end (s inside the held eighth) */
    fw_wire_static_t st;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, L_PM - L_PM / 10, 0xfu, 58 << 16, &st));
    TEST_ASSERT_EQUAL_INT(FW_WIRE_ROTATE_NEAR_A, st.regime);
    TEST_ASSERT_TRUE(st.s_pm > 0 && st.s_pm < L_PM / 8);
}

static void test_trench_static_symmetric_hold_bifurcates_at_the_middle(void)
{
    /* both end pieces held: G(0) = 0 at l = L/2 exactly (translation); one
     * LSB either side rotates */
    const uint32_t ends = 1u | (1u << (N_PIECES - 1));
    fw_wire_static_t st;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, L_PM / 2, ends, 58 << 16, &st));
    TEST_ASSERT_EQUAL_INT(FW_WIRE_TRANSLATE, st.regime);
    TEST_ASSERT_FALSE(st.s_defined);
    TEST_ASSERT_EQUAL_INT32(0, st.u);
    TEST_ASSERT_EQUAL_INT32(L_PM / 16, st.lever_pm);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, L_PM / 2 - 20, ends, 58 << 16, &st));
    TEST_ASSERT_EQUAL_INT(FW_WIRE_ROTATE_NEAR_B, st.regime);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, L_PM / 2 + 20, ends, 58 << 16, &st));
    TEST_ASSERT_EQUAL_INT(FW_WIRE_ROTATE_NEAR_A, st.regime);
}

static void test_trench_static_refuses_bad_arguments(void)
{
    fw_wire_static_t st;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_static_point_held(L_PM, 0, 1u, FW_WIRE_HOLD_ONE_Q16 - 1, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_static_point_held(L_PM, 0, 1u, FW_WIRE_HOLD_MAX_Q16 + 1, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_static_point_held(0, 0, 1u, 2 << 16, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_static_point_held(L_PM, 0, 1u, 2 << 16, NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_static_point_held(L_PM, -1, 1u, 2 << 16, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_static_point_held(L_PM, L_PM + 1, 1u, 2 << 16, &st));
    /* the longest rod, the largest hold: no overflow (UBSan build) */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(FW_WIRE_LENGTH_MAX_PM, 7, 0x0f0f0f0fu,
                                                           FW_WIRE_HOLD_MAX_Q16, &st));
    TEST_ASSERT_TRUE(st.k_q16 <= FW_WIRE_HOLD_MAX_Q16);
}

/* ---- which pieces a trench holds ----------------------------------------- */

static void test_trench_holds_a_rod_lying_in_it(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0xffffffffu, w.held);
    TEST_ASSERT_EQUAL_INT32(tip.hold_q16, w.hold_q16);
    /* axis 70 nm off the path: slack (240 - 100) / 2 = 70: still held; 71 not */
    w.y_pm = 70000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0xffffffffu, w.held);
    w.y_pm = 71000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
    w.y_pm = -71000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
}

static void test_trench_narrower_than_the_rod_holds_nothing(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, -1400000, 1400000, 0, D_PM - 1);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
    /* exactly as wide as the rod: held on the path only */
    n = straight_trench(p, 200, -1400000, 1400000, 0, D_PM);
    w.hold_points = -1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0xffffffffu, w.held);
}

static void test_trench_under_half_the_rod_holds_that_half(void)
{
    /* the trench ends under the rod's middle: the pieces of end B (x > 0)
     * and those whose midpoints lie within the slack, 70 nm, of its end
     * (pieces 15 and 14, 20.3 and 60.9 nm before it; the trench's end is
     * round, as the simulator has it) */
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, 0, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0xffffc000u, w.held);
}

static void test_trench_a_rod_across_it_is_held_where_it_crosses(void)
{
    /* a trench along y through x = 0: only the middle pieces' midpoints lie
     * within the slack of 70 nm of it (pieces 15, 16 at 20.3 nm, 14, 17 at
     * 60.9 nm; 13 and 18 at 101.6 nm are not) */
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t i, n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    for (i = 0; i < n; i++) {
        p[i].y_pm = p[i].x_pm;
        p[i].x_pm = 0;
    }
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0xfu << 14, w.held);
}

static void test_trench_strokes_are_not_joined(void)
{
    /* two strokes, one left of the rod and one right: no segment spans the
     * gap between them, so the rod (between) is not held */
    static fw_trench_point_t p[4];
    fw_wire_t w;
    fw_wire_tip_t tip;
    rod_and_tip(&w, &tip);
    p[0] = (fw_trench_point_t){ -3000000, 0, 500000, 240000, FW_LITHO_STROKE_START };
    p[1] = (fw_trench_point_t){ -2000000, 0, 500000, 240000, 0u };
    p[2] = (fw_trench_point_t){ 2000000, 0, 500000, 240000, FW_LITHO_STROKE_START };
    p[3] = (fw_trench_point_t){ 3000000, 0, 500000, 240000, 0u };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, 4));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
    /* joined, the same points hold it */
    p[2].flags = 0u;
    w.hold_points = -1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, 4));
    TEST_ASSERT_EQUAL_HEX32(0xffffffffu, w.held);
}

static void test_trench_hold_empty_far_and_null_inputs(void)
{
    static fw_trench_point_t p[3];
    fw_wire_t w;
    fw_wire_tip_t tip;
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_hold(NULL, &tip, p, 0));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_hold(&w, NULL, p, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, NULL, 5));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
    w.held = 0x5u;
    w.hold_points = -1;   /* forget the cache: computed anew for n = -3 (taken as 0) */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, -3));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
    /* one point is no segment */
    p[0] = (fw_trench_point_t){ 0, 0, 500000, 240000, FW_LITHO_STROKE_START };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, 1));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
    /* a segment from one corner of the int32 plane to the other, a rod at
     * the far corner, a zero-length segment, the widest width: skipped or
     * judged without overflow (the UBSan build) */
    p[0] = (fw_trench_point_t){ INT32_MIN, INT32_MIN, INT32_MAX, INT32_MAX, FW_LITHO_STROKE_START };
    p[1] = (fw_trench_point_t){ INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX, 0u };
    p[2] = (fw_trench_point_t){ INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX, 0u };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, 3));
    TEST_ASSERT_EQUAL_HEX32(0u, w.held);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, INT32_MAX - L_PM, INT32_MAX - 1000, 0u, L_PM, D_PM));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, 3));
    /* the zero-length segment at the corner is 2^31 pm wide: it holds the
     * whole rod (1.3 um away); the corner-to-corner one is skipped */
    TEST_ASSERT_EQUAL_HEX32(0xffffffffu, w.held);
}

static void test_trench_hold_is_cached_until_the_rod_or_the_trench_changes(void)
{
    static fw_trench_point_t p[200];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0xffffffffu, w.held);
    /* the same pose and count: not recomputed (a changed point goes unseen) */
    p[5].width_pm = 0;
    w.held = 0x5u;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0x5u, w.held);
    /* a new point: recomputed */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n - 1));
    TEST_ASSERT_TRUE(w.held != 0x5u);
    /* the rod moved: recomputed */
    w.held = 0x5u;
    w.y_pm += 1;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n - 1));
    TEST_ASSERT_TRUE(w.held != 0x5u);
}

/* ---- the push rule of a held rod ----------------------------------------- */

static void test_trench_rule_a_held_rod_needs_hold_times_the_push(void)
{
    /* in the trench along its length: k f L = 26000 pN becomes hold x that;
     * the whole of it decides (not half, as for a free rod), one pN either
     * side */
    static fw_trench_point_t p[200];
    const int32_t apex[3] = { 0, -50000, 0 };
    fw_wire_t w;
    fw_wire_tip_t tip;
    fw_wire_static_t st;
    int64_t whole;
    int32_t n = straight_trench(p, 200, -1400000, 1400000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(L_PM, L_PM / 2, w.held, w.hold_q16, &st));
    whole = ((int64_t)st.k_q16 * 26000 + (1 << 15)) >> 16;
    TEST_ASSERT_DOUBLE_WITHIN(0.01 * whole, 26000 * ref_hold(20.0, 0.3), (double)whole);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, whole, 0, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & FW_WIRE_PUSHED);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, whole / 2 + 1, 0, INT32_MAX));   /* the midpoint: stuck */
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & FW_WIRE_PUSHED);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, 13001, 0, INT32_MAX));   /* a free rod's trigger */
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & FW_WIRE_PUSHED);
    TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, whole + 1, 0, INT32_MAX));
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_PUSHED) != 0u);
}

static void test_trench_rule_a_rod_held_at_one_end_turns_about_it(void)
{
    /* end A in a trench along the rod ending at x = -560 nm: the midpoints
     * of pieces 0-3 (the last at -507.8 nm) lie within the slack of 70 nm,
     * piece 4's (-467.2) does not. A push at L/10 from B by 10 nm: A's end
     * moves by under 1 nm, B's by about 11 nm (about A's held part) */
    static fw_trench_point_t p[200];
    int32_t a0[2], b0[2], a1[2], b1[2];
    fw_wire_t w;
    fw_wire_tip_t tip;
    int32_t n = straight_trench(p, 200, -1400000, -560000, 0, 240000);
    rod_and_tip(&w, &tip);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_hold(&w, &tip, p, n));
    TEST_ASSERT_EQUAL_HEX32(0xfu, w.held);
    fw_wire_ends_pm(&w, a0, b0);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_push(&w, L_PM - L_PM / 10, 10000, NULL));
    fw_wire_ends_pm(&w, a1, b1);
    TEST_ASSERT_INT32_WITHIN(1000, a0[1], a1[1]);
    TEST_ASSERT_INT32_WITHIN(1500, b0[1] + 11000, b1[1]);
    /* the free rod turns about a point near B's side instead: A moves back */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, L_PM, D_PM));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_push(&w, L_PM - L_PM / 10, 10000, NULL));
    fw_wire_ends_pm(&w, a1, b1);
    TEST_ASSERT_TRUE(a1[1] < a0[1] - 3000);
}

static void test_trench_push_on_a_short_held_rod_stays_first_order(void)
{
    /* a rod only four times as long as it is thick, held on one piece near
     * B, hold 1000, pushed near B through the update: the lever is clamped
     * to L/16 and each step is a quarter of it, so the turn stays first
     * order (no wrap of the angle) and the rod ends where the apex is */
    static fw_trench_point_t p[2];
    const int32_t len = 400000;
    int32_t apex[3] = { 0, 0, 0 };
    int32_t a0[2], b0[2], a1[2], b1[2];
    fw_wire_t w;
    fw_wire_tip_t tip;
    fw_wire_static_t st;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, len, D_PM));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(&tip, 10000, 20000, 20000, 0, 0));   /* mu 0: hold 1000 */
    w.held = 1u << 24;
    w.hold_q16 = tip.hold_q16;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point_held(len, (int32_t)(0.819 * len), w.held, w.hold_q16, &st));
    TEST_ASSERT_TRUE(st.lever_pm >= len / 16);
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_push(&w, (int32_t)(0.819 * len), st.lever_pm + 1, NULL));
    fw_wire_ends_pm(&w, a0, b0);
    apex[0] = (int32_t)(0.319 * len);
    apex[1] = -50000;
    (void)p;
    w.hold_points = 0;   /* the mask set above stands (no trench given: the cache is kept) */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, INT32_MAX, 0, INT32_MAX));
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_PUSHED) != 0u);
    fw_wire_ends_pm(&w, a1, b1);
    /* turned by well under a half turn, either way */
    {
        double turn = tu_wrap_pi(tu_bam_rad(w.psi));
        TEST_ASSERT_TRUE(fabs(turn) < 1.0);
    }
    (void)a0; (void)b0; (void)a1; (void)b1;
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_trench_hold_matches_the_simulators_formula);
    RUN_TEST(test_trench_hold_caps_at_1000_when_the_wall_is_too_steep);
    RUN_TEST(test_trench_static_no_held_piece_is_the_closed_form);
    RUN_TEST(test_trench_static_all_held_is_the_uniform_rod_times_the_hold);
    RUN_TEST(test_trench_static_matches_double_over_masks_and_pushes);
    RUN_TEST(test_trench_static_held_end_is_the_pivot);
    RUN_TEST(test_trench_static_symmetric_hold_bifurcates_at_the_middle);
    RUN_TEST(test_trench_static_refuses_bad_arguments);
    RUN_TEST(test_trench_holds_a_rod_lying_in_it);
    RUN_TEST(test_trench_narrower_than_the_rod_holds_nothing);
    RUN_TEST(test_trench_under_half_the_rod_holds_that_half);
    RUN_TEST(test_trench_a_rod_across_it_is_held_where_it_crosses);
    RUN_TEST(test_trench_strokes_are_not_joined);
    RUN_TEST(test_trench_hold_empty_far_and_null_inputs);
    RUN_TEST(test_trench_hold_is_cached_until_the_rod_or_the_trench_changes);
    RUN_TEST(test_trench_rule_a_held_rod_needs_hold_times_the_push);
    RUN_TEST(test_trench_rule_a_rod_held_at_one_end_turns_about_it);
    RUN_TEST(test_trench_push_on_a_short_held_rod_stays_first_order);
    return UNITY_END();
}
