/* test_board_fast.c - fw_board's fast path: selected at its domain's edges,
 * and bit-identical to the checked path over a random sweep of
 * configurations, signals and walks. */
#include <string.h>
#include "unity.h"
#include "fw_board.h"
#include "fw_math.h"
#include "test_util.h"
#include "board_util.h"

void setUp(void) {}
void tearDown(void) {}

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

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_board_fast_path_selected_at_the_domain_edges);
    RUN_TEST(test_board_fast_path_bit_identical_to_checked_over_sweep);
    return UNITY_END();
}
