/* test_wire.c - fw_wire: static point, minimum push (corrected end value
 * 0.414), bifurcation at L/2, motion update, tip-wire squeeze. */
#include "unity.h"
#include "fw_wire.h"
#include "fw_math.h"
#include "test_util.h"

#define L_PM 1300000     /* the paper's 1.3 um wire */

void setUp(void) {}
void tearDown(void) {}

static double ref_k(double L, double l)
{
    return (2.0 * sqrt((l - L / 2.0) * (l - L / 2.0) + L * L / 4.0) - fabs(L - 2.0 * l)) / L;
}

static double ref_s(double L, double l)
{
    double q = sqrt((l - L / 2.0) * (l - L / 2.0) + L * L / 4.0);
    return (l < L / 2.0) ? l + q : l - q;
}

static void test_wire_end_push_is_sqrt2_minus_1_not_2_minus_sqrt2(void)
{
    fw_wire_static_t st;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point(L_PM, 0, &st));
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround((sqrt(2.0) - 1.0) * TU_TWO_POW(30)), st.k);
    TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(L_PM / sqrt(2.0)), st.s_pm);
    TEST_ASSERT_EQUAL_INT(FW_WIRE_ROTATE_NEAR_B, st.regime);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point(L_PM, L_PM, &st));
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround((sqrt(2.0) - 1.0) * TU_TWO_POW(30)), st.k);
    TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(L_PM - L_PM / sqrt(2.0)), st.s_pm);
    TEST_ASSERT_EQUAL_INT(FW_WIRE_ROTATE_NEAR_A, st.regime);
}

static void test_wire_middle_and_one_lsb_either_side(void)
{
    static const struct { int line; int32_t L; int32_t l; int regime; bool sdef; int32_t s; } rows[] = {
        { __LINE__, L_PM, L_PM / 2, FW_WIRE_TRANSLATE, false, 0 },
        { __LINE__, L_PM, L_PM / 2 - 1, FW_WIRE_ROTATE_NEAR_B, true, L_PM },
        { __LINE__, L_PM, L_PM / 2 + 1, FW_WIRE_ROTATE_NEAR_A, true, 0 },
        { __LINE__, 1300001, 650000, FW_WIRE_ROTATE_NEAR_B, true, 1300001 },  /* odd L: no exact middle */
        { __LINE__, 1300001, 650001, FW_WIRE_ROTATE_NEAR_A, true, 0 },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        fw_wire_static_t st;
        UNITY_TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point(rows[i].L, rows[i].l, &st), rows[i].line, "status");
        UNITY_TEST_ASSERT_EQUAL_INT(rows[i].regime, st.regime, rows[i].line, "regime");
        UNITY_TEST_ASSERT(rows[i].sdef == st.s_defined, rows[i].line, "s defined");
        UNITY_TEST_ASSERT_INT32_WITHIN(1, rows[i].s, st.s_pm, rows[i].line, "s");
        UNITY_TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(ref_k(rows[i].L, rows[i].l) * TU_TWO_POW(30)), st.k,
                                       rows[i].line, "k -> 1 at the middle");
        UNITY_TEST_ASSERT(st.lever_pm >= rows[i].L / 2, rows[i].line, "|l - s| >= L/2");
    }
}

static void test_wire_l_beyond_ends_refused(void)
{
    fw_wire_static_t st;
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_static_point(L_PM, -1, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_static_point(L_PM, L_PM + 1, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_static_point(L_PM, INT32_MIN, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_static_point(0, 0, &st));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_static_point(FW_WIRE_LENGTH_MAX_PM + 1, 0, &st));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point(FW_WIRE_LENGTH_MAX_PM, 0, &st));
}

static void test_wire_static_point_sweep_matches_double(void)
{
    tu_rng_t rng;
    tu_err_t ek;
    tu_err_t es;
    long i;
    tu_rng_seed(&rng, 71);
    tu_err_init(&ek, "wire_k_q30", "(unit)", 1.0 / TU_TWO_POW(30));
    tu_err_init(&es, "wire_s_pm", "pm", 1.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        int32_t L = tu_rng_range(&rng, 1, FW_WIRE_LENGTH_MAX_PM);
        int32_t l = tu_rng_range(&rng, 0, L);
        fw_wire_static_t st;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_static_point(L, l, &st));
        tu_err_add(&ek, tu_q(st.k, 30) - ref_k(L, l));
        if (st.s_defined) {
            tu_err_add(&es, st.s_pm - ref_s(L, l));
        }
    }
    tu_err_print(&ek);
    tu_err_print(&es);
    TEST_ASSERT_TRUE(tu_err_worst_lsb(&ek) <= 2.0);
    TEST_ASSERT_TRUE(es.worst <= 1.0);
}

static void test_wire_push_threshold(void)
{
    bool sat = false;
    TEST_ASSERT_INT32_WITHIN(1, 4142, fw_wire_push_threshold_pn((q30_t)lround((sqrt(2.0) - 1.0) * TU_TWO_POW(30)), 10000, &sat));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_wire_push_threshold_pn(FW_Q30_MAX, INT32_MAX, &sat));
    TEST_ASSERT_TRUE(sat);
}

static void test_wire_end_push_rotates_about_static_point(void)
{
    /* wire along x centred at 0; push end A (l = 0) by +100 pm along +y */
    fw_wire_t w;
    fw_wire_static_t st;
    double dpsi;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, L_PM, 100000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_push(&w, 0, 100, &st));
    dpsi = 100.0 / (0.0 - L_PM / sqrt(2.0));
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)llround(dpsi / (2.0 * TU_PI) * 4294967296.0), (int32_t)w.psi);
    /* centre moves 100 (L/2 - s) / (l - s) = 100 (1 - 0.5 sqrt2) ... along +y */
    TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(100.0 * (L_PM / 2.0 - L_PM / sqrt(2.0)) / (-L_PM / sqrt(2.0))), w.y_pm);
    TEST_ASSERT_EQUAL_INT32(0, w.x_pm);
}

static double max_dpsi_step(int32_t dl)
{
    double prev = 0.0;
    double worst = 0.0;
    int32_t l;
    for (l = L_PM / 2 - 100000; l <= L_PM / 2 + 100000; l += dl) {
        fw_wire_t w;
        double d;
        (void)fw_wire_init(&w, 0, 0, 0u, L_PM, 100000);
        (void)fw_wire_push(&w, l, 1000, NULL);
        d = (double)(int32_t)w.psi;
        if (l > L_PM / 2 - 100000 && fabs(d - prev) > worst) {
            worst = fabs(d - prev);
        }
        prev = d;
    }
    return worst;
}

static void test_wire_push_goes_smoothly_to_translation_at_middle(void)
{
    static const int32_t ls[] = { L_PM / 2 - 1, L_PM / 2, L_PM / 2 + 1 };
    size_t i;
    for (i = 0; i < 3; i++) {
        fw_wire_t w;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, L_PM, 100000));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_push(&w, ls[i], 1000, NULL));
        TEST_ASSERT_EQUAL_INT32(1000, w.y_pm);
        /* blend weight 8 |u| = 1.2e-5: rotation 1.9e-8 rad = 13 bam at most */
        TEST_ASSERT_INT32_WITHIN(16, 0, (int32_t)w.psi);
    }
    {
        /* continuity of dpsi in l through the blend band and the middle:
         * a jump would not shrink with the step in l, a continuous dpsi does */
        double coarse = max_dpsi_step(500);
        double fine = max_dpsi_step(50);
        printf("wire: largest dpsi change between pushes 500 pm apart %.0f bam, 50 pm apart %.0f bam\n",
               coarse, fine);
        TEST_ASSERT_TRUE(fine < 0.2 * coarse + 4.0);
    }
}

static void test_wire_zero_length_and_too_large_moves(void)
{
    fw_wire_t w;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 5, 6, 12345u, L_PM, 100000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_push(&w, 0, 0, NULL));
    TEST_ASSERT_EQUAL_INT32(5, w.x_pm);
    TEST_ASSERT_EQUAL_INT32(6, w.y_pm);
    TEST_ASSERT_EQUAL_UINT32(12345u, w.psi);
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_push(&w, 0, L_PM / 4 + 1, NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_push(&w, L_PM + 1, 10, NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_init(&w, 0, 0, 0u, 0, 100000));
    fw_wire_shift(&w, INT32_MAX, 0);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, w.x_pm);
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_SAT_POS) != 0u);
}

/* ---- squeeze ---------------------------------------------------------------- */

static void test_wire_squeeze_at_psi_max_and_one_lsb_either_side(void)
{
    q30_t k = (q30_t)lround((sqrt(2.0) - 1.0) * TU_TWO_POW(30));
    q30_t mu = (q30_t)lround(0.2 * TU_TWO_POW(30));
    fw_squeeze_t sq;
    fw_bam_t pm;
    double psi_max = atan(1.0 / ((sqrt(2.0) - 1.0) * 0.2));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_squeeze_solve(0u, k, mu, 1000, 0, &sq));
    pm = sq.psi_max;
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)llround(psi_max / (2.0 * TU_PI) * 4294967296.0), (int32_t)pm);
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_squeeze_solve(pm, k, mu, 1000, 50, &sq));
    TEST_ASSERT_EQUAL_UINT32(FW_FLAG_SQUEEZE, sq.flags);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, sq.f_r_pn);
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_wire_squeeze_solve(pm + 1u, k, mu, 1000, 50, &sq));
    TEST_ASSERT_EQUAL_UINT32(FW_FLAG_SQUEEZE, sq.flags);
    /* one LSB below: huge but finite, saturated with a flag, no overflow */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_squeeze_solve(pm - 1u, k, mu, 1000, 50, &sq));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, sq.f_r_pn);
    TEST_ASSERT_TRUE((sq.flags & FW_FLAG_SAT_FORCE) != 0u);
    TEST_ASSERT_TRUE((sq.flags & FW_FLAG_SQUEEZE) == 0u);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_squeeze_solve(FW_BAM_QUARTER_TURN, k, mu, 1000, 50, &sq));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_squeeze_solve(0u, 0, mu, 1000, 50, &sq));
    /* mu = 0: psi_max = 90 deg, never squeezes */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_squeeze_solve(FW_BAM_QUARTER_TURN - 1000u, k, 0, 1000, 0, &sq));
}

static void test_wire_squeeze_sweep_matches_eq_29_30(void)
{
    tu_rng_t rng;
    tu_err_t e;
    long i;
    tu_rng_seed(&rng, 81);
    tu_err_init(&e, "squeeze_fr_pn(<1e5)", "pN", 1.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        double kd = 0.414 + 0.586 * tu_rng_unit(&rng);
        double mud = 0.05 + 0.9 * tu_rng_unit(&rng);
        q30_t k = (q30_t)lround(kd * TU_TWO_POW(30));
        q30_t mu = (q30_t)lround(mud * TU_TWO_POW(30));
        int32_t fl = tu_rng_range(&rng, 100, 1000000);
        double kq = tu_q(k, 30);
        double muq = tu_q(mu, 30);
        double pmax = atan(1.0 / (kq * muq));
        fw_bam_t psi = (fw_bam_t)(uint64_t)llround(tu_rng_unit(&rng) * (pmax - 0.01) / (2.0 * TU_PI) * 4294967296.0);
        double p = tu_bam_rad(psi);
        double fr = kq * fl / (cos(p) - kq * muq * sin(p));
        fw_squeeze_t sq;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_squeeze_solve(psi, k, mu, fl, 500, &sq));
        if (fr < 2e9) {
            if (fr < 1e5) {
                tu_err_add(&e, sq.f_r_pn - fr);
            }
            TEST_ASSERT_TRUE(fabs(sq.f_r_pn - fr) <= 1.0 + 2e-6 * fr);
            TEST_ASSERT_TRUE(fabs(sq.df_pn - (sq.f_r_pn * sin(p) - 500.0)) <= 1.0);
        }
    }
    tu_err_print(&e);
}

static void test_wire_contact_geometry_table(void)
{
    /* Rod 1000 nm long along x (psi = 0) centred at the origin, reach 60 nm.
     * Rows: apex, expected l, dn, touch. */
    static const struct { int line; int32_t x, y, l, dn; bool touch; } rows[] = {
        { __LINE__, 0, -30000, 500000, 30000, true },     /* below the axis: push along +y */
        { __LINE__, 0, 30000, 500000, -30000, true },     /* above: push along -y */
        { __LINE__, -500000, -59999, 0, 1, true },        /* at end A, one pm inside the reach */
        { __LINE__, -500000, -60000, 0, 0, false },       /* exactly at the reach: no contact */
        { __LINE__, -500001, -10000, -1, 50000, false },  /* one pm beyond end A */
        { __LINE__, 500000, 0, 1000000, 60000, true },    /* on the axis at end B: zero normal, +n side rule */
        { __LINE__, 500001, 0, 1000001, 60000, false },
    };
    fw_wire_t w;
    size_t i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, 1000000, 100000));
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        int32_t tip[2] = { rows[i].x, rows[i].y };
        int32_t l = 0, dn = 0;
        bool touch = !rows[i].touch;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_contact(&w, tip, 60000, &touch, &l, &dn));
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].l, l, rows[i].line, "l");
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].dn, dn, rows[i].line, "dn");
        UNITY_TEST_ASSERT(rows[i].touch == touch, rows[i].line, "touch");
    }
}

static void test_wire_contact_rotated_matches_double_within_two_pm(void)
{
    tu_rng_t rng;
    long i;
    tu_rng_seed(&rng, 77);
    for (i = 0; i < AFM_SWEEP_N / 10; i++) {
        fw_wire_t w;
        int32_t mdeg = tu_rng_range(&rng, -180000, 180000);
        int32_t len = tu_rng_range(&rng, 1000, 100000000);
        int32_t cx = tu_rng_range(&rng, -50000000, 50000000), cy = tu_rng_range(&rng, -50000000, 50000000);
        int32_t tip[2] = { cx + tu_rng_range(&rng, -60000000, 60000000), cy + tu_rng_range(&rng, -60000000, 60000000) };
        int32_t reach = tu_rng_range(&rng, 0, 1000000);
        int32_t l, dn;
        bool touch;
        double a = mdeg * 3.14159265358979323846 / 180000.0;
        double dx = (double)tip[0] - cx, dy = (double)tip[1] - cy;
        double l_ref = dx * cos(a) + dy * sin(a) + len / 2;   /* len/2 as the firmware rounds it */
        double n_ref = dy * cos(a) - dx * sin(a);
        double dn_ref = n_ref <= 0 ? n_ref + reach : n_ref - reach;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, cx, cy, fw_math_bam_from_mdeg(mdeg), len, 1000));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_contact(&w, tip, reach, &touch, &l, &dn));
        TEST_ASSERT_DOUBLE_WITHIN(2.0, l_ref - (len % 2) * 0.5, (double)l);
        if (fabs(n_ref) > 2.0) TEST_ASSERT_DOUBLE_WITHIN(2.0, dn_ref, (double)dn);
    }
}

static void test_wire_contact_rejects_null_and_negative_reach(void)
{
    fw_wire_t w;
    int32_t tip[2] = { 0, 0 }, l, dn;
    bool touch;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, 1000, 100));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_contact(NULL, tip, 10, &touch, &l, &dn));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_contact(&w, tip, -1, &touch, &l, &dn));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_contact(&w, NULL, 10, &touch, &l, &dn));
}

/* ---- the push rule (fw_wire_update) ---------------------------------------- */

/* The paper's rod (1.3 um x 100 nm) along x at the origin; the apex under
 * its middle (k = 1), inside the reach r_tip + d/2 = 60 nm. */
static void rule_rod(fw_wire_t *w, fw_wire_tip_t *tip, int32_t gamma_mdeg, int32_t mu_ppm, bool down)
{
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(w, 0, 0, 0u, L_PM, 100000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(tip, 10000, gamma_mdeg, 20000, mu_ppm, 0));
    tip->down_force = down;
}

static void test_wire_rule_triggers_one_pn_past_half_of_k_f_l(void)
{
    /* without the down force the push is k f L = 1 x 26000 pN: half is 13000 */
    const int32_t apex[3] = { 0, -50000, 0 };
    fw_wire_t w;
    fw_wire_tip_t tip;
    rule_rod(&w, &tip, 20000, 300000, false);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, 13000, 0, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & FW_WIRE_PUSHED);
    TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, 13001, 0, INT32_MAX));
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_PUSHED) != 0u);
    TEST_ASSERT_EQUAL_INT32(10000, w.y_pm);   /* moved until the apex sits on its surface */
}

static void test_wire_rule_with_down_force_uses_eq_29_push(void)
{
    /* gamma 20 deg, mu 0.3: the push that moves the rod is k f L / (1 - k mu
     * tan psi) = 26000 / (1 - 0.3 tan 20) = 29188 pN; half of it decides */
    const int32_t apex[3] = { 0, -50000, 0 };
    fw_wire_t w;
    fw_wire_tip_t tip;
    fw_squeeze_t sq;
    double ref = 26000.0 / (1.0 - 0.3 * tan(20.0 * TU_PI / 180.0));
    rule_rod(&w, &tip, 20000, 300000, true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_squeeze_solve(tip.tip_half_angle, FW_Q30_ONE, tip.mu, 26000, 0, &sq));
    TEST_ASSERT_DOUBLE_WITHIN(2.0, ref, (double)sq.push_pn);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, sq.push_pn >> 1, 0, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & (FW_WIRE_PUSHED | FW_WIRE_SQUEEZED));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, (sq.push_pn >> 1) + 1, 0, INT32_MAX));
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_PUSHED) != 0u);
    /* a sliding rod's excess is the push plus noise: a third below still
     * moves the model (the reason for the midpoint) */
    rule_rod(&w, &tip, 20000, 300000, true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, sq.push_pn - sq.push_pn / 3, 0, INT32_MAX));
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_PUSHED) != 0u);
}

static void test_wire_rule_squeezes_past_psi_max_and_the_twist_counts(void)
{
    /* mu 1.0, k 1 at the middle: psi_max = 45 deg. gamma 44 deg pushes;
     * the same with a twist of 2 deg (either sign) squeezes: the rod stays */
    const int32_t apex[3] = { 0, -50000, 0 };
    const q30_t two_deg = (q30_t)lround(2.0 * TU_PI / 180.0 * TU_TWO_POW(30));
    fw_wire_t w;
    fw_wire_tip_t tip;
    rule_rod(&w, &tip, 44000, 1000000, true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, INT32_MAX, 0, INT32_MAX));
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_PUSHED) != 0u);
    rule_rod(&w, &tip, 44000, 1000000, true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, INT32_MAX, two_deg, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_SQUEEZED, w.flags & (FW_WIRE_PUSHED | FW_WIRE_SQUEEZED));
    TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, INT32_MAX, -two_deg, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_SQUEEZED, w.flags & (FW_WIRE_PUSHED | FW_WIRE_SQUEEZED));
    /* below half of k f L the tip merely touches: neither flag */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, 13000, two_deg, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & (FW_WIRE_PUSHED | FW_WIRE_SQUEEZED));
    /* without the down force nothing squeezes */
    rule_rod(&w, &tip, 44000, 1000000, false);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, INT32_MAX, two_deg, INT32_MAX));
    TEST_ASSERT_TRUE((w.flags & FW_WIRE_PUSHED) != 0u);
}

static void test_wire_ride_push_is_the_load_over_tan_psi(void)
{
    /* psi 45 deg: tan 1, H_ride = F_z + F_a,ts; 20 deg: / tan 20 */
    const fw_bam_t d45 = fw_math_bam_from_mdeg(45000), d20 = fw_math_bam_from_mdeg(20000);
    TEST_ASSERT_INT32_WITHIN(2, 6000, fw_wire_ride_push_pn(d45, 5000, 1000));
    TEST_ASSERT_DOUBLE_WITHIN(2.0, 5000.0 / tan(20.0 * TU_PI / 180.0), (double)fw_wire_ride_push_pn(d20, 5000, 0));
    /* no load and no adhesion: the tip lifts at once; psi 0: no flank to climb */
    TEST_ASSERT_EQUAL_INT32(0, fw_wire_ride_push_pn(d45, 0, 0));
    TEST_ASSERT_EQUAL_INT32(0, fw_wire_ride_push_pn(d45, -3000, 1000));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_wire_ride_push_pn(0, 5000, 0));
    /* a huge load at a shallow angle saturates, it does not wrap */
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_wire_ride_push_pn(fw_math_bam_from_mdeg(1), INT32_MAX, 1000));
}

static void test_wire_rides_over_below_eq_30s_load_and_pushes_above_it(void)
{
    /* gamma 20 deg, mu 0.3, no adhesion: eq. 29's push 29188 pN; eq. 30's
     * least load dF = push tan psi = 10623 pN. At 0.9 dF eq. 30 predicts
     * the lift once the excess passes half of H_ride = 0.9 dF / tan psi:
     * the rod stays, the ride-over pending (no climb yet: not RIDDEN;
     * test_wire_ride has the evidence); at 1.1 dF it is pushed at half of
     * eq. 29's push. */
    const int32_t apex[3] = { 0, -50000, 0 };
    fw_wire_t w;
    fw_wire_tip_t tip;
    fw_squeeze_t sq;
    int32_t low;
    int32_t high;
    int32_t ride;
    rule_rod(&w, &tip, 20000, 300000, true);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_squeeze_solve(tip.tip_half_angle, FW_Q30_ONE, tip.mu, 26000, 0, &sq));
    TEST_ASSERT_DOUBLE_WITHIN(3.0, 26000.0 / (1.0 - 0.3 * tan(20.0 * TU_PI / 180.0)) * tan(20.0 * TU_PI / 180.0),
                              (double)sq.df_pn);
    low = (int32_t)lround(0.9 * sq.df_pn);
    high = (int32_t)lround(1.1 * sq.df_pn);
    ride = fw_wire_ride_push_pn(tip.tip_half_angle, low, 0);
    TEST_ASSERT_TRUE(ride < sq.push_pn);
    /* below half of H_ride: the tip merely touches */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, ride >> 1, 0, low));
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN | FW_WIRE_SQUEEZED));
    /* past it: a ride-over predicted, the rod stays, however large the
     * excess (the apex only r_tip inside the reach: no contradiction) */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, (ride >> 1) + 1, 0, low));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, w.flags & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN | FW_WIRE_SQUEEZED |
                                                              FW_WIRE_RIDE_PENDING));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, INT32_MAX, 0, low));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, w.flags & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN | FW_WIRE_SQUEEZED |
                                                              FW_WIRE_RIDE_PENDING));
    TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
    /* the load above dF: pushed, as without any load limit */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, sq.push_pn >> 1, 0, high));
    TEST_ASSERT_EQUAL_UINT32(0u, w.flags & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, (sq.push_pn >> 1) + 1, 0, high));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_PUSHED, w.flags & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN));
    /* without the down force the load does not matter */
    rule_rod(&w, &tip, 20000, 300000, false);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, 13001, 0, 0));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_PUSHED, w.flags & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_wire_end_push_is_sqrt2_minus_1_not_2_minus_sqrt2);
    RUN_TEST(test_wire_middle_and_one_lsb_either_side);
    RUN_TEST(test_wire_l_beyond_ends_refused);
    RUN_TEST(test_wire_static_point_sweep_matches_double);
    RUN_TEST(test_wire_push_threshold);
    RUN_TEST(test_wire_end_push_rotates_about_static_point);
    RUN_TEST(test_wire_push_goes_smoothly_to_translation_at_middle);
    RUN_TEST(test_wire_zero_length_and_too_large_moves);
    RUN_TEST(test_wire_squeeze_at_psi_max_and_one_lsb_either_side);
    RUN_TEST(test_wire_squeeze_sweep_matches_eq_29_30);
    RUN_TEST(test_wire_contact_geometry_table);
    RUN_TEST(test_wire_contact_rotated_matches_double_within_two_pm);
    RUN_TEST(test_wire_contact_rejects_null_and_negative_reach);
    RUN_TEST(test_wire_rule_triggers_one_pn_past_half_of_k_f_l);
    RUN_TEST(test_wire_rule_with_down_force_uses_eq_29_push);
    RUN_TEST(test_wire_rule_squeezes_past_psi_max_and_the_twist_counts);
    RUN_TEST(test_wire_ride_push_is_the_load_over_tan_psi);
    RUN_TEST(test_wire_rides_over_below_eq_30s_load_and_pushes_above_it);
    return UNITY_END();
}
