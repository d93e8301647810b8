/* test_board16.c - fw_board16, the 16-bit signal chain: its domain rules,
 * its error contract against the double model of the same equations fed
 * the same ADC codes (worst 0.5 % and RMS 0.05 % of k_n K_n 10 V over
 * friction loops in every direction, the blend zone included, at two scan
 * angles and two ADC widths), the flags at the rails, the apex at the int32
 * ends, the fallback's clamp, and the codes equal to the 32-bit chain's. */
#include <string.h>
#include "unity.h"
#include "fw_board16.h"
#include "fw_paper_probe.h"
#include "test_util.h"

static fw_board_config_t cfg;
static fw_board16_t b;

void setUp(void)
{
    fw_paper_board_config(&cfg, 270000);
    cfg.adhesion_pn = 5000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_init(&b, &cfg));
}
void tearDown(void) {}

static void test_board16_domain_rules(void)
{
    fw_board16_t x;
    struct { int line; int field; int32_t value; fw_rule_t rule; } rows[] = {
        { __LINE__, 0, 104857, FW_RULE_OK },              /* 2^20 pN at 10 V, rounded down */
        { __LINE__, 0, 104858, FW_RULE_WORD16_RANGE },
        { __LINE__, 1, 104858, FW_RULE_WORD16_RANGE },
        { __LINE__, 2, 2097152, FW_RULE_OK },              /* C = 2^21 pm/V */
        { __LINE__, 2, 2097153, FW_RULE_WORD16_RANGE },
        { __LINE__, 3, 1 << 26, FW_RULE_OK },
        { __LINE__, 3, (1 << 26) + 1, FW_RULE_WORD16_RANGE },
        { __LINE__, 4, 16383, FW_RULE_OK },                /* the window's minimum below 2^14 pm */
        { __LINE__, 4, 16384, FW_RULE_WORD16_RANGE },
        { __LINE__, 5, 1, FW_RULE_ADC_FILTER },            /* no ADC filter on this path */
        { __LINE__, 6, 7, FW_RULE_ADC_BITS },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        fw_board_config_t c;
        fw_paper_board_config(&c, 300000);
        switch (rows[i].field) {
        case 0: c.normal_gain_pn_per_v = rows[i].value; break;
        case 1: c.lateral_gain_pn_per_v = rows[i].value; break;
        case 2: c.disp_l_pm_per_v = rows[i].value; break;
        case 3: c.adhesion_pn = rows[i].value; break;
        case 4: c.theta_min_disp_pm = rows[i].value; break;
        case 5: c.filter_log2 = rows[i].value; break;
        default: c.adc_bits = rows[i].value; break;
        }
        UNITY_TEST_ASSERT_EQUAL_INT(rows[i].rule, fw_board16_check(&c), rows[i].line, "rule");
        UNITY_TEST_ASSERT_EQUAL_INT(fw_rule_status(rows[i].rule), fw_board16_init(&x, &c), rows[i].line, "status");
    }
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board16_init(NULL, &cfg));
    TEST_ASSERT_EQUAL_INT(FW_RULE_NULL_POINTER, fw_board16_check(NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board16_step_block(&b, NULL, NULL, 1));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, NULL, NULL, 0));
}

/* The double model of the chain (physics.md sections 1, 3, 4 with the blend
 * of fw_force.h), fed the signals of the ADC codes: the apex, the window's
 * direction over FW_THETA_WINDOW samples, eq. 1-3. */
typedef struct {
    double ax[FW_THETA_WINDOW];
    double ay[FW_THETA_WINDOW];
    int n;
    double dir_c, dir_s;
    int known;
} ref_t;

static double ref_volts(int32_t bits, int32_t uv)
{
    return fw_acq_quantize_code(bits, uv, NULL) * 20.0 / TU_TWO_POW(bits);
}

static void ref_step(ref_t *r, const fw_board_config_t *c, const fw_sample_in_t *in, double f_a[3])
{
    double al = (c->scan_angle_mdeg - 270000) * 1e-3 * TU_PI / 180.0;
    double sn = ref_volts(c->adc_bits, in->sn_uv);
    double sl = ref_volts(c->adc_bits, in->sl_uv);
    double ox = c->disp_n_pm_per_v * sn;
    double oy = c->disp_l_pm_per_v * sl;
    double ax = in->piezo_pm[0] + cos(al) * ox - sin(al) * oy;
    double ay = in->piezo_pm[1] + sin(al) * ox + cos(al) * oy;
    double g = 2.0 * c->tip_height_nm / c->lever_length_nm;
    double mu = c->mu_ppm * 1e-6;
    double fy = c->lateral_gain_pn_per_v * sl;
    double n = c->normal_gain_pn_per_v * sn;
    double fx = 0.0;
    int slot = r->n % FW_THETA_WINDOW;
    int oldest = (r->n < FW_THETA_WINDOW) ? 0 : (r->n + 1) % FW_THETA_WINDOW;
    double dx;
    double dy;
    r->ax[slot] = ax;
    r->ay[slot] = ay;
    dx = ax - r->ax[oldest];
    dy = ay - r->ay[oldest];
    r->n++;
    if (dx * dx + dy * dy >= 1000.0 * 1000.0) {
        double len = sqrt(dx * dx + dy * dy);
        double cxa = dx / len;
        double cya = dy / len;
        r->dir_c = cos(al) * cxa + sin(al) * cya;   /* into frame C */
        r->dir_s = cos(al) * cya - sin(al) * cxa;
        r->known = 1;
    }
    if (r->known) {
        double as = fabs(r->dir_s);
        if (as >= 0.125) {
            fx = fy * r->dir_c / r->dir_s;
        }
        if (as < 0.25) {
            double mc = mu * r->dir_c;
            double fb = -mc * (n + c->adhesion_pn) / (1.0 - mc * g);
            double w = (as - 0.125) / 0.125;
            fx = (as < 0.125) ? fb : w * fx + (1.0 - w) * fb;
        }
    }
    f_a[0] = cos(al) * fx - sin(al) * fy;
    f_a[1] = sin(al) * fx + cos(al) * fy;
    f_a[2] = n - g * fx;
}

/* Friction loops: the piezo walks along theta_a (frame A) at 0.5 nm per
 * sample while the sample pushes back with friction F_par against the
 * motion and a load F_z; S_n, S_l from eq. 1 inverted. */
static void signals(const fw_board_config_t *c, double th_c, double fpar, double fz, int32_t *sn_uv,
                    int32_t *sl_uv)
{
    double g = 2.0 * c->tip_height_nm / c->lever_length_nm;
    double fx = -fpar * cos(th_c);
    double fy = -fpar * sin(th_c);
    *sl_uv = (int32_t)lround(fy / c->lateral_gain_pn_per_v * 1e6);
    *sn_uv = (int32_t)lround((fz + g * fx) / c->normal_gain_pn_per_v * 1e6);
}

static void test_board16_error_contract_against_the_double_model(void)
{
    static const int32_t angles[] = { 270000, 300000 };
    static const int32_t widths[] = { 16, 12 };
    long trials = AFM_SWEEP_N / 200;
    tu_rng_t r;
    tu_err_t e;
    long t;
    double fs;
    tu_rng_seed(&r, 1616);
    for (t = 0; t < trials; t++) {
        fw_board_config_t c;
        ref_t ref;
        double th_c;
        double th_a;
        double fpar = 500.0 + 20000.0 * tu_rng_unit(&r);
        double fz = -5000.0 + 60000.0 * tu_rng_unit(&r);
        double al;
        int32_t sn;
        int32_t sl;
        int i;
        fw_paper_board_config(&c, angles[t % 2]);
        c.adc_bits = widths[(t / 2) % 2];
        c.adhesion_pn = 5000;
        if (t == 0) {
            fs = c.normal_gain_pn_per_v * 10.0;
            tu_err_init(&e, "board16_force_vs_double", "pN", 1.0);
        }
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_init(&b, &c));
        memset(&ref, 0, sizeof ref);
        /* 40 % of the directions near the lever's axis (fallback and blend) */
        th_c = (tu_rng_unit(&r) < 0.4) ? ((tu_rng_unit(&r) < 0.5 ? 0.0 : TU_PI) + 0.5 * (tu_rng_unit(&r) - 0.5))
                                        : 2.0 * TU_PI * tu_rng_unit(&r);
        al = (c.scan_angle_mdeg - 270000) * 1e-3 * TU_PI / 180.0;
        th_a = th_c + al;
        signals(&c, th_c, fpar, fz, &sn, &sl);
        for (i = 0; i < 48; i++) {
            fw_sample_in_t in;
            fw_sample_out_t out;
            double f[3];
            in.sn_uv = sn;
            in.sl_uv = sl;
            in.piezo_pm[0] = 2000000 + (int32_t)lround(i * 500.0 * cos(th_a));
            in.piezo_pm[1] = -1000000 + (int32_t)lround(i * 500.0 * sin(th_a));
            in.piezo_pm[2] = 0;
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, &in, &out, 1));
            ref_step(&ref, &c, &in, f);
            if (i >= FW_THETA_WINDOW + 2) {   /* the direction is known in both */
                double d = sqrt((out.force_pn[0] - f[0]) * (out.force_pn[0] - f[0])
                                + (out.force_pn[1] - f[1]) * (out.force_pn[1] - f[1])
                                + (out.force_pn[2] - f[2]) * (out.force_pn[2] - f[2]));
                tu_err_add(&e, d);
            }
        }
    }
    tu_err_print(&e);
    printf("board16: worst %.4f %% of full scale (%.0f pN), RMS %.4f %%\n", 100.0 * e.worst / fs, fs,
           100.0 * sqrt(e.sum2 / (double)e.n) / fs);
    TEST_ASSERT_TRUE(e.worst <= 0.005 * fs);
    TEST_ASSERT_TRUE(sqrt(e.sum2 / (double)e.n) <= 0.0005 * fs);
}

static void test_board16_rails_flags_and_codes_equal_the_32_bit_chain(void)
{
    static const int32_t uvs[] = { 10000000, 10000001, INT32_MAX, 9999999, -10000000, INT32_MIN, 0, 153, -152 };
    fw_board_t b32;
    size_t i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b32, &cfg));
    for (i = 0; i < sizeof uvs / sizeof uvs[0]; i++) {
        /* each value on S_n with S_l at 0, then on S_l with S_n at 0 */
        fw_sample_in_t in[2] = { { uvs[i], 0, { 0, 0, 0 } }, { 0, uvs[i], { 0, 0, 0 } } };
        fw_sample_out_t o16[2];
        fw_sample_out_t o32[2];
        bool rail = uvs[i] >= 10000000 || uvs[i] <= -10000000;
        int k;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, in, o16, 2));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b32, in, o32, 2));
        for (k = 0; k < 2; k++) {
            TEST_ASSERT_EQUAL_INT32(o32[k].sn_code, o16[k].sn_code);
            TEST_ASSERT_EQUAL_INT32(o32[k].sl_code, o16[k].sl_code);
        }
        TEST_ASSERT_EQUAL(rail, (o16[0].flags & FW_FLAG_SAT_SN) != 0u);
        TEST_ASSERT_EQUAL(rail, (o16[1].flags & FW_FLAG_SAT_SL) != 0u);
        TEST_ASSERT_EQUAL_UINT32(0u, o16[0].flags & FW_FLAG_SAT_SL);
    }
    /* a 10-bit ADC: its codes, as 1.15 of 10 V inside */
    cfg.adc_bits = 10;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_init(&b, &cfg));
    {
        fw_sample_in_t in = { 5000000, -2500000, { 0, 0, 0 } };
        fw_sample_out_t o;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, &in, &o, 1));
        TEST_ASSERT_EQUAL_INT32(256, o.sn_code);
        TEST_ASSERT_EQUAL_INT32(-128, o.sl_code);
        TEST_ASSERT_INT32_WITHIN(20, 53400, o.force_pn[2]);   /* k_n K_n 5 V, no direction yet */
    }
}

static void test_board16_standing_tip_unknown_direction_and_finite(void)
{
    fw_sample_in_t in = { 3000000, 1000000, { 100, 200, 0 } };
    fw_sample_out_t out;
    int i;
    for (i = 0; i < 40; i++) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, &in, &out, 1));
        TEST_ASSERT_TRUE((out.flags & FW_FLAG_THETA_UNKNOWN) != 0u);
        TEST_ASSERT_EQUAL_INT32(0, out.force_pn[0]);   /* F_x = 0 across the lever */
    }
    TEST_ASSERT_INT32_WITHIN(12, FW_PAPER_LATERAL_GAIN_PN_PER_V, out.force_pn[1]);
    fw_board16_reset(&b);
    TEST_ASSERT_FALSE(b.known);
}

static void test_board16_apex_at_the_int32_ends_saturates_with_flag(void)
{
    /* a piezo at INT32_MAX with a positive bending offset, and a jump across
     * the whole int32 range between two samples: no overflow, flags */
    fw_sample_in_t in = { 5000000, 5000000, { INT32_MAX, INT32_MIN, 0 } };
    fw_sample_out_t out;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, &in, &out, 1));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, out.tip_pm[0]);
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_POS) != 0u);
    in.piezo_pm[0] = INT32_MIN;
    in.piezo_pm[1] = INT32_MAX - 200000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, &in, &out, 1));
    TEST_ASSERT_TRUE(b.known);   /* a move of 2^32 pm is a direction */
    TEST_ASSERT_TRUE(b.cx < 0 && b.cy > 0);
}

static void test_board16_fallback_clamp_is_flagged(void)
{
    /* mu 0.5, adhesion 2^26 pN: mu (N + F_adh) = 33.6 uN passes the
     * fallback's 131 nN clamp while the tip moves along the lever */
    fw_sample_in_t in;
    fw_sample_out_t out;
    int i;
    uint32_t flags = 0;
    cfg.mu_ppm = 500000;
    cfg.tip_height_nm = 10000;
    cfg.adhesion_pn = 1 << 26;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_init(&b, &cfg));
    for (i = 0; i < 40; i++) {
        in.sn_uv = 1000000;
        in.sl_uv = 0;
        in.piezo_pm[0] = i * 2000;
        in.piezo_pm[1] = 0;
        in.piezo_pm[2] = 0;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board16_step_block(&b, &in, &out, 1));
        flags |= out.flags;
    }
    TEST_ASSERT_TRUE((flags & FW_FLAG_SAT_FORCE) != 0u);
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_FX_UNOBSERVABLE) != 0u);
    /* F_x = -131071 pN / (1 - mu 2h/l) = -145.6 nN at the clamp (opposing +x) */
    TEST_ASSERT_INT32_WITHIN(300, -145634, out.force_pn[0]);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_board16_domain_rules);
    RUN_TEST(test_board16_error_contract_against_the_double_model);
    RUN_TEST(test_board16_rails_flags_and_codes_equal_the_32_bit_chain);
    RUN_TEST(test_board16_standing_tip_unknown_direction_and_finite);
    RUN_TEST(test_board16_apex_at_the_int32_ends_saturates_with_flag);
    RUN_TEST(test_board16_fallback_clamp_is_flagged);
    return UNITY_END();
}
