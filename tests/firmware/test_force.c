/* test_force.c - fw_force: eq. 1a-1c, the friction fallback near
 * sin theta = 0, rotation (eq. 3), the lateral excess. */
#include <stdlib.h>
#include "unity.h"
#include "fw_force.h"
#include "fw_paper_probe.h"
#include "fw_math.h"
#include "test_util.h"

/* the paper's probe (fw_paper_probe.h), adhesion 5 nN */
#define KN FW_PAPER_NORMAL_GAIN_PN_PER_V
#define LAT FW_PAPER_LATERAL_GAIN_PN_PER_V
#define H_NM FW_PAPER_TIP_HEIGHT_NM
#define L_NM FW_PAPER_LEVER_LENGTH_NM
#define MU_PPM FW_PAPER_MU_PPM
#define ADH 5000

static fw_force_t f;

void setUp(void)
{
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_init(&f, KN, LAT, H_NM, L_NM, MU_PPM, ADH));
}
void tearDown(void) {}

/* double reference of the documented model, including the blend */
static void ref_force(double sn, double sl, double c, double s, double out[3], int *unobs)
{
    double g = 2.0 * H_NM / L_NM;
    double mu = MU_PPM / 1e6;
    double fy = LAT * sl;
    double n = KN * sn;
    double as = fabs(s);
    double fx = 0.0;
    double lo = 4096.0 / 32768.0;
    double hi = 8192.0 / 32768.0;
    if (c == 0.0 && s == 0.0) {
        s = 32767.0 / 32768.0;
        as = s;
    }
    if (as >= lo) {
        fx = fy * c / s;
    }
    *unobs = as < hi;
    if (as < hi) {
        double fb = -mu * c * (n + ADH) / (1.0 - mu * c * g);
        double w = (as - lo) / (hi - lo);
        fx = (as < lo) ? fb : w * fx + (1.0 - w) * fb;
    }
    out[0] = fx;
    out[1] = fy;
    out[2] = n - g * fx;
}

static void solve_deg(double theta_deg, q23_t sn, q23_t sl, int32_t fc[3], uint32_t *flags)
{
    double t = theta_deg * TU_PI / 180.0;
    q15_t c = (q15_t)lround(cos(t) * 32767.0);
    q15_t s = (q15_t)lround(sin(t) * 32767.0);
    *flags = 0;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_solve_pn(&f, sn, sl, c, s, fc, flags));
}

static void test_force_init_rejects_bad_probe(void)
{
    fw_force_t g;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_force_init(&g, 0, LAT, H_NM, L_NM, MU_PPM, ADH));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_force_init(&g, KN, LAT, 0, L_NM, MU_PPM, ADH));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_force_init(&g, KN, LAT, H_NM, L_NM, 1000001, ADH));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_force_init(&g, KN, LAT, H_NM, L_NM, MU_PPM, -1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_force_init(&g, KN, LAT, L_NM, L_NM, MU_PPM, ADH));
    /* mu 2h/l = 1 * 1.8 > 1/2 */
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_force_init(&g, KN, LAT, 90000, L_NM, 1000000, ADH));
}

static void test_force_cot_theta_45_deg_gives_fx_equal_fy(void)
{
    int32_t fc[3];
    uint32_t flags;
    solve_deg(45.0, FW_Q23_ONE, FW_Q23_ONE, fc, &flags);
    TEST_ASSERT_EQUAL_INT32(LAT, fc[1]);
    TEST_ASSERT_INT32_WITHIN(2, LAT, fc[0]);
    /* F_z = 10680 - 0.346 * 37900 */
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(KN - 2.0 * H_NM / L_NM * LAT), fc[2]);
    TEST_ASSERT_EQUAL_UINT32(0u, flags);
}

static void test_force_cot_theta_90_deg_gives_zero_fx(void)
{
    int32_t fc[3];
    uint32_t flags;
    solve_deg(90.0, 2 * FW_Q23_ONE, -FW_Q23_ONE, fc, &flags);
    TEST_ASSERT_EQUAL_INT32(0, fc[0]);
    TEST_ASSERT_EQUAL_INT32(-LAT, fc[1]);
    TEST_ASSERT_EQUAL_INT32(2 * KN, fc[2]);
}

static void test_force_cot_theta_at_0_and_pi_uses_friction_fallback(void)
{
    /* theta = 0 and pi exactly, and one LSB of sin (1/32767) either side */
    static const struct { int line; q15_t c; q15_t s; } rows[] = {
        { __LINE__, 32767, 0 }, { __LINE__, 32767, 1 }, { __LINE__, 32767, -1 },
        { __LINE__, -32767, 0 }, { __LINE__, -32767, 1 }, { __LINE__, -32767, -1 },
        { __LINE__, 0, 0 },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        int32_t fc[3];
        uint32_t flags = 0;
        double ref[3];
        int unobs;
        q23_t sn = 3 * FW_Q23_ONE;
        q23_t sl = FW_Q23_ONE / 100;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_solve_pn(&f, sn, sl, rows[i].c, rows[i].s, fc, &flags));
        ref_force(3.0, 0.01, rows[i].c / 32768.0, rows[i].s / 32768.0, ref, &unobs);
        UNITY_TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(ref[0]), fc[0], rows[i].line, "F_x");
        UNITY_TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(ref[2]), fc[2], rows[i].line, "F_z");
        UNITY_TEST_ASSERT((flags & FW_FLAG_FX_UNOBSERVABLE) != 0u || (rows[i].c == 0 && rows[i].s == 0),
                          rows[i].line, "unobservable flag");
        UNITY_TEST_ASSERT((flags & FW_FLAG_SAT_FORCE) == 0u, rows[i].line, "no saturation");
    }
}

static void test_force_friction_fallback_opposes_motion_along_lever(void)
{
    int32_t fc[3];
    uint32_t flags;
    /* moving +x (theta = 0) under load: friction on the tip points -x */
    solve_deg(0.0, 2 * FW_Q23_ONE, 0, fc, &flags);
    TEST_ASSERT_TRUE(fc[0] < 0);
    solve_deg(180.0, 2 * FW_Q23_ONE, 0, fc, &flags);
    TEST_ASSERT_TRUE(fc[0] > 0);
}

static double max_jump(double from_deg, double to_deg, double step_deg)
{
    double worst = 0.0;
    int32_t prev[3];
    double t;
    bool first = true;
    for (t = from_deg; t <= to_deg; t += step_deg) {
        int32_t fc[3];
        uint32_t flags;
        int k;
        solve_deg(t, 3 * FW_Q23_ONE, FW_Q23_ONE / 4, fc, &flags);
        for (k = 0; k < 3 && !first; k++) {
            TEST_ASSERT_TRUE(fc[k] != INT32_MAX && fc[k] != INT32_MIN);
            if (fabs((double)fc[k] - prev[k]) > worst) {
                worst = fabs((double)fc[k] - prev[k]);
            }
        }
        prev[0] = fc[0];
        prev[1] = fc[1];
        prev[2] = fc[2];
        first = false;
    }
    return worst;
}

static void test_force_sweep_through_0_and_pi_is_continuous(void)
{
    /* A jump would not shrink with the step; a continuous F_x does. */
    double coarse0 = max_jump(-30.0, 30.0, 0.05);
    double fine0 = max_jump(-30.0, 30.0, 0.005);
    double coarse1 = max_jump(150.0, 210.0, 0.05);
    double fine1 = max_jump(150.0, 210.0, 0.005);
    printf("continuity: max step jump %.1f pN at 0.05 deg, %.1f pN at 0.005 deg (theta ~ 0); "
           "%.1f / %.1f pN (theta ~ pi)\n", coarse0, fine0, coarse1, fine1);
    TEST_ASSERT_TRUE(fine0 < 0.2 * coarse0 + 4.0);
    TEST_ASSERT_TRUE(fine1 < 0.2 * coarse1 + 4.0);
}

static void test_force_saturates_exactly_with_flag(void)
{
    fw_force_t g;
    int32_t fc[3];
    uint32_t flags = 0;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_init(&g, INT32_MAX, INT32_MAX, H_NM, L_NM, 0, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_solve_pn(&g, FW_Q23_MAX, FW_Q23_MIN, 0, 32767, fc, &flags));
    TEST_ASSERT_EQUAL_INT32(INT32_MIN, fc[1]);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fc[2]);
    TEST_ASSERT_TRUE((flags & FW_FLAG_SAT_FORCE) != 0u);
    flags = 0;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_solve_pn(&g, FW_Q23_MIN, FW_Q23_MAX, 23170, 23170, fc, &flags));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fc[0]);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fc[1]);
    TEST_ASSERT_EQUAL_INT32(INT32_MIN, fc[2]);
    TEST_ASSERT_TRUE((flags & FW_FLAG_SAT_FORCE) != 0u);
    flags = 0;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_force_solve_pn(&g, 0, 0, 0, 0, NULL, &flags));
}

static void test_force_rotate_scan_angle_0_maps_c_to_a_by_minus_270(void)
{
    int32_t vc[3] = { 1000, 0, 5 };
    int32_t va[3];
    bool sat = false;
    /* scan angle 0 deg: alpha = -270 deg = +90 deg, x_C -> y_A */
    fw_bam_t alpha = fw_math_bam_from_mdeg(-270000);
    fw_force_rotate_pn(vc, fw_math_cos_q30(alpha), fw_math_sin_q30(alpha), va, &sat);
    TEST_ASSERT_EQUAL_INT32(0, va[0]);
    TEST_ASSERT_EQUAL_INT32(1000, va[1]);
    TEST_ASSERT_EQUAL_INT32(5, va[2]);
}

/* ---- direction-vector solver (fw_force_solve_pn) ---------------------- */

static void solve_dir(int32_t x, int32_t y, q23_t sn, q23_t sl, int32_t fc[3], uint32_t *flags,
                      double ref[3], int *unobs)
{
    double len = sqrt((double)x * x + (double)y * y);
    *flags = 0;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_solve_pn(&f, sn, sl, x, y, fc, flags));
    if (len == 0.0) {
        ref_force(tu_q(sn, 23), tu_q(sl, 23), 0.0, 1.0, ref, unobs);
    } else {
        ref_force(tu_q(sn, 23), tu_q(sl, 23), x / len, y / len, ref, unobs);
    }
}

static int32_t isqrt_i64(int64_t v)
{
    return (int32_t)fw_math_isqrt_u64((uint64_t)v);
}

static void test_force_dir_zones_at_one_eighth_and_one_quarter_and_one_lsb_either_side(void)
{
    /* |sin| >= 1/4 <=> 15 y^2 >= x^2 and |sin| >= 1/8 <=> 63 y^2 >= x^2:
     * x = isqrt(k y^2) lies on or inside the boundary, x + 1 one LSB outside;
     * F_x matches the model on both sides and changes only by the
     * model's own step (continuity) */
    static const struct { int line; int32_t y; } rows[] = {
        { __LINE__, 1 }, { __LINE__, 3 }, { __LINE__, 1000 }, { __LINE__, 4096 },
        { __LINE__, -1 }, { __LINE__, -777 }, { __LINE__, -4096 },
    };
    static const int32_t ks[] = { 15, 63 };
    size_t i;
    size_t k;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        for (k = 0; k < 2; k++) {
            int32_t y = rows[i].y;
            int32_t x0 = isqrt_i64((int64_t)ks[k] * y * y);
            int sgn;
            for (sgn = -1; sgn <= 1; sgn += 2) {
                int32_t fc_in[3];
                int32_t fc_out[3];
                uint32_t fl_in;
                uint32_t fl_out;
                double ref[3];
                int unobs;
                solve_dir(sgn * x0, y, 3 * FW_Q23_ONE, FW_Q23_ONE / 4, fc_in, &fl_in, ref, &unobs);
                UNITY_TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(ref[0]), fc_in[0], rows[i].line, "F_x inside");
                UNITY_TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(ref[2]), fc_in[2], rows[i].line, "F_z inside");
                UNITY_TEST_ASSERT(((fl_in & FW_FLAG_FX_UNOBSERVABLE) != 0u) == (ks[k] == 63), rows[i].line,
                                  "flag on or inside the boundary");
                solve_dir(sgn * (x0 + 1), y, 3 * FW_Q23_ONE, FW_Q23_ONE / 4, fc_out, &fl_out, ref, &unobs);
                UNITY_TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(ref[0]), fc_out[0], rows[i].line, "F_x outside");
                UNITY_TEST_ASSERT_INT32_WITHIN(1, (int32_t)lround(ref[2]), fc_out[2], rows[i].line, "F_z outside");
                UNITY_TEST_ASSERT((fl_out & FW_FLAG_FX_UNOBSERVABLE) != 0u, rows[i].line, "flag outside");
                if (y * sgn >= 1000 || y * sgn <= -1000) {
                    /* one LSB of direction at |y| >= 1000: F_x continuous */
                    UNITY_TEST_ASSERT(abs(fc_in[0] - fc_out[0]) <= 40, rows[i].line, "continuity");
                }
            }
        }
    }
}

static void test_force_dir_zero_vector_is_90_deg_without_flag(void)
{
    int32_t fc[3];
    uint32_t flags;
    double ref[3];
    int unobs;
    solve_dir(0, 0, 2 * FW_Q23_ONE, -FW_Q23_ONE, fc, &flags, ref, &unobs);
    TEST_ASSERT_EQUAL_INT32(0, fc[0]);
    TEST_ASSERT_EQUAL_INT32(-LAT, fc[1]);
    TEST_ASSERT_EQUAL_INT32(2 * KN, fc[2]);
    TEST_ASSERT_EQUAL_UINT32(0u, flags);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_force_solve_pn(&f, 0, 0, 1, 0, NULL, &flags));
}

static void test_force_dir_sweep_matches_double_model(void)
{
    tu_rng_t rng;
    tu_err_t e;
    long i;
    tu_rng_seed(&rng, 32);
    tu_err_init(&e, "force_solve_pn", "pN", 1.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        q23_t sn = tu_rng_range(&rng, -25 * FW_Q23_ONE, 25 * FW_Q23_ONE);
        q23_t sl = tu_rng_range(&rng, -10 * FW_Q23_ONE, 10 * FW_Q23_ONE);
        /* any magnitude up to 2^15, and a third near the lever's axis */
        int sh = (int)(tu_rng_u32(&rng) % 16u);
        int32_t x = tu_rng_range(&rng, -FW_FORCE_DIR_MAX, FW_FORCE_DIR_MAX) >> sh;
        int32_t y = tu_rng_range(&rng, -FW_FORCE_DIR_MAX, FW_FORCE_DIR_MAX) >> sh;
        int32_t fc[3];
        uint32_t flags;
        double ref[3];
        int unobs;
        int k;
        if (i % 3 == 0) {
            y /= 4;
        }
        solve_dir(x, y, sn, sl, fc, &flags, ref, &unobs);
        for (k = 0; k < 3; k++) {
            tu_err_add(&e, fc[k] - ref[k]);
        }
        TEST_ASSERT_EQUAL_INT(unobs, (flags & FW_FLAG_FX_UNOBSERVABLE) != 0u);
    }
    tu_err_print(&e);
    TEST_ASSERT_TRUE(e.worst <= 1.0);
}

static void test_force_dir_fit_keeps_direction_to_2_pow_minus_13(void)
{
    tu_rng_t rng;
    tu_err_t e;
    long i;
    tu_rng_seed(&rng, 33);
    tu_err_init(&e, "force_dir_fit", "rad", 1.0 / 8192.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        int sh = (int)(tu_rng_u32(&rng) % 17u);
        int32_t x0 = (int32_t)tu_rng_u32(&rng) >> sh;
        int32_t y0 = (int32_t)tu_rng_u32(&rng) >> sh;
        int32_t x = x0;
        int32_t y = y0;
        if (x0 == 0 && y0 == 0) {
            continue;
        }
        fw_force_dir_fit(&x, &y);
        TEST_ASSERT_TRUE(x >= -FW_FORCE_DIR_MAX && x <= FW_FORCE_DIR_MAX);
        TEST_ASSERT_TRUE(y >= -FW_FORCE_DIR_MAX && y <= FW_FORCE_DIR_MAX);
        tu_err_add(&e, tu_wrap_pi(atan2((double)y, (double)x) - atan2((double)y0, (double)x0)));
    }
    tu_err_print(&e);
    TEST_ASSERT_TRUE(tu_err_worst_lsb(&e) <= 1.0);
}

/* The fast solver against fw_force_solve_fit_pn at the fast domain's
 * corner (gains 2^18 pN/V, adhesion 2^26 pN, mu 2h/l = 1/2) and for the
 * paper's probe: signals anywhere in +-20 V (with the ends), directions of
 * every length up to 2^15 including the axes, the zero vector and the zone
 * boundaries 15 y^2 = x^2 +- 1, 63 y^2 = x^2 +- 1: identical forces and
 * flags, never FW_FLAG_SAT_FORCE. */
static void test_force_fast_solver_identical_to_checked_at_domain_corner(void)
{
    tu_rng_t rng;
    fw_force_t g[2];
    long i;
    const q23_t s_max = 20 * FW_Q23_ONE;
    tu_rng_seed(&rng, 0xF0F0ull);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_init(&g[0], 1 << 18, 1 << 18, 25000, 100000, 1000000, 1 << 26));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_init(&g[1], KN, LAT, H_NM, L_NM, MU_PPM, ADH));
    TEST_ASSERT_TRUE(g[0].fast && g[1].fast);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        const fw_force_t *ff = &g[i & 1];
        uint32_t pick = tu_rng_u32(&rng) % 8u;
        q23_t sn = (pick == 0u) ? s_max : ((pick == 1u) ? -s_max : tu_rng_range(&rng, -s_max, s_max));
        q23_t sl = (pick == 2u) ? s_max : ((pick == 3u) ? -s_max : tu_rng_range(&rng, -s_max, s_max));
        int sh = (int)(tu_rng_u32(&rng) % 16u);
        int32_t x = tu_rng_range(&rng, -FW_FORCE_DIR_MAX, FW_FORCE_DIR_MAX) >> sh;
        int32_t y = tu_rng_range(&rng, -FW_FORCE_DIR_MAX, FW_FORCE_DIR_MAX) >> sh;
        int32_t fc_c[3];
        int32_t fc_f[3];
        uint32_t fl_c = 0;
        uint32_t fl_f = 0;
        switch (tu_rng_u32(&rng) % 8u) {
        case 0u:   /* on a zone boundary, one LSB either side */
            y = tu_rng_range(&rng, -8000, 8000);
            x = (int32_t)lround(sqrt((tu_rng_u32(&rng) & 1u) ? 15.0 : 63.0) * y) + tu_rng_range(&rng, -1, 1);
            break;
        case 1u:
            x = (tu_rng_u32(&rng) & 1u) ? 0 : x;
            y = (tu_rng_u32(&rng) & 1u) ? 0 : y;
            break;
        default:
            break;
        }
        fw_force_solve_fit_pn(ff, sn, sl, x, y, fc_c, &fl_c);
        fw_force_solve_fast_pn(ff, fw_force_term8(ff->normal_gain_pn_per_v, sn), fw_force_term8(ff->lateral_gain_pn_per_v, sl),
                                   x, y, (int64_t)x * x, (int64_t)y * y, fc_f, &fl_f);
        if (fc_c[0] != fc_f[0] || fc_c[1] != fc_f[1] || fc_c[2] != fc_f[2] || fl_c != fl_f
            || (fl_c & FW_FLAG_SAT_FORCE) != 0u) {
            printf("S_n %ld S_l %ld dir (%ld, %ld)\n", (long)sn, (long)sl, (long)x, (long)y);
            TEST_ASSERT_EQUAL_INT32_ARRAY(fc_c, fc_f, 3);
            TEST_ASSERT_EQUAL_UINT32(fl_c, fl_f);
            TEST_ASSERT_EQUAL_UINT32(0u, fl_c & FW_FLAG_SAT_FORCE);
        }
    }
    printf("SWEEP force fast vs checked n=%ld identical\n", (long)AFM_SWEEP_N);
}

/* ---- theta estimator ------------------------------------------------------ */

static void test_force_lateral_excess_is_friction_free_part_and_never_overflows(void)
{
    fw_force_t g;
    const int32_t slide[3] = { -2500, 0, 20000 };   /* |F_xy| = 0.1 (20 + 5) nN: no excess */
    const int32_t push[3] = { -3600, 0, 20000 };    /* 1.1 nN above the friction */
    const int32_t pull[3] = { 3000, 4000, -9000 };  /* F_z + F_adh < 0: no friction, all of |F_xy| */
    const int32_t huge[3] = { INT32_MIN, INT32_MIN, INT32_MIN };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_force_init(&g, KN, LAT, H_NM, L_NM, 100000, 5000));
    TEST_ASSERT_INT64_WITHIN(1, 0, fw_force_lateral_excess_pn(&g, slide));
    TEST_ASSERT_INT64_WITHIN(1, 1100, fw_force_lateral_excess_pn(&g, push));
    TEST_ASSERT_EQUAL_INT64(5000, fw_force_lateral_excess_pn(&g, pull));
    /* |F_xy| = 2^31 sqrt2, no friction (F_z + F_adh < 0) */
    TEST_ASSERT_EQUAL_INT64(3037000499LL, fw_force_lateral_excess_pn(&g, huge));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_force_init_rejects_bad_probe);
    RUN_TEST(test_force_cot_theta_45_deg_gives_fx_equal_fy);
    RUN_TEST(test_force_cot_theta_90_deg_gives_zero_fx);
    RUN_TEST(test_force_cot_theta_at_0_and_pi_uses_friction_fallback);
    RUN_TEST(test_force_friction_fallback_opposes_motion_along_lever);
    RUN_TEST(test_force_sweep_through_0_and_pi_is_continuous);
    RUN_TEST(test_force_saturates_exactly_with_flag);
    RUN_TEST(test_force_rotate_scan_angle_0_maps_c_to_a_by_minus_270);
    RUN_TEST(test_force_dir_zones_at_one_eighth_and_one_quarter_and_one_lsb_either_side);
    RUN_TEST(test_force_dir_zero_vector_is_90_deg_without_flag);
    RUN_TEST(test_force_dir_sweep_matches_double_model);
    RUN_TEST(test_force_dir_fit_keeps_direction_to_2_pow_minus_13);
    RUN_TEST(test_force_fast_solver_identical_to_checked_at_domain_corner);
    RUN_TEST(test_force_lateral_excess_is_friction_free_part_and_never_overflows);
    return UNITY_END();
}
