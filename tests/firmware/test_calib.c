/* test_calib.c - fw_calib: tilted-surface closed form, adhesion, C_n fit,
 * C_l estimate. */
#include "unity.h"
#include "fw_calib.h"
#include "fw_paper_probe.h"
#include "fw_math.h"
#include "test_util.h"

void setUp(void) {}
void tearDown(void) {}

static q24_t q24(double v)
{
    return (q24_t)lround(v * TU_TWO_POW(24));
}

static fw_bam_t bam_deg(double deg)
{
    return (fw_bam_t)(int64_t)llround(deg / 360.0 * 4294967296.0);
}

/* double reference of the closed form */
static int ref_tilted(double ru, double rd, double phi, double knkn, double *mu, double *lat)
{
    /* B = 2 (rho + 1) / ((rho - 1) sin 2phi), written so r_d = 0 works */
    double b = 2.0 * (ru + rd) / ((ru - rd) * sin(2.0 * phi));
    if (b < 2.0) {
        return 0;
    }
    *mu = 2.0 / (b + sqrt(b * b - 4.0));
    *lat = knkn * tan(phi + atan(*mu)) / ru;
    return 1;
}

static void test_calib_tilted_paper_numbers(void)
{
    fw_calib_tilted_t t;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_tilted_solve(q24(0.07), q24(0.02), bam_deg(9.0), FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    printf("paper: mu %.5f (ppm %ld), k_theta K_l/h %ld pN/V, beta %.4f deg\n",
           tu_q(t.mu, 30), (long)t.mu_ppm, (long)t.lateral_gain_pn_per_v, tu_bam_rad(t.beta) * 180.0 / TU_PI);
    TEST_ASSERT_INT32_WITHIN(50, 86500, t.mu_ppm);          /* 0.0865 */
    TEST_ASSERT_INT32_WITHIN(50, FW_PAPER_LATERAL_GAIN_PN_PER_V, t.lateral_gain_pn_per_v);    /* 37.9 nN/V */
    /* phi = 8.98 deg matches the paper's 0.086 and 37.8 */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_tilted_solve(q24(0.07), q24(0.02), bam_deg(8.98), FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    TEST_ASSERT_INT32_WITHIN(500, 86000, t.mu_ppm);
    TEST_ASSERT_INT32_WITHIN(60, 37800, t.lateral_gain_pn_per_v);
}

static void test_calib_tilted_refuses_rho_near_1_and_inside(void)
{
    static const struct { int line; double ru; double rd; double phi; fw_status_t st; } rows[] = {
        { __LINE__, 0.07, 0.07, 9.0, FW_ERR_DOMAIN },               /* rho = 1 */
        { __LINE__, 0.07, 0.0699999, 9.0, FW_ERR_DOMAIN },          /* rho -> 1+ */
        { __LINE__, 0.07, 0.06995, 9.0, FW_ERR_DOMAIN },            /* rho 1.00071: within 2^-10 of 1 */
        { __LINE__, 0.07, 0.0699, 9.0, FW_OK },                     /* rho 1.0014: just outside */
        { __LINE__, 0.07, 0.0698, 9.0, FW_OK },                     /* rho 1.0029 */
        { __LINE__, 0.02, 0.07, 9.0, FW_ERR_DOMAIN },               /* |rho| < 1 */
        { __LINE__, 0.07, -0.07, 9.0, FW_ERR_DOMAIN },              /* rho = -1 */
        { __LINE__, 0.07, -0.02, 9.0, FW_OK },                      /* rho = -3.5: B = 3.60, mu = 0.304 */
        { __LINE__, 0.07, -0.05, 40.0, FW_ERR_DOMAIN },             /* rho = -1.4: B = 1.22 < 2, no real beta */
        { __LINE__, 0.07, -0.069, 2.0, FW_ERR_DOMAIN },             /* rho -> -1-: B -> 0, no real beta */
        { __LINE__, -0.07, 0.02, 9.0, FW_ERR_DOMAIN },              /* r_u <= 0 */
        { __LINE__, 0.07, 0.0, 9.0, FW_OK },                        /* rho infinite: mu = tan phi */
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        fw_calib_tilted_t t;
        fw_status_t st = fw_calib_tilted_solve(q24(rows[i].ru), q24(rows[i].rd), bam_deg(rows[i].phi), FW_PAPER_NORMAL_GAIN_PN_PER_V, &t);
        double mu;
        double lat;
        if (st == FW_OK && ref_tilted(tu_q(q24(rows[i].ru), 24), tu_q(q24(rows[i].rd), 24),
                                      tu_bam_rad(bam_deg(rows[i].phi)), (double)FW_PAPER_NORMAL_GAIN_PN_PER_V, &mu, &lat)) {
            UNITY_TEST_ASSERT(fabs(tu_q(t.mu, 30) - mu) < 1e-6, rows[i].line, "mu");
        }
        UNITY_TEST_ASSERT_EQUAL_INT(rows[i].st, st, rows[i].line, "status");
    }
}

static void test_calib_tilted_rho_below_minus_1_accepted_when_phi_lt_beta(void)
{
    /* phi 3 deg < beta (mu 0.2 -> 11.3 deg): r_d < 0 */
    double phi = 3.0 * TU_PI / 180.0;
    double beta = atan(0.2);
    double a = 0.3;
    double ru = a * tan(phi + beta);
    double rd = a * tan(phi - beta);
    fw_calib_tilted_t t;
    TEST_ASSERT_TRUE(ru / rd < -1.0);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_tilted_solve(q24(ru), q24(rd), bam_deg(3.0), FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    TEST_ASSERT_INT32_WITHIN(20, 200000, t.mu_ppm);
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround((double)FW_PAPER_NORMAL_GAIN_PN_PER_V / a), t.lateral_gain_pn_per_v);
}

static void test_calib_tilted_refuses_phi_zero_and_tiny(void)
{
    fw_calib_tilted_t t;
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_tilted_solve(q24(0.07), q24(0.02), 0u, FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_tilted_solve(q24(0.07), q24(0.02), FW_BAM_QUARTER_TURN, FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_tilted_solve(q24(0.07), q24(0.02), 0u - 1000u, FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    /* phi -> 0: one LSB of angle and just below 0.1 deg are refused, 0.1 deg is accepted */
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_tilted_solve(q24(0.07), q24(0.02), 1u, FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_tilted_solve(q24(0.07), q24(0.02),
                                                               fw_math_bam_from_mdeg(FW_CALIB_PHI_MIN_MDEG) - 1u, FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_tilted_solve(q24(0.07), q24(0.02),
                                                       fw_math_bam_from_mdeg(FW_CALIB_PHI_MIN_MDEG), FW_PAPER_NORMAL_GAIN_PN_PER_V, &t));
    TEST_ASSERT_TRUE(t.mu > 0);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_calib_tilted_solve(q24(0.07), q24(0.02), bam_deg(9.0), 0, &t));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_calib_tilted_solve(q24(0.07), q24(0.02), bam_deg(9.0), FW_PAPER_NORMAL_GAIN_PN_PER_V, NULL));
}

static void test_calib_tilted_sweep_matches_double(void)
{
    tu_rng_t rng;
    tu_err_t emu;
    tu_err_t elat;
    long i;
    long n_ok = 0;
    tu_rng_seed(&rng, 61);
    tu_err_init(&emu, "calib_tilted_mu", "(unit)", 1.0 / TU_TWO_POW(30));
    tu_err_init(&elat, "calib_tilted_lateral_gain", "pN/V", 1.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        double phi_deg = 0.5 + tu_rng_unit(&rng) * 40.0;
        double mu_true = 0.01 + tu_rng_unit(&rng) * 0.6;
        double a = 0.05 + tu_rng_unit(&rng) * 2.0;
        double phi;
        double ru;
        double rd;
        double mu;
        double lat;
        fw_calib_tilted_t t;
        fw_bam_t pb = bam_deg(phi_deg);
        phi = tu_bam_rad(pb);
        ru = a * tan(phi + atan(mu_true));
        rd = a * tan(phi - atan(mu_true));
        /* the reference uses the quantised inputs */
        ru = tu_q(q24(ru), 24);
        rd = tu_q(q24(rd), 24);
        if (fw_calib_tilted_solve(q24(ru), q24(rd), pb, FW_PAPER_NORMAL_GAIN_PN_PER_V, &t) != FW_OK) {
            continue;
        }
        if (!ref_tilted(ru, rd, phi, (double)FW_PAPER_NORMAL_GAIN_PN_PER_V, &mu, &lat)) {
            continue;
        }
        n_ok++;
        tu_err_add(&emu, tu_q(t.mu, 30) - mu);
        tu_err_add(&elat, t.lateral_gain_pn_per_v - lat);
    }
    tu_err_print(&emu);
    tu_err_print(&elat);
    printf("  (%ld of %ld cases inside the domain)\n", n_ok, (long)AFM_SWEEP_N);
    TEST_ASSERT_TRUE(n_ok > AFM_SWEEP_N / 2);
    TEST_ASSERT_TRUE(emu.worst <= 6e-8);
    TEST_ASSERT_TRUE(elat.worst <= 1.0);
}

static void test_calib_adhesion_from_loop_offsets(void)
{
    /* both lines through S_l = 0 at S_n = -0.5 V: F_adh = 10680 * 0.5 */
    int32_t adh;
    bool sat = false;
    q23_t bu = (q23_t)lround(0.07 * 0.5 * TU_TWO_POW(23));
    q23_t bd = (q23_t)lround(0.02 * 0.5 * TU_TWO_POW(23));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_adhesion_pn(q24(0.07), bu, q24(0.02), bd, FW_PAPER_NORMAL_GAIN_PN_PER_V, &adh, &sat));
    TEST_ASSERT_INT32_WITHIN(2, 5340, adh);
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_adhesion_pn(q24(0.07), bu, q24(0.07), bd, FW_PAPER_NORMAL_GAIN_PN_PER_V, &adh, &sat));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_adhesion_pn(1, FW_Q23_MAX, 0, FW_Q23_MIN, INT32_MAX, &adh, &sat));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, adh);
    TEST_ASSERT_TRUE(sat);
}

static void test_calib_lines_paper_gives_23_1_nm_per_v(void)
{
    const int32_t depth[4] = { 500000, 1000000, 1500000, 2000000 };
    const int32_t off[4] = { 0, 130000, 260000, 390000 };
    int32_t cn;
    int32_t res;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_lines_cn(depth, off, 4, FW_PAPER_DEFLECTION_PM_PER_V, &cn, &res));
    TEST_ASSERT_INT32_WITHIN(1, 23140, cn);    /* 130 / (500 / 89) nm/V */
    TEST_ASSERT_EQUAL_INT32(0, res);
}

static void test_calib_lines_residual_and_refusals(void)
{
    const int32_t depth[4] = { 500000, 1000000, 1500000, 2000000 };
    const int32_t off[4] = { 0, 140000, 250000, 390000 };
    const int32_t same[4] = { 500000, 500000, 500000, 500000 };
    int32_t cn;
    int32_t res;
    /* reference: slope 0.256, residuals -3, 9, -9, 3 nm, rms 6.708 nm */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_lines_cn(depth, off, 4, FW_PAPER_DEFLECTION_PM_PER_V, &cn, &res));
    TEST_ASSERT_INT32_WITHIN(1, 22784, cn);
    TEST_ASSERT_INT32_WITHIN(1, 6708, res);
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_lines_cn(same, off, 4, FW_PAPER_DEFLECTION_PM_PER_V, &cn, &res));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_calib_lines_cn(depth, off, 1, FW_PAPER_DEFLECTION_PM_PER_V, &cn, &res));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_calib_lines_cn(depth, off, 4, 0, &cn, &res));
    {
        const int32_t big[2] = { 0, FW_CALIB_LINES_RANGE_PM + 1 };
        TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_calib_lines_cn(big, off, 2, FW_PAPER_DEFLECTION_PM_PER_V, &cn, &res));
    }
    {
        /* extremes of the allowed range: no overflow */
        const int32_t x[2] = { -FW_CALIB_LINES_RANGE_PM, FW_CALIB_LINES_RANGE_PM };
        const int32_t y[2] = { FW_CALIB_LINES_RANGE_PM, -FW_CALIB_LINES_RANGE_PM };
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_lines_cn(x, y, 2, INT32_MAX, &cn, &res));
        TEST_ASSERT_EQUAL_INT32(-INT32_MAX, cn);
    }
}

static void test_calib_disp_estimate_paper_probe(void)
{
    int32_t cl;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_disp_estimate(FW_PAPER_TIP_HEIGHT_NM, FW_PAPER_LEVER_LENGTH_NM, FW_PAPER_DEFLECTION_PM_PER_V, &cl));
    TEST_ASSERT_EQUAL_INT32(23096, cl);   /* 3 * 17.3 * 89 / 200 = 23.0955 nm/V */
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_disp_estimate(100000, FW_PAPER_LEVER_LENGTH_NM, FW_PAPER_DEFLECTION_PM_PER_V, &cl));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_calib_disp_estimate(0, FW_PAPER_LEVER_LENGTH_NM, FW_PAPER_DEFLECTION_PM_PER_V, &cl));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_calib_disp_estimate(INT32_MAX - 1, INT32_MAX, INT32_MAX, &cl));
    TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(1.5 * (INT32_MAX - 1.0)), cl);
}

static void test_calib_tilted_rule_names_each_refusal(void)
{
    int32_t g = FW_PAPER_NORMAL_GAIN_PN_PER_V;
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, fw_calib_tilted_rule(q24(0.07), q24(0.02), bam_deg(9.0), g));
    TEST_ASSERT_EQUAL_INT(FW_RULE_FORCE_GAINS, fw_calib_tilted_rule(q24(0.07), q24(0.02), bam_deg(9.0), 0));
    TEST_ASSERT_EQUAL_INT(FW_RULE_TILTED_SLOPE, fw_calib_tilted_rule(q24(0.07), q24(0.02), bam_deg(0.09), g));
    TEST_ASSERT_EQUAL_INT(FW_RULE_TILTED_SLOPE, fw_calib_tilted_rule(q24(0.07), q24(0.02), FW_BAM_QUARTER_TURN, g));
    TEST_ASSERT_EQUAL_INT(FW_RULE_TILTED_UPHILL, fw_calib_tilted_rule(0, q24(0.02), bam_deg(9.0), g));
    TEST_ASSERT_EQUAL_INT(FW_RULE_TILTED_CONTRAST, fw_calib_tilted_rule(q24(0.02), q24(0.07), bam_deg(9.0), g));
    TEST_ASSERT_EQUAL_INT(FW_RULE_TILTED_CONTRAST, fw_calib_tilted_rule(q24(0.07), q24(-0.07), bam_deg(9.0), g));
    /* B < 2: a contrast too strong for the slope angle */
    TEST_ASSERT_EQUAL_INT(FW_RULE_TILTED_NO_ANGLE, fw_calib_tilted_rule(q24(1.0), q24(0.0), bam_deg(45.0), g));
    {
        fw_calib_tilted_t t;
        TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_calib_tilted_solve(q24(0.07), q24(0.02), bam_deg(9.0), g, NULL));
        TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_calib_tilted_solve(q24(0.02), q24(0.07), bam_deg(9.0), g, &t));
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_calib_tilted_paper_numbers);
    RUN_TEST(test_calib_tilted_refuses_rho_near_1_and_inside);
    RUN_TEST(test_calib_tilted_rho_below_minus_1_accepted_when_phi_lt_beta);
    RUN_TEST(test_calib_tilted_refuses_phi_zero_and_tiny);
    RUN_TEST(test_calib_tilted_sweep_matches_double);
    RUN_TEST(test_calib_adhesion_from_loop_offsets);
    RUN_TEST(test_calib_lines_paper_gives_23_1_nm_per_v);
    RUN_TEST(test_calib_lines_residual_and_refusals);
    RUN_TEST(test_calib_disp_estimate_paper_probe);
    RUN_TEST(test_calib_tilted_rule_names_each_refusal);
    return UNITY_END();
}
