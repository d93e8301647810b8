/* test_board.c - fw_board: one sample through acquisition, force and
 * compensation; frame invariance; saturation; virtual S_n. */
#include <string.h>
#include "unity.h"
#include "fw_board.h"
#include "fw_paper_probe.h"
#include "fw_math.h"
#include "test_util.h"

static fw_board_config_t cfg;
static fw_board_t b;

/* The paper's lever (fw_paper_probe.h) at 270 deg, adhesion 5 nN, the
 * joystick's centre at (45, 45) um. */
static void paper_config(fw_board_config_t *c)
{
    fw_paper_board_config(c, 270000);
    c->adhesion_pn = 5000;
    c->scan_center_pm[0] = 45000000;
    c->scan_center_pm[1] = 45000000;
}

void setUp(void)
{
    paper_config(&cfg);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &cfg));
}
void tearDown(void) {}

static void test_board_init_validates_config(void)
{
    fw_board_t x;
    fw_board_config_t c;
    paper_config(&c);
    c.adc_bits = 7;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.deflection_pm_per_v = 0;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.lateral_gain_pn_per_v = -5;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.disp_n_pm_per_v = -5;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.filter_log2 = 9;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, &c));
    paper_config(&c);
    c.tip_height_nm = c.lever_length_nm;
    TEST_ASSERT_EQUAL_INT(FW_ERR_DOMAIN, fw_board_init(&x, &c));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(NULL, &c));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_init(&x, NULL));
    paper_config(&c);
    c.scan_angle_mdeg = INT32_MIN;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&x, &c));
}

/* signals (uV) that a force F_A on a tip moving along dir_A would produce
 * at scan angle scan_deg, using the documented model backwards */
static void signals_for(double scan_deg, double fa_x, double fa_y, double fz,
                        int32_t *sn_uv, int32_t *sl_uv)
{
    double a = (scan_deg - 270.0) * TU_PI / 180.0;
    double fcx = cos(a) * fa_x + sin(a) * fa_y;
    double fcy = -sin(a) * fa_x + cos(a) * fa_y;
    double g = 2.0 * cfg.tip_height_nm / cfg.lever_length_nm;
    *sl_uv = (int32_t)lround(fcy / cfg.lateral_gain_pn_per_v * 1e6);
    *sn_uv = (int32_t)lround((fz + g * fcx) / cfg.normal_gain_pn_per_v * 1e6);
}

static void test_board_same_push_same_frame_a_force_at_every_scan_angle(void)
{
    /* friction on a tip moving at 30 deg in frame A, load 20 nN:
     * |F_par| = mu (F_z + F_adh) so the cot path and the fallback agree */
    static const double scans[] = { 0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0,
                                    17.5, 300.123, 240.0, 60.0 };
    const double dir = 30.0 * TU_PI / 180.0;
    const double fz = 20000.0;
    const double fpar = 0.0865 * (fz + 5000.0);
    const double fax = -fpar * cos(dir);
    const double fay = -fpar * sin(dir);
    size_t k;
    double worst = 0.0;
    for (k = 0; k < sizeof scans / sizeof scans[0]; k++) {
        fw_sample_in_t in;
        fw_sample_out_t out;
        int i;
        cfg.scan_angle_mdeg = (int32_t)lround(scans[k] * 1000.0);
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &cfg));
        signals_for(scans[k], fax, fay, fz, &in.sn_uv, &in.sl_uv);
        for (i = 0; i < 40; i++) {
            in.piezo_pm[0] = (int32_t)lround(200.0 * i * cos(dir));
            in.piezo_pm[1] = (int32_t)lround(200.0 * i * sin(dir));
            in.piezo_pm[2] = 0;
            TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
        }
        TEST_ASSERT_EQUAL_UINT32(0u, out.flags & ~FW_FLAG_FX_UNOBSERVABLE);
        TEST_ASSERT_INT32_WITHIN(100, (int32_t)lround(fax), out.force_pn[0]);
        TEST_ASSERT_INT32_WITHIN(100, (int32_t)lround(fay), out.force_pn[1]);
        TEST_ASSERT_INT32_WITHIN(40, (int32_t)lround(fz), out.force_pn[2]);
        if (fabs(out.force_pn[0] - fax) > worst) {
            worst = fabs(out.force_pn[0] - fax);
        }
        if (fabs(out.force_pn[1] - fay) > worst) {
            worst = fabs(out.force_pn[1] - fay);
        }
    }
    printf("frame invariance: worst lateral error %.1f pN of %.1f pN (16-bit ADC)\n", worst, fpar);
}

static void test_board_sn_past_10v_flags_and_uses_virtual_sn(void)
{
    fw_sample_in_t in = { 5000000, 0, { 0, 0, 0 } };
    fw_sample_out_t out;
    /* saturated before any reference: no virtual output */
    fw_sample_in_t first = { 12000000, 0, { 0, 0, 0 } };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &first, &out));
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_SN) != 0u);
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_VIRTUAL_SN) == 0u);
    TEST_ASSERT_EQUAL_INT32(32767, out.sn_code);
    /* 5 V at z = 0, then 1 um further down, saturated */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_UINT32(0u, out.flags & FW_FLAG_SAT_SN);
    in.sn_uv = 10000000;   /* exactly at the rail counts as saturated */
    in.piezo_pm[2] = -1000000;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_TRUE((out.flags & (FW_FLAG_SAT_SN | FW_FLAG_VIRTUAL_SN)) == (FW_FLAG_SAT_SN | FW_FLAG_VIRTUAL_SN));
    /* S_n' = 5 V + 1000/89 V. The bending offset moved the apex by
     * +C_n dS_n along x_C: theta = 0, friction fallback against the motion
     * F_x = -mu (N + F_adh) / (1 - mu 2h/l), F_z = N - (2h/l) F_x */
    {
        double n = 10680.0 * (5.0 + 1000.0 / 89.0);
        double g = 2.0 * 17300.0 / 100000.0;
        double fx = -0.0865 * (n + 5000.0) / (1.0 - 0.0865 * g);
        TEST_ASSERT_INT32_WITHIN(4, (int32_t)lround(fx), out.force_pn[0]);
        TEST_ASSERT_INT32_WITHIN(4, (int32_t)lround(n - g * fx), out.force_pn[2]);
    }
    /* the apex uses S_n' too: x offset +C_n S_n' */
    TEST_ASSERT_INT32_WITHIN(2, (int32_t)lround(23100.0 * (5.0 + 1000.0 / 89.0)), out.tip_pm[0]);
    TEST_ASSERT_EQUAL_UINT32(2u, fw_board_sat_count(&b, FW_FLAG_SAT_SN));
    TEST_ASSERT_TRUE((fw_board_sticky_flags(&b) & FW_FLAG_VIRTUAL_SN) != 0u);
    fw_board_reset(&b);
    TEST_ASSERT_EQUAL_UINT32(0u, fw_board_sat_count(&b, FW_FLAG_SAT_SN));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_board_sticky_flags(&b));
}

static void test_board_sl_at_just_past_far_past_rail_flags(void)
{
    static const struct { int line; int32_t uv; int32_t code; bool sat; } rows[] = {
        { __LINE__, 9999999, 32767, false },
        { __LINE__, 10000000, 32767, true },
        { __LINE__, 10000001, 32767, true },
        { __LINE__, INT32_MAX, 32767, true },
        { __LINE__, -9999999, -32768, false },
        { __LINE__, -10000000, -32768, true },
        { __LINE__, INT32_MIN, -32768, true },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        fw_sample_in_t in = { 0, rows[i].uv, { 0, 0, 0 } };
        fw_sample_out_t out;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
        UNITY_TEST_ASSERT_EQUAL_INT32(rows[i].code, out.sl_code, rows[i].line, "code");
        UNITY_TEST_ASSERT(((out.flags & FW_FLAG_SAT_SL) != 0u) == rows[i].sat, rows[i].line, "flag");
    }
    TEST_ASSERT_EQUAL_UINT32(5u, fw_board_sat_count(&b, FW_FLAG_SAT_SL));
}

static void test_board_zero_length_moves_stay_finite_theta_unknown(void)
{
    fw_sample_in_t in = { 3000000, 1000000, { 100, 200, 0 } };
    fw_sample_out_t out;
    int i;
    for (i = 0; i < 50; i++) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    }
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_THETA_UNKNOWN) != 0u);
    /* theta 90 deg: F_x = 0, F_y = lat S_l */
    TEST_ASSERT_EQUAL_INT32(0, out.force_pn[0]);
    TEST_ASSERT_INT32_WITHIN(12, 37900, out.force_pn[1]);
}

static void test_board_piezo_cmd_puts_apex_at_joystick_target(void)
{
    fw_sample_in_t in = { 4000000, -2000000, { 45000000, 45000000, 0 } };
    fw_sample_out_t out;
    int32_t joy[2] = { 16384, -32768 };
    int32_t cmd[2];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_piezo_cmd(&b, joy, cmd));
    in.piezo_pm[0] = cmd[0];
    in.piezo_pm[1] = cmd[1];
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_INT32_WITHIN(1, 45000000 + 1250000, out.tip_pm[0]);
    TEST_ASSERT_INT32_WITHIN(1, 45000000 - 2500000, out.tip_pm[1]);
    joy[0] = 40000;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_piezo_cmd(&b, joy, cmd));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_piezo_cmd(&b, NULL, cmd));
}

static void test_board_baseline_removes_offset(void)
{
    fw_sample_in_t in = { 500000, -300000, { 0, 0, 0 } };
    fw_sample_out_t out;
    TEST_ASSERT_EQUAL_INT(FW_ERR_STATE, fw_board_record_baseline(&b));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_record_baseline(&b));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_EQUAL_INT32(0, out.force_pn[1]);
    TEST_ASSERT_EQUAL_INT32(0, out.force_pn[2]);
}

static void test_board_force_saturates_with_flag_and_counter(void)
{
    fw_board_config_t c;
    fw_sample_in_t in = { 9000000, 9000000, { 0, 0, 0 } };
    fw_sample_out_t out;
    paper_config(&c);
    c.normal_gain_pn_per_v = INT32_MAX;
    c.lateral_gain_pn_per_v = INT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &c));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_TRUE((out.flags & FW_FLAG_SAT_FORCE) != 0u);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, out.force_pn[2]);
    TEST_ASSERT_EQUAL_UINT32(1u, fw_board_sat_count(&b, FW_FLAG_SAT_FORCE));
}

/* ---- fast path ------------------------------------------------------------ */

/* The fast path's domain at its edges (fw_board.h): the path init selects. */
static void test_board_fast_path_selected_at_the_domain_edges(void)
{
    static const struct {
        int line;
        int32_t kn, lat, adh, cn, cl, filter, scan_mdeg;
        fw_board_path_t path;
    } rows[] = {
        { __LINE__, 10680, 37900, 5000, 23100, 23100, 0, 270000, FW_BOARD_PATH_FAST_ALIGNED },
        { __LINE__, 10680, 37900, 5000, 23100, 23100, 0, 630000, FW_BOARD_PATH_FAST_ALIGNED },
        { __LINE__, 10680, 37900, 5000, 23100, 23100, 0, -90000, FW_BOARD_PATH_FAST_ALIGNED },
        { __LINE__, 10680, 37900, 5000, 23100, 23100, 0, 270001, FW_BOARD_PATH_FAST },
        { __LINE__, 10680, 37900, 5000, 23100, 23100, 0, 300000, FW_BOARD_PATH_FAST },
        { __LINE__, 10680, 37900, 5000, 23100, 23100, 0, 90000, FW_BOARD_PATH_FAST },
        { __LINE__, 1 << 18, 1 << 18, 1 << 26, 1 << 21, 1 << 21, 0, 270000, FW_BOARD_PATH_FAST_ALIGNED },
        { __LINE__, (1 << 18) + 1, 37900, 5000, 23100, 23100, 0, 270000, FW_BOARD_PATH_CHECKED },
        { __LINE__, 10680, (1 << 18) + 1, 5000, 23100, 23100, 0, 270000, FW_BOARD_PATH_CHECKED },
        { __LINE__, 10680, 37900, (1 << 26) + 1, 23100, 23100, 0, 270000, FW_BOARD_PATH_CHECKED },
        { __LINE__, 10680, 37900, 5000, (1 << 21) + 1, 23100, 0, 270000, FW_BOARD_PATH_CHECKED },
        { __LINE__, 10680, 37900, 5000, 23100, (1 << 21) + 1, 0, 300000, FW_BOARD_PATH_CHECKED },
        { __LINE__, 10680, 37900, 5000, 23100, 23100, 1, 270000, FW_BOARD_PATH_CHECKED },
        { __LINE__, 10680, 37900, 0, 0, 0, 0, 270000, FW_BOARD_PATH_FAST_ALIGNED },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        fw_board_config_t c;
        fw_board_t x;
        paper_config(&c);
        c.normal_gain_pn_per_v = rows[i].kn;
        c.lateral_gain_pn_per_v = rows[i].lat;
        c.adhesion_pn = rows[i].adh;
        c.disp_n_pm_per_v = rows[i].cn;
        c.disp_l_pm_per_v = rows[i].cl;
        c.filter_log2 = rows[i].filter;
        c.scan_angle_mdeg = rows[i].scan_mdeg;
        UNITY_TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&x, &c), rows[i].line, "init");
        UNITY_TEST_ASSERT_EQUAL_INT(rows[i].path, x.path_cfg, rows[i].line, "path");
        /* the checked path until a sample has been stepped */
        UNITY_TEST_ASSERT_EQUAL_UINT32(0u, x.fast_span_uv, rows[i].line, "span after init");
    }
}

/* A configuration for the sweep, kind 0..5: the paper's lever (0..2), or
 * the fast domain's corner (3..5: every bound at its limit, mu as large as
 * init allows); a scan angle of 270 deg (aligned), a random one, or a
 * quadrant. */
static void sweep_config(tu_rng_t *r, uint32_t kind, fw_board_config_t *c)
{
    paper_config(c);
    if (kind >= 3u) {
        c->normal_gain_pn_per_v = 1 << 18;
        c->lateral_gain_pn_per_v = 1 << 18;
        c->adhesion_pn = 1 << 26;
        c->disp_n_pm_per_v = 1 << 21;
        c->disp_l_pm_per_v = 1 << 21;
        c->mu_ppm = 1000000;
        c->tip_height_nm = 25000;   /* 2h/l = 1/2: mu 2h/l = 1/2 */
    }
    switch (kind % 3u) {
    case 0u:
        c->scan_angle_mdeg = 270000;
        break;
    case 1u:
        c->scan_angle_mdeg = tu_rng_range(r, -720000, 720000);
        break;
    default:
        c->scan_angle_mdeg = 90000 * tu_rng_range(r, 0, 3);
        break;
    }
    c->adc_bits = (tu_rng_u32(r) % 4u == 0u) ? 12 + 2 * tu_rng_range(r, 0, 1) : 16;
    c->theta_min_disp_pm = tu_rng_range(r, 0, 3000);
}

/* An input near a boundary the fast path must leave to the checked one. */
static int32_t sweep_edge_uv(tu_rng_t *r, const fw_board_t *x)
{
    int32_t top = x->acq_sn.fast_lo_uv + (int32_t)x->acq_sn.fast_span_uv;   /* first clamped */
    switch (tu_rng_u32(r) % 8u) {
    case 0u: return 10000000;
    case 1u: return -10000000;
    case 2u: return 9999999;
    case 3u: return -9999999;
    case 4u: return top - 1;
    case 5u: return top;
    case 6u: return (tu_rng_u32(r) & 1u) ? INT32_MAX : INT32_MIN;
    default: return tu_rng_range(r, -30000000, 30000000);
    }
}

static void assert_boards_identical(const fw_board_t *f, const fw_board_t *c, const fw_sample_out_t *of,
                                    const fw_sample_out_t *oc, long i)
{
    int k;
    bool same = memcmp(of, oc, sizeof *of) == 0
                && f->sn_v == c->sn_v && f->sl_v == c->sl_v && f->z_pm == c->z_pm
                && f->sn_ref_v == c->sn_ref_v && f->z_ref_pm == c->z_ref_pm
                && f->have_ref == c->have_ref && f->ref_live == c->ref_live
                && f->stepped == c->stepped && f->fast_span_uv == c->fast_span_uv
                && f->sticky_flags == c->sticky_flags && f->sat_force_count == c->sat_force_count
                && f->acq_sn.last_v == c->acq_sn.last_v && f->acq_sl.last_v == c->acq_sl.last_v
                && f->acq_sn.sat_count == c->acq_sn.sat_count && f->acq_sl.sat_count == c->acq_sl.sat_count
                && f->acq_sn.sat_sticky == c->acq_sn.sat_sticky && f->acq_sl.sat_sticky == c->acq_sl.sat_sticky
                && f->theta.pos == c->theta.pos && f->theta.fill == c->theta.fill
                && f->theta.dir_x == c->theta.dir_x && f->theta.dir_y == c->theta.dir_y
                && f->theta.known == c->theta.known;
    for (k = 0; k < FW_THETA_WINDOW; k++) {
        same = same && f->theta.x_pm[k] == c->theta.x_pm[k] && f->theta.y_pm[k] == c->theta.y_pm[k];
    }
    if (!same) {
        printf("sample %ld: fast F = (%ld, %ld, %ld) flags 0x%lx, checked F = (%ld, %ld, %ld) flags 0x%lx\n", i,
               (long)of->force_pn[0], (long)of->force_pn[1], (long)of->force_pn[2], (unsigned long)of->flags,
               (long)oc->force_pn[0], (long)oc->force_pn[1], (long)oc->force_pn[2], (unsigned long)oc->flags);
        TEST_FAIL_MESSAGE("fast and checked paths differ");
    }
}

/* The samples waiting for fw_board_step_block in the sweep below, with
 * the checked path's outputs for them. */
#define SWEEP_BLOCK_MAX 64
typedef struct {
    fw_sample_in_t in[SWEEP_BLOCK_MAX];
    fw_sample_out_t oc[SWEEP_BLOCK_MAX];
    fw_sample_out_t og[SWEEP_BLOCK_MAX];
    size_t n;
    size_t target;
    long blocks;
} sweep_block_t;

/* Step g over the waiting samples in one fw_board_step_block and compare
 * every output with the checked path's, and g's state with c's (c has
 * stepped the same samples). The next block's length is drawn from rb
 * (1..SWEEP_BLOCK_MAX). */
static void sweep_block_flush(sweep_block_t *q, fw_board_t *g, const fw_board_t *c, tu_rng_t *rb, long i)
{
    size_t k;
    if (q->n > 0) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(g, q->in, q->og, q->n));
        for (k = 0; k + 1 < q->n; k++) {
            if (memcmp(&q->og[k], &q->oc[k], sizeof q->og[k]) != 0) {
                printf("block ending at sample %ld: output %lu of %lu differs\n", i, (unsigned long)k,
                       (unsigned long)q->n);
                TEST_FAIL_MESSAGE("fw_board_step_block and the checked path differ");
            }
        }
        assert_boards_identical(g, c, &q->og[q->n - 1], &q->oc[q->n - 1], i);
        q->blocks++;
    }
    q->n = 0;
    q->target = 1u + tu_rng_u32(rb) % SWEEP_BLOCK_MAX;
}

/* The three boards of the sweep below: f steps on fw_board_step (fast path
 * wherever it is open), c on fw_board_step_checked, g in blocks
 * (fw_board_step_block). */
typedef struct {
    fw_board_t f;
    fw_board_t c;
    fw_board_t g;
} sweep_boards_t;

/* The sweep's walk of the tip and its signals: where the piezo is, where it
 * heads and how fast, and the photodiode's slow signals and their noise. */
typedef struct {
    double x;
    double y;
    double heading;
    double turn;
    double speed;
    int32_t z;
    int32_t sn_uv;
    int32_t sl_uv;
    int32_t noise_uv;
} sweep_walk_t;

/* How often the fast path ran, and in which of its branches. */
typedef struct {
    long fast;
    long aligned;
    long unobs;
    long pos;
    long unknown;
    long far;
} sweep_counts_t;

/* A new segment: the three boards on a configuration of kind `kind` with
 * one baseline, the piezo somewhere in its range, a noise level. */
static void sweep_segment_start(tu_rng_t *r, uint32_t kind, sweep_boards_t *b, sweep_walk_t *w)
{
    fw_board_config_t cfg_i;
    q23_t base_n = tu_rng_range(r, -10 * FW_Q23_ONE, 10 * FW_Q23_ONE);
    q23_t base_l = tu_rng_range(r, -10 * FW_Q23_ONE, 10 * FW_Q23_ONE);
    sweep_config(r, kind, &cfg_i);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b->f, &cfg_i));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b->c, &cfg_i));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b->g, &cfg_i));
    TEST_ASSERT_TRUE(b->f.path_cfg != FW_BOARD_PATH_CHECKED);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&b->f.acq_sn, base_n));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&b->c.acq_sn, base_n));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&b->g.acq_sn, base_n));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&b->f.acq_sl, base_l));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&b->c.acq_sl, base_l));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_acq_set_baseline_q23(&b->g.acq_sl, base_l));
    w->x = tu_rng_range(r, -2000000000, 2000000000);
    w->y = tu_rng_range(r, -2000000000, 2000000000);
    /* mostly a few mV (the apex then moves by the piezo's step),
     * sometimes volts (it jumps by microns with C at 2^21 pm/V) */
    w->noise_uv = (tu_rng_u32(r) % 4u == 0u) ? tu_rng_range(r, 0, 3000000) : tu_rng_range(r, 0, 3000);
}

/* A new leg of the walk: straight, curving, or along the lever. */
static void sweep_leg(tu_rng_t *r, const fw_board_t *f, sweep_walk_t *w)
{
    uint32_t kind = tu_rng_u32(r) % 3u;
    double alpha = (f->cfg.scan_angle_mdeg - 270000) * 1e-3 * TU_PI / 180.0;
    w->speed = 20.0 + 1500.0 * tu_rng_unit(r);
    w->heading = 2.0 * TU_PI * tu_rng_unit(r);
    w->turn = (kind == 1u) ? (tu_rng_unit(r) - 0.5) * 0.02 : 0.0;
    if (kind == 2u) {
        w->heading = alpha + ((tu_rng_u32(r) & 1u) ? 0.0 : TU_PI) + (tu_rng_unit(r) - 0.5) * 0.6;
    }
}

/* The walk's next sample: a step along the leg (now and then a jump of the
 * piezo, or a corner of its range), the signals with their noise (now and
 * then at an edge of the fast range). */
static fw_sample_in_t sweep_next_input(tu_rng_t *r, const fw_board_t *f, sweep_walk_t *w)
{
    fw_sample_in_t in;
    w->heading += w->turn;
    w->x += w->speed * cos(w->heading);
    w->y += w->speed * sin(w->heading);
    if (tu_rng_u32(r) % 1000u == 0u) {   /* a jump of the piezo */
        w->x = tu_rng_range(r, INT32_MIN, INT32_MAX);
        w->y = tu_rng_range(r, INT32_MIN, INT32_MAX);
    }
    w->x = (w->x > INT32_MAX) ? INT32_MAX : ((w->x < INT32_MIN) ? INT32_MIN : w->x);
    w->y = (w->y > INT32_MAX) ? INT32_MAX : ((w->y < INT32_MIN) ? INT32_MIN : w->y);
    w->z += tu_rng_range(r, -300, 300);
    w->sn_uv += tu_rng_range(r, -w->noise_uv / 64 - 1, w->noise_uv / 64 + 1);
    w->sl_uv += tu_rng_range(r, -w->noise_uv / 64 - 1, w->noise_uv / 64 + 1);
    w->sn_uv = (w->sn_uv > 9999999) ? 9999999 : ((w->sn_uv < -9999999) ? -9999999 : w->sn_uv);
    w->sl_uv = (w->sl_uv > 9999999) ? 9999999 : ((w->sl_uv < -9999999) ? -9999999 : w->sl_uv);
    in.sn_uv = w->sn_uv + tu_rng_range(r, -w->noise_uv, w->noise_uv);
    in.sl_uv = w->sl_uv + tu_rng_range(r, -w->noise_uv, w->noise_uv);
    if (tu_rng_u32(r) % 100u == 0u) {
        in.sn_uv = sweep_edge_uv(r, f);
    }
    if (tu_rng_u32(r) % 100u == 0u) {
        in.sl_uv = sweep_edge_uv(r, f);
    }
    in.piezo_pm[0] = (int32_t)lround(w->x);
    in.piezo_pm[1] = (int32_t)lround(w->y);
    in.piezo_pm[2] = w->z;
    if (tu_rng_u32(r) % 500u == 0u) {   /* one sample at a corner of the piezo's range */
        in.piezo_pm[0] = (tu_rng_u32(r) & 1u) ? INT32_MAX : INT32_MIN;
        in.piezo_pm[1] = (tu_rng_u32(r) & 1u) ? INT32_MAX : INT32_MIN;
    }
    return in;
}

/* Counts a sample the fast path took (`fast`), by branch; `oldest` is the
 * theta window's oldest point before the step. */
static void sweep_count(sweep_counts_t *n, const fw_board_t *f, const fw_sample_out_t *of, bool fast,
                        const int32_t oldest[2])
{
    int64_t dx = (int64_t)of->tip_pm[0] - oldest[0];
    int64_t dy = (int64_t)of->tip_pm[1] - oldest[1];
    bool far = dx > FW_THETA_FAST_WINDOW_PM || dx < -FW_THETA_FAST_WINDOW_PM
               || dy > FW_THETA_FAST_WINDOW_PM || dy < -FW_THETA_FAST_WINDOW_PM;
    n->far += fast && far;
    n->fast += fast;
    n->aligned += fast && f->path_cfg == FW_BOARD_PATH_FAST_ALIGNED;
    n->unobs += fast && (of->flags & FW_FLAG_FX_UNOBSERVABLE) != 0u;
    n->pos += fast && (of->flags & FW_FLAG_SAT_POS) != 0u;
    n->unknown += fast && (of->flags & FW_FLAG_THETA_UNKNOWN) != 0u;
}

/* After sample i: now and then a baseline recorded or a reset, on all three
 * boards; the block waiting for g ends first (before anything but a sample
 * changes the boards), and at a segment's end and the sweep's. */
static void sweep_after_sample(tu_rng_t *r, tu_rng_t *rb, sweep_boards_t *b, sweep_block_t *q, long i, long seg)
{
    bool do_baseline = tu_rng_u32(r) % 10000u == 0u;
    bool do_reset = tu_rng_u32(r) % 20000u == 0u;
    if (q->n == q->target || do_baseline || do_reset || (i + 1) % seg == 0 || i + 1 == AFM_SWEEP_N) {
        sweep_block_flush(q, &b->g, &b->c, rb, i);
    }
    if (do_baseline) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_record_baseline(&b->f));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_record_baseline(&b->c));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_record_baseline(&b->g));
    }
    if (do_reset) {
        fw_board_reset(&b->f);
        fw_board_reset(&b->c);
        fw_board_reset(&b->g);
    }
}

/* fw_board_step (fast path wherever it is open) and fw_board_step_block
 * (blocks of 1..64 samples) against fw_board_step_checked on the same
 * inputs: bit-identical outputs and state over AFM_SWEEP_N samples (10^6 on the host), in segments with their
 * own configuration (inside the fast domain, at its corner), baseline,
 * speed and heading; signals mostly inside the fast range with excursions
 * to the rails and the top code, theta moves past the fast window, piezo
 * jumps that push the apex past int32, baseline records and resets. Each
 * of the fast path's branches is counted and must have run. */
static void test_board_fast_path_bit_identical_to_checked_over_sweep(void)
{
    /* at least two segments of each configuration kind */
    const long seg = (AFM_SWEEP_N / 12 < 5000) ? AFM_SWEEP_N / 12 : 5000;
    static sweep_boards_t b;
    static sweep_block_t q;
    sweep_walk_t w = { 0.0, 0.0, 0.0, 0.0, 300.0, 0, 0, 0, 1000 };
    sweep_counts_t n = { 0, 0, 0, 0, 0, 0 };
    tu_rng_t r;
    tu_rng_t rb;
    long i;
    tu_rng_seed(&r, 0xFA57ull);
    tu_rng_seed(&rb, 0xB10Cull);
    q.n = 0;
    q.blocks = 0;
    q.target = 1;
    for (i = 0; i < AFM_SWEEP_N; i++) {
        fw_sample_in_t in;
        fw_sample_out_t of;
        fw_sample_out_t oc;
        int32_t oldest[2];
        bool fast;
        if (i % seg == 0) {
            sweep_segment_start(&r, (uint32_t)((i / seg) % 6), &b, &w);
        }
        if (i % 400 == 0) {
            sweep_leg(&r, &b.f, &w);
        }
        in = sweep_next_input(&r, &b.f, &w);
        fast = (uint32_t)in.sn_uv - (uint32_t)b.f.fast_lo_uv < b.f.fast_span_uv
               && (uint32_t)in.sl_uv - (uint32_t)b.f.fast_lo_uv < b.f.fast_span_uv;
        oldest[0] = b.f.theta.x_pm[(b.f.theta.pos + 1) & (FW_THETA_WINDOW - 1)];
        oldest[1] = b.f.theta.y_pm[(b.f.theta.pos + 1) & (FW_THETA_WINDOW - 1)];
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b.f, &in, &of));
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_checked(&b.c, &in, &oc));
        assert_boards_identical(&b.f, &b.c, &of, &oc, i);
        q.in[q.n] = in;
        q.oc[q.n] = oc;
        q.n++;
        sweep_count(&n, &b.f, &of, fast, oldest);
        sweep_after_sample(&r, &rb, &b, &q, i, seg);
    }
    printf("SWEEP board fast vs checked n=%ld identical (and in %ld blocks); fast %ld (aligned %ld):"
           " fallback/blend %ld, apex past int32 %ld, theta unknown %ld, beyond the fast window %ld\n",
           (long)AFM_SWEEP_N, q.blocks, n.fast, n.aligned, n.unobs, n.pos, n.unknown, n.far);
    TEST_ASSERT_TRUE(n.fast > AFM_SWEEP_N / 2);
    TEST_ASSERT_TRUE(n.aligned > 0 && n.aligned < n.fast);
    TEST_ASSERT_TRUE(n.unobs > 0);
    TEST_ASSERT_TRUE(n.pos > 0);
    TEST_ASSERT_TRUE(n.unknown > 0);
    TEST_ASSERT_TRUE(n.far > 0 && n.far < n.fast / 2);
    TEST_ASSERT_TRUE(q.blocks > AFM_SWEEP_N / SWEEP_BLOCK_MAX);
}

/* fw_board_step_block on a configuration with only the checked path (ADC
 * filter on), in uneven blocks, against fw_board_step one sample at a
 * time: the same outputs and state. */
static void test_board_step_block_checked_config_matches_single_steps(void)
{
    static fw_board_t s1;
    static fw_board_t s2;
    fw_sample_in_t in[300];
    fw_sample_out_t o1[300];
    fw_sample_out_t o2[300];
    size_t i;
    size_t at = 0;
    size_t len = 1;
    cfg.filter_log2 = 2;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&s1, &cfg));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&s2, &cfg));
    TEST_ASSERT_EQUAL_INT(FW_BOARD_PATH_CHECKED, s2.path_cfg);
    for (i = 0; i < 300; i++) {
        in[i].sn_uv = (int32_t)(3000000 + 40000 * (long)(i % 17)) * ((i % 50 == 7) ? 4 : 1);
        in[i].sl_uv = -200000 + 3000 * (int32_t)i;
        in[i].piezo_pm[0] = 45000000 + 400 * (int32_t)i;
        in[i].piezo_pm[1] = 45000000 + 90 * (int32_t)i;
        in[i].piezo_pm[2] = -100 * (int32_t)i;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&s1, &in[i], &o1[i]));
    }
    while (at < 300) {
        size_t n = (300 - at < len) ? 300 - at : len;
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&s2, &in[at], &o2[at], n));
        at += n;
        len = len * 2 + 1;
    }
    TEST_ASSERT_EQUAL_MEMORY(o1, o2, sizeof o1);
    assert_boards_identical(&s2, &s1, &o2[299], &o1[299], 299);
    TEST_ASSERT_TRUE((fw_board_sticky_flags(&s2) & FW_FLAG_SAT_SN) != 0u);
}

/* fw_board_step_block's arguments: NULL board or buffers refused with
 * nothing changed; an empty block is FW_OK and changes nothing. */
static void test_board_step_block_null_and_empty(void)
{
    fw_sample_in_t in = { 1000, 2000, { 0, 0, 0 } };
    fw_sample_out_t out;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(NULL, &in, &out, 1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(&b, NULL, &out, 1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(&b, &in, NULL, 1));
    TEST_ASSERT_FALSE(b.stepped);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b, NULL, NULL, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b, &in, &out, 0));
    TEST_ASSERT_FALSE(b.stepped);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_block(NULL, NULL, NULL, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step_block(&b, &in, &out, 1));
    TEST_ASSERT_TRUE(b.stepped);
}

/* Every entry tests its pointers (fw_board.h) and leaves the instance
 * untouched on FW_ERR_ARG. */
static void test_board_step_checked_null_pointers_return_arg_error(void)
{
    fw_board_config_t c;
    fw_board_t b;
    fw_sample_in_t in = { 0, 0, { 0, 0, 0 } };
    fw_sample_out_t out;
    paper_config(&c);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_init(&b, &c));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_checked(NULL, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_checked(&b, NULL, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step_checked(&b, &in, NULL));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step(NULL, &in, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step(&b, NULL, &out));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_board_step(&b, &in, NULL));
    TEST_ASSERT_FALSE(b.stepped);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_board_step(&b, &in, &out));
    TEST_ASSERT_TRUE(b.stepped);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_board_init_validates_config);
    RUN_TEST(test_board_same_push_same_frame_a_force_at_every_scan_angle);
    RUN_TEST(test_board_sn_past_10v_flags_and_uses_virtual_sn);
    RUN_TEST(test_board_sl_at_just_past_far_past_rail_flags);
    RUN_TEST(test_board_zero_length_moves_stay_finite_theta_unknown);
    RUN_TEST(test_board_piezo_cmd_puts_apex_at_joystick_target);
    RUN_TEST(test_board_baseline_removes_offset);
    RUN_TEST(test_board_force_saturates_with_flag_and_counter);
    RUN_TEST(test_board_fast_path_selected_at_the_domain_edges);
    RUN_TEST(test_board_fast_path_bit_identical_to_checked_over_sweep);
    RUN_TEST(test_board_step_checked_null_pointers_return_arg_error);
    RUN_TEST(test_board_step_block_checked_config_matches_single_steps);
    RUN_TEST(test_board_step_block_null_and_empty);
    return UNITY_END();
}
