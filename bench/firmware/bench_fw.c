/*
 * bench_fw.c - per-sample cost and accuracy of the firmware's chain
 * (acquisition + compensation + theta + force + rotation) on three word
 * sizes: the firmware's 16-bit fw_board16_step_block, its 32-bit fw_board_step_block,
 * and a double-precision reference (bench_ref.c). Host only; a benchmark,
 * not a test: it prints numbers and asserts nothing.
 *
 * Output is line based for bench/bench_firmware.sh, which adds callgrind's
 * instruction counts and prints the table:
 *   input  key=value ...            the sweep
 *   row    path=NAME ns=... worst_pn=... rms_pn=... worst_pct=...
 *   note   free text
 *
 * Error: |F_path - F_ref| (3-vector, frame A, pN) per sample against the
 * double reference fed with the same 16-bit ADC codes, so it measures the
 * arithmetic; the row "ref_analog" (double, unquantised input) shows what
 * the ADC itself contributes. Full scale: k_n K_n 10 V.
 *
 * The sweep (deterministic, seeded per scan angle): the piezo moves in
 * segments of 2000..8000 samples at 200..800 pm per sample - curving on a
 * radius of 0.3..3 um, straight in a random direction, or straight along
 * the lever (theta = 0 or 180 deg, exactly or within 3 deg); the tip
 * carries a load F_z = 43 + 47 sin(2 pi i / 50000) nN and friction
 * mu (F_z + F_adh) plus a push max(0, 30 sin(2 pi i / 37000)) nN, both
 * opposing the apex's motion (found self-consistently, since the apex moves
 * with the signals); S_n, S_l follow from eq. 1a-1c plus +-2 mV of uniform
 * noise, clamped inside +-9.99 V.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "fw_board.h"
#include "fw_paper_probe.h"
#include "fw_board16.h"
#include "bench_ref.h"

#ifdef BENCH_HAVE_CALLGRIND
#include <valgrind/callgrind.h>
#define BENCH_CG_BEGIN() do { CALLGRIND_START_INSTRUMENTATION; CALLGRIND_ZERO_STATS; } while (0)
#define BENCH_CG_END(name) do { CALLGRIND_DUMP_STATS_AT(name); CALLGRIND_STOP_INSTRUMENTATION; } while (0)
#else
#define BENCH_CG_BEGIN() do { } while (0)
#define BENCH_CG_END(name) do { (void)(name); } while (0)
#endif

#define BENCH_PI 3.14159265358979323846
#define BENCH_MAX_ANGLES 8
#define BENCH_N_DEFAULT 200000
#define BENCH_REPEATS_DEFAULT 7
#define BENCH_BLOCK_DEFAULT 20     /* samples per fw_board_step_block: the default scene's
                                      analog block (20 kHz sampling, 1 kHz blocks) */
#define BENCH_SEG_MIN 2000
#define BENCH_SEG_SPAN 6000
#define BENCH_NOISE_UV 2000
#define BENCH_LOAD_MEAN_PN 43000.0
#define BENCH_LOAD_AMP_PN 47000.0
#define BENCH_LOAD_PERIOD 50000.0  /* samples: slow, so the apex moves with the piezo */
#define BENCH_PUSH_AMP_PN 30000.0
#define BENCH_PUSH_PERIOD 37000.0
#define BENCH_SPEED_MIN_PM 200.0   /* per sample */
#define BENCH_SPEED_MAX_PM 800.0
#define BENCH_RADIUS_MIN_PM 300000.0
#define BENCH_RADIUS_MAX_PM 3000000.0
#define BENCH_APEX_ITER 4
#define BENCH_SIGNAL_MAX_UV 9990000
#define BENCH_TARGET_FRAC 0.001   /* the error target, of full scale */
#define BENCH_FS_PN(cfg) (10.0 * (cfg)->normal_gain_pn_per_v)

enum { PATH_Q15, PATH_FW32, PATH_REF, PATH_REF_ANALOG, PATH_COUNT };
static const char *const path_name[PATH_COUNT] = { "q15", "fw32", "ref", "ref_analog" };

typedef struct {
    fw_board_config_t cfg;
    fw_sample_in_t *in;
    fw_sample_out_t *out_16;
    fw_sample_out_t *out_fw;
    double (*out_d)[3];
    double (*ref)[3];
    double *theta_c;      /* true direction of motion, frame C, rad (for notes) */
    unsigned char *corner; /* 1 where a segment starts (the heading jumps) */
    fw_board_t board;
    fw_board16_t q15;
    bench_ref_t refp;
    bench_ref_t ref_analog;
} bench_angle_t;

/* ---- the sweep ---------------------------------------------------------- */

static uint64_t rng_state;
static size_t bench_block = BENCH_BLOCK_DEFAULT;

static uint64_t rng_next(void)   /* splitmix64 */
{
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double rng_unit(void)     /* [0, 1) */
{
    return (double)(rng_next() >> 11) * (1.0 / 9007199254740992.0);
}

static double rng_range(double lo, double hi)
{
    return lo + (hi - lo) * rng_unit();
}

static double clampd(double v, double lo, double hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* The paper's lever (fw_paper_probe.h) as the tests use it: adhesion 5 nN,
 * the joystick's centre at (45, 45) um. */
static void paper_config(fw_board_config_t *c, int32_t scan_mdeg)
{
    fw_paper_board_config(c, scan_mdeg);
    c->adhesion_pn = 5000;
    c->scan_center_pm[0] = 45000000;
    c->scan_center_pm[1] = 45000000;
}

/* S_n, S_l (V) for friction plus push opposing a motion at theta (frame C). */
static void sweep_signals(const fw_board_config_t *c, double fpar, double fz, double th,
                          double *sn_v, double *sl_v)
{
    double g = 2.0 * c->tip_height_nm / c->lever_length_nm;
    double fx = -fpar * cos(th);
    double fy = -fpar * sin(th);
    *sl_v = fy / c->lateral_gain_pn_per_v;
    *sn_v = (fz + g * fx) / c->normal_gain_pn_per_v;
}

/* The piezo's path: a segment at a time, each curving, straight or along
 * the lever. */
typedef struct {
    double heading;   /* piezo, frame A */
    double turn;      /* rad per sample */
    double speed;     /* pm per sample */
    size_t left;      /* samples left in the segment */
} bench_seg_t;

/* A new segment (its first sample is a corner). */
static void new_segment(bench_seg_t *g, double alpha)
{
    int kind = (int)(rng_next() % 3u);
    g->left = BENCH_SEG_MIN + (size_t)(rng_next() % BENCH_SEG_SPAN);
    g->speed = rng_range(BENCH_SPEED_MIN_PM, BENCH_SPEED_MAX_PM);
    if (kind == 0) {           /* curving, radius 0.3..3 um */
        g->turn = g->speed / rng_range(BENCH_RADIUS_MIN_PM, BENCH_RADIUS_MAX_PM);
        if (rng_next() & 1u) {
            g->turn = -g->turn;
        }
        g->heading = rng_range(-BENCH_PI, BENCH_PI);
    } else if (kind == 1) {    /* straight, any direction */
        g->turn = 0.0;
        g->heading = rng_range(-BENCH_PI, BENCH_PI);
    } else {                   /* along the lever: theta 0 or pi, exactly or within 3 deg */
        double off = (rng_next() & 1u) ? 0.0 : rng_range(-3.0, 3.0) * BENCH_PI / 180.0;
        g->turn = 0.0;
        g->heading = alpha + ((rng_next() & 1u) ? 0.0 : BENCH_PI) + off;
    }
}

/* The apex's direction of motion theta (frame C) and the sample's signals.
 * Friction opposes the APEX's motion, and the apex moves with the signals
 * (fw_comp.h): theta = direction of the apex's velocity, piezo step +
 * R(alpha) C (S(i, theta) - S(i - 1, theta - turn)), found by fixed-point
 * iteration from the piezo's heading (the apex turns with the piezo on a
 * smooth path). At a corner the piezo's heading is used. */
static double apex_theta(const fw_board_config_t *c, const double step_c[2], double th, double turn, int corner, double fpar,
                         double fz, double fpar_prev, double fz_prev, double *sn_v, double *sl_v)
{
    int it;
    for (it = 0; it < BENCH_APEX_ITER && !corner; it++) {
        double sn0;
        double sl0;
        double dx;
        double dy;
        sweep_signals(c, fpar, fz, th, sn_v, sl_v);
        sweep_signals(c, fpar_prev, fz_prev, th - turn, &sn0, &sl0);
        dx = c->disp_n_pm_per_v * (*sn_v - sn0);
        dy = c->disp_l_pm_per_v * (*sl_v - sl0);
        th = atan2(step_c[1] + dy, step_c[0] + dx);
    }
    sweep_signals(c, fpar, fz, th, sn_v, sl_v);
    return th;
}

static void make_sweep(bench_angle_t *a, size_t n, uint64_t seed)
{
    const fw_board_config_t *c = &a->cfg;
    double alpha = (c->scan_angle_mdeg - 270000) * 1e-3 * BENCH_PI / 180.0;
    double mu = c->mu_ppm * 1e-6;
    double x = c->scan_center_pm[0];
    double y = c->scan_center_pm[1];
    bench_seg_t g = {0.0, 0.0, 300.0, 0};
    double step_c[2];
    double fpar_prev = 0.0;
    double fz_prev = 0.0;
    size_t i;
    rng_state = seed;
    for (i = 0; i < n; i++) {
        double th;
        double fz;
        double push;
        double fpar;
        double sn_v = 0.0;
        double sl_v = 0.0;
        if (g.left == 0) {
            new_segment(&g, alpha);
            a->corner[i] = 1;
        }
        g.left--;
        g.heading += g.turn;
        x += g.speed * cos(g.heading);
        y += g.speed * sin(g.heading);
        step_c[0] = g.speed * cos(g.heading - alpha);   /* piezo step in frame C */
        step_c[1] = g.speed * sin(g.heading - alpha);
        fz = BENCH_LOAD_MEAN_PN + BENCH_LOAD_AMP_PN * sin(2.0 * BENCH_PI * i / BENCH_LOAD_PERIOD);
        push = BENCH_PUSH_AMP_PN * sin(2.0 * BENCH_PI * i / BENCH_PUSH_PERIOD);
        push = push < 0.0 ? 0.0 : push;
        fpar = mu * (fz + c->adhesion_pn) + push;
        th = apex_theta(c, step_c, g.heading - alpha, g.turn, a->corner[i], fpar, fz, fpar_prev, fz_prev, &sn_v, &sl_v);
        fpar_prev = fpar;
        fz_prev = fz;
        a->in[i].sn_uv = (int32_t)clampd(lround(sn_v * 1e6) + rng_range(-BENCH_NOISE_UV, BENCH_NOISE_UV),
                                         -BENCH_SIGNAL_MAX_UV, BENCH_SIGNAL_MAX_UV);
        a->in[i].sl_uv = (int32_t)clampd(lround(sl_v * 1e6) + rng_range(-BENCH_NOISE_UV, BENCH_NOISE_UV),
                                         -BENCH_SIGNAL_MAX_UV, BENCH_SIGNAL_MAX_UV);
        a->in[i].piezo_pm[0] = (int32_t)lround(x);
        a->in[i].piezo_pm[1] = (int32_t)lround(y);
        a->in[i].piezo_pm[2] = 0;
        a->theta_c[i] = th;
    }
}

/* ---- the measured loops (not inlined, so callgrind can name them) ------- */

/* The firmware's 16-bit chain (fw_board16), driven as the 32-bit one. */
__attribute__((noinline)) void bench_loop_q15(fw_board16_t *b, const fw_sample_in_t *in,
                                              fw_sample_out_t *out, size_t n, size_t block)
{
    size_t i;
    for (i = 0; i < n; i += block) {
        (void)fw_board16_step_block(b, &in[i], &out[i], (n - i < block) ? n - i : block);
    }
}

/* The firmware as fw_node drives it: one fw_board_step_block per analog
 * block of `block` samples, outputs left in the block's buffer (the
 * errors are read from it after the measured loop). */
__attribute__((noinline)) void bench_loop_fw32(fw_board_t *b, const fw_sample_in_t *in,
                                               fw_sample_out_t *out, size_t n, size_t block)
{
    size_t i;
    for (i = 0; i < n; i += block) {
        (void)fw_board_step_block(b, &in[i], &out[i], (n - i < block) ? n - i : block);
    }
}

__attribute__((noinline)) void bench_loop_ref(bench_ref_t *r, const fw_sample_in_t *in,
                                              double (*f)[3], size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        bench_ref_step(r, &in[i], f[i]);
    }
}

static void run_path(int path, bench_angle_t *a, size_t n)
{
    switch (path) {
    case PATH_Q15:
        fw_board16_reset(&a->q15);
        bench_loop_q15(&a->q15, a->in, a->out_16, n, bench_block);
        break;
    case PATH_FW32:
        fw_board_reset(&a->board);
        bench_loop_fw32(&a->board, a->in, a->out_fw, n, bench_block);
        break;
    case PATH_REF:
        bench_ref_reset(&a->refp);
        bench_loop_ref(&a->refp, a->in, a->out_d, n);
        break;
    default:
        bench_ref_reset(&a->ref_analog);
        bench_loop_ref(&a->ref_analog, a->in, a->out_d, n);
        break;
    }
}

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec;
}

static int cmp_double(const void *x, const void *y)
{
    double a = *(const double *)x;
    double b = *(const double *)y;
    return (a > b) - (a < b);
}

/* ---- main ---------------------------------------------------------------- */

static void usage(FILE *f)
{
    fprintf(f,
            "usage: bench_fw [-n SAMPLES] [-r REPEATS] [-b SAMPLES] [-a DEG[,DEG...]] [--callgrind | --path NAME]\n"
            "  -n SAMPLES   samples per scan angle (default %d)\n"
            "  -r REPEATS   timing repeats, the median is reported (default %d)\n"
            "  -b SAMPLES   samples per fw_board_step_block call (default %d, the default\n"
            "               scene's analog block)\n"
            "  -a DEGREES   scan angles in degrees (default 270,300)\n"
            "  --callgrind  run each path's loop once per scan angle between callgrind\n"
            "               client requests (dumps named bench_PATH@DEG); no timing, no errors\n"
            "  --path NAME  run only NAME's loop once (q15, fw32, ref, ref_analog), for\n"
            "               valgrind --toggle-collect=bench_loop_*\n"
            "  --features   print whether callgrind client requests are compiled in\n"
            "Prints 'input', 'row' and 'note' lines; bench/bench_firmware.sh makes the table.\n",
            BENCH_N_DEFAULT, BENCH_REPEATS_DEFAULT, BENCH_BLOCK_DEFAULT);
}

/* The command line (usage()). */
typedef struct {
    size_t n;
    int repeats;
    int n_angles;
    double angles_deg[BENCH_MAX_ANGLES];
    int only_path;
    int callgrind;
} bench_opts_t;

/* "-a 270,300": the scan angles, at most BENCH_MAX_ANGLES. */
static void parse_angles(char *s, bench_opts_t *o)
{
    o->n_angles = 0;
    while (*s != '\0' && o->n_angles < BENCH_MAX_ANGLES) {
        char *end;
        o->angles_deg[o->n_angles++] = strtod(s, &end);
        s = (*end == ',') ? end + 1 : end;
        if (end == s && *s != '\0') {
            break;
        }
    }
}

/* Reads the command line into o; returns -1 to go on, else the exit code. */
static int parse_args(int argc, char **argv, bench_opts_t *o)
{
    int i;
    int p;
    o->n = BENCH_N_DEFAULT;
    o->repeats = BENCH_REPEATS_DEFAULT;
    o->n_angles = 0;
    o->only_path = -1;
    o->callgrind = 0;
    for (i = 1; i < argc; i++) {
        if (strcmp(argv[i], "-n") == 0 && i + 1 < argc) {
            o->n = (size_t)strtoul(argv[++i], NULL, 10);
        } else if (strcmp(argv[i], "-r") == 0 && i + 1 < argc) {
            o->repeats = atoi(argv[++i]);
        } else if (strcmp(argv[i], "-b") == 0 && i + 1 < argc) {
            long v = strtol(argv[++i], NULL, 10);
            if (v < 1 || v > 1000000) {
                fprintf(stderr, "bench_fw: -b %s: samples per block must be 1..1000000\n", argv[i]);
                return 2;
            }
            bench_block = (size_t)v;
        } else if (strcmp(argv[i], "-a") == 0 && i + 1 < argc) {
            parse_angles(argv[++i], o);
        } else if (strcmp(argv[i], "--callgrind") == 0) {
            o->callgrind = 1;
        } else if (strcmp(argv[i], "--path") == 0 && i + 1 < argc) {
            const char *name = argv[++i];
            for (p = 0; p < PATH_COUNT; p++) {
                if (strcmp(name, path_name[p]) == 0) {
                    o->only_path = p;
                }
            }
            if (o->only_path < 0) {
                fprintf(stderr, "bench_fw: unknown path '%s'\n", name);
                return 2;
            }
        } else if (strcmp(argv[i], "--features") == 0) {
#ifdef BENCH_HAVE_CALLGRIND
            printf("callgrind_requests=1\n");
#else
            printf("callgrind_requests=0\n");
#endif
            return 0;
        } else if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
            usage(stdout);
            return 0;
        } else {
            usage(stderr);
            return 2;
        }
    }
    if (o->n_angles == 0) {
        o->angles_deg[0] = 270.0;
        o->angles_deg[1] = 300.0;
        o->n_angles = 2;
    }
    if (o->n < 100 || o->repeats < 1) {
        fprintf(stderr, "bench_fw: need at least 100 samples and 1 repeat\n");
        return 2;
    }
    return -1;
}

/* One scan angle's card, references and input sweep; 0, or 1 after saying why. */
static int setup_angle(bench_angle_t *a, double angle_deg, size_t n, int k)
{
    paper_config(&a->cfg, (int32_t)lround(angle_deg * 1000.0));
    a->in = malloc(n * sizeof *a->in);
    a->out_16 = malloc(n * sizeof *a->out_16);
    a->out_fw = malloc(n * sizeof *a->out_fw);
    a->out_d = malloc(n * sizeof *a->out_d);
    a->ref = malloc(n * sizeof *a->ref);
    a->theta_c = malloc(n * sizeof *a->theta_c);
    a->corner = calloc(n, 1);
    if (a->in == NULL || a->out_16 == NULL || a->out_fw == NULL || a->out_d == NULL || a->ref == NULL || a->theta_c == NULL
        || a->corner == NULL) {
        fprintf(stderr, "bench_fw: out of memory\n");
        return 1;
    }
    if (fw_board_init(&a->board, &a->cfg) != FW_OK) {
        fprintf(stderr, "bench_fw: fw_board_init refused the paper's lever\n");
        return 1;
    }
    if (fw_board16_init(&a->q15, &a->cfg) != FW_OK) {
        fprintf(stderr, "bench_fw: fw_board16_init refused the paper's lever\n");
        return 1;
    }
    bench_ref_init(&a->refp, &a->cfg, a->cfg.adc_bits);
    bench_ref_init(&a->ref_analog, &a->cfg, 0);
    make_sweep(a, n, 0x5EEDull + (uint64_t)k * 0x10001ull);
    return 0;
}

static void free_angle(bench_angle_t *a)
{
    free(a->in);
    free(a->out_16);
    free(a->out_fw);
    free(a->out_d);
    free(a->ref);
    free(a->theta_c);
    free(a->corner);
}

/* --callgrind or --path: each path's loops between callgrind's requests, no table. */
static void run_for_callgrind(const bench_opts_t *o, bench_angle_t *ang)
{
    int p;
    int k;
    for (p = 0; p < PATH_COUNT; p++) {
        char dump[32];
        if (o->only_path >= 0 && p != o->only_path) {
            continue;
        }
        for (k = 0; k < o->n_angles; k++) {
            snprintf(dump, sizeof dump, "bench_%s@%g", path_name[p], o->angles_deg[k]);
            BENCH_CG_BEGIN();
            run_path(p, &ang[k], o->n);
            BENCH_CG_END(dump);
        }
    }
    printf("input samples=%zu\n", o->n * (size_t)o->n_angles);
}

/* The "input" line: the sweep's ranges and how much of it runs near the lever's axis. */
static void print_inputs(const bench_opts_t *o, const bench_angle_t *ang)
{
    double sn_min = 1e9, sn_max = -1e9, sl_min = 1e9, sl_max = -1e9;
    size_t near_axis = 0;
    const size_t n = o->n;
    int k;
    for (k = 0; k < o->n_angles; k++) {
        size_t j;
        for (j = 0; j < n; j++) {
            double sn = ang[k].in[j].sn_uv * 1e-6;
            double sl = ang[k].in[j].sl_uv * 1e-6;
            sn_min = sn < sn_min ? sn : sn_min;
            sn_max = sn > sn_max ? sn : sn_max;
            sl_min = sl < sl_min ? sl : sl_min;
            sl_max = sl > sl_max ? sl : sl_max;
            near_axis += fabs(sin(ang[k].theta_c[j])) < 0.25;
        }
    }
    printf("input samples=%zu per_angle=%zu angles=", n * (size_t)o->n_angles, n);
    for (k = 0; k < o->n_angles; k++) {
        printf("%s%g", k ? "," : "", o->angles_deg[k]);
    }
    printf(" sn_v=%.2f..%.2f sl_v=%.2f..%.2f near_axis_pct=%.1f repeats=%d fs_pn=%.0f fw_block=%zu\n", sn_min, sn_max, sl_min,
           sl_max, 100.0 * near_axis / (n * (double)o->n_angles), o->repeats, BENCH_FS_PN(&ang[0].cfg), bench_block);
}

/* A path's force error against the reference over every angle's sweep. */
typedef struct {
    double worst, sum2, worst_theta, worst_angle, worst_steady;
    size_t worst_at, worst_since, over;
} bench_err_t;

static void path_errors(int p, const bench_opts_t *o, const bench_angle_t *ang, bench_err_t *e)
{
    int k;
    memset(e, 0, sizeof *e);
    for (k = 0; k < o->n_angles; k++) {
        size_t j;
        size_t since_corner = FW_THETA_WINDOW;
        for (j = 0; j < o->n; j++) {
            double d2 = 0.0;
            double d;
            int c;
            since_corner = ang[k].corner[j] ? 0 : since_corner + 1;
            for (c = 0; c < 3; c++) {
                double v = (p == PATH_FW32) ? ang[k].out_fw[j].force_pn[c]
                           : (p == PATH_Q15) ? ang[k].out_16[j].force_pn[c] : ang[k].out_d[j][c];
                double err = v - ang[k].ref[j][c];
                d2 += err * err;
            }
            d = sqrt(d2);
            e->sum2 += d2;
            e->over += d > BENCH_TARGET_FRAC * BENCH_FS_PN(&ang[k].cfg);
            if (since_corner >= FW_THETA_WINDOW && d > e->worst_steady) {
                e->worst_steady = d;
            }
            if (d > e->worst) {
                e->worst = d;
                e->worst_at = j;
                e->worst_theta = ang[k].theta_c[j] * 180.0 / BENCH_PI;
                e->worst_angle = o->angles_deg[k];
                e->worst_since = since_corner;
            }
        }
    }
}

/* One path's row: the median time per sample over the repeats, its errors. 0, or 1 out of memory. */
static int bench_path(int p, const bench_opts_t *o, bench_angle_t *ang)
{
    double *t = malloc((size_t)o->repeats * sizeof *t);
    bench_err_t e;
    int r;
    int k;
    if (t == NULL) {
        return 1;
    }
    for (r = 0; r < o->repeats; r++) {
        double t0 = now_ns();
        for (k = 0; k < o->n_angles; k++) {
            run_path(p, &ang[k], o->n);
        }
        t[r] = (now_ns() - t0) / (o->n * (double)o->n_angles);
    }
    qsort(t, (size_t)o->repeats, sizeof *t, cmp_double);
    path_errors(p, o, ang, &e);
    printf("row path=%s ns=%.1f worst_pn=%.1f rms_pn=%.2f worst_pct=%.4f\n", path_name[p], t[o->repeats / 2], e.worst,
           sqrt(e.sum2 / (o->n * (double)o->n_angles)), 100.0 * e.worst / BENCH_FS_PN(&ang[0].cfg));
    if (e.worst > 0.0) {
        printf("note %s: worst at scan %g deg, sample %zu (%zu after a corner), true theta %.1f deg;"
               " %zu samples over 0.1%% FS; worst outside the %d samples after a corner %.1f pN\n",
               path_name[p], e.worst_angle, e.worst_at, e.worst_since, e.worst_theta, e.over, FW_THETA_WINDOW, e.worst_steady);
    }
    free(t);
    return 0;
}

int main(int argc, char **argv)
{
    bench_opts_t o;
    bench_angle_t ang[BENCH_MAX_ANGLES];
    int code = parse_args(argc, argv, &o);
    int k;
    int p;
    if (code >= 0) {
        return code;
    }
    for (k = 0; k < o.n_angles; k++) {
        if (setup_angle(&ang[k], o.angles_deg[k], o.n, k) != 0) {
            return 1;
        }
    }
    if (o.callgrind || o.only_path >= 0) {
        run_for_callgrind(&o, ang);
        return 0;
    }
    /* the reference outputs */
    for (k = 0; k < o.n_angles; k++) {
        run_path(PATH_REF, &ang[k], o.n);
        memcpy(ang[k].ref, ang[k].out_d, o.n * sizeof *ang[k].ref);
    }
    print_inputs(&o, ang);
    for (p = 0; p < PATH_COUNT; p++) {
        if (bench_path(p, &o, ang) != 0) {
            return 1;
        }
    }
    for (k = 0; k < o.n_angles; k++) {
        free_angle(&ang[k]);
    }
    return 0;
}
