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
#define _GNU_SOURCE   /* getopt_long */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "fw_board.h"
#include "fw_paper_probe.h"
#include "fw_board16.h"
#include "bench_ref.h"
#include "bench_fw.h"

#ifdef BENCH_HAVE_CALLGRIND
#include <valgrind/callgrind.h>
#define BENCH_CG_BEGIN() do { CALLGRIND_START_INSTRUMENTATION; CALLGRIND_ZERO_STATS; } while (0)
#define BENCH_CG_END(name) do { CALLGRIND_DUMP_STATS_AT(name); CALLGRIND_STOP_INSTRUMENTATION; } while (0)
#else
#define BENCH_CG_BEGIN() do { } while (0)
#define BENCH_CG_END(name) do { (void)(name); } while (0)
#endif

enum { PATH_Q15, PATH_FW32, PATH_REF, PATH_REF_ANALOG, PATH_COUNT };
static const char *const path_name[PATH_COUNT] = { "q15", "fw32", "ref", "ref_analog" };

#define BENCH_XSTR(x) #x
#define BENCH_STR(x) BENCH_XSTR(x)   /* a default's digits in the usage text */

static size_t bench_block = BENCH_BLOCK_DEFAULT;

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

/* The command line: one table, from which getopt_long's options and the
 * usage text both come. */
typedef struct {
    size_t n;
    int repeats;
    int n_angles;
    double angles_deg[BENCH_MAX_ANGLES];
    int only_path;
    int callgrind;
} bench_opts_t;

enum { OPT_CALLGRIND = 256, OPT_PATH, OPT_FEATURES };

typedef struct {
    struct option opt;   /* name, has_arg, flag (unused), val */
    const char *short_name;
    const char *arg;
    const char *help;
} bench_option_t;

static const bench_option_t bench_options[] = {
    { { "samples", required_argument, NULL, 'n' }, "-n", "SAMPLES",
      "samples per scan angle, at least 100 (default " BENCH_STR(BENCH_N_DEFAULT) ")" },
    { { "repeats", required_argument, NULL, 'r' }, "-r", "REPEATS",
      "timing repeats, the median is reported (default " BENCH_STR(BENCH_REPEATS_DEFAULT) ")" },
    { { "block", required_argument, NULL, 'b' }, "-b", "SAMPLES",
      "samples per fw_board_step_block call, 1..1000000 (default " BENCH_STR(BENCH_BLOCK_DEFAULT)
      ",\nthe default scene's analog block)" },
    { { "angles", required_argument, NULL, 'a' }, "-a", "DEG[,DEG...]",
      "scan angles in degrees, at most " BENCH_STR(BENCH_MAX_ANGLES) " (default 270,300)" },
    { { "callgrind", no_argument, NULL, OPT_CALLGRIND }, NULL, NULL,
      "run each path's loop once per scan angle between callgrind\n"
      "client requests (dumps named bench_PATH@DEG); no timing, no errors" },
    { { "path", required_argument, NULL, OPT_PATH }, NULL, "NAME",
      "run only NAME's loop once (q15, fw32, ref, ref_analog), for\n"
      "valgrind --toggle-collect=bench_loop_*" },
    { { "features", no_argument, NULL, OPT_FEATURES }, NULL, NULL,
      "print whether callgrind client requests are compiled in" },
    { { "help", no_argument, NULL, 'h' }, "-h", NULL, "this text" },
};
enum { BENCH_N_OPTIONS = (int)(sizeof bench_options / sizeof bench_options[0]) };

static void usage(FILE *f)
{
    int k;
    fprintf(f, "usage: bench_fw [OPTION...]\n");
    for (k = 0; k < BENCH_N_OPTIONS; k++) {
        const bench_option_t *o = &bench_options[k];
        char head[64];
        snprintf(head, sizeof head, "%s%s--%s%s%s", o->short_name ? o->short_name : "",
                 o->short_name ? ", " : "", o->opt.name, o->arg ? " " : "", o->arg ? o->arg : "");
        const char *h;
        fprintf(f, "  %-28s ", head);
        for (h = o->help; *h != '\0'; h++) {   /* a help's further lines under its first */
            fputc(*h, f);
            if (*h == '\n') {
                fprintf(f, "%31s", "");
            }
        }
        fputc('\n', f);
    }
    fprintf(f, "Prints 'input', 'row' and 'note' lines; bench/bench_firmware.sh makes the table.\n");
}

/* Refuses an option's value in one line naming both; returns the exit code 2. */
static int refuse(const char *opt, const char *value, const char *why)
{
    fprintf(stderr, "bench_fw: %s %s: %s\n", opt, value, why);
    return 2;
}

/* A whole decimal integer in [lo, hi] from s; 0, or -1 if s is not one. */
static int parse_long(const char *s, long lo, long hi, long *v)
{
    char *end;
    errno = 0;
    *v = strtol(s, &end, 10);
    return (end == s || *end != '\0' || errno != 0 || *v < lo || *v > hi) ? -1 : 0;
}

/* "-a 270,300": the scan angles; 0, or -1 for an empty, unreadable or
 * non-finite entry or more than BENCH_MAX_ANGLES of them. */
static int parse_angles(const char *s, bench_opts_t *o)
{
    o->n_angles = 0;
    for (;;) {
        char *end;
        double v = strtod(s, &end);
        if (end == s || !isfinite(v) || o->n_angles >= BENCH_MAX_ANGLES) {
            return -1;
        }
        o->angles_deg[o->n_angles++] = v;
        if (*end == '\0') {
            return 0;
        }
        if (*end != ',') {
            return -1;
        }
        s = end + 1;
    }
}

/* --path NAME: the path's index, or -1. */
static int path_index(const char *name)
{
    int p;
    for (p = 0; p < PATH_COUNT; p++) {
        if (strcmp(name, path_name[p]) == 0) {
            return p;
        }
    }
    return -1;
}

/* One option's value into o; -1 to go on, else the exit code. */
static int take_option(int c, const char *arg, bench_opts_t *o)
{
    long v;
    switch (c) {
    case 'n':
        return parse_long(arg, 100, 100000000L, &v) ? refuse("-n", arg, "samples must be 100..100000000")
                                                     : (o->n = (size_t)v, -1);
    case 'r':
        return parse_long(arg, 1, 1000, &v) ? refuse("-r", arg, "repeats must be 1..1000") : (o->repeats = (int)v, -1);
    case 'b':
        return parse_long(arg, 1, 1000000, &v) ? refuse("-b", arg, "samples per block must be 1..1000000")
                                               : (bench_block = (size_t)v, -1);
    case 'a':
        return parse_angles(arg, o) ? refuse("-a", arg, "angles must be finite numbers, comma separated, at most "
                                                        BENCH_STR(BENCH_MAX_ANGLES))
                                    : -1;
    case OPT_CALLGRIND:
        o->callgrind = 1;
        return -1;
    case OPT_PATH:
        o->only_path = path_index(arg);
        return o->only_path < 0 ? refuse("--path", arg, "unknown path (q15, fw32, ref, ref_analog)") : -1;
    case OPT_FEATURES:
#ifdef BENCH_HAVE_CALLGRIND
        printf("callgrind_requests=1\n");
#else
        printf("callgrind_requests=0\n");
#endif
        return 0;
    case 'h':
        usage(stdout);
        return 0;
    default:   /* getopt_long has named the option */
        fprintf(stderr, "bench_fw: see bench_fw --help\n");
        return 2;
    }
}

/* Reads the command line into o; returns -1 to go on, else the exit code. */
static int parse_args(int argc, char **argv, bench_opts_t *o)
{
    struct option longopts[BENCH_N_OPTIONS + 1];
    char shortopts[2 * BENCH_N_OPTIONS + 1];
    size_t ns = 0;
    int k;
    int c;
    for (k = 0; k < BENCH_N_OPTIONS; k++) {
        longopts[k] = bench_options[k].opt;
        if (bench_options[k].short_name != NULL) {
            shortopts[ns++] = (char)bench_options[k].opt.val;
            if (bench_options[k].opt.has_arg == required_argument) {
                shortopts[ns++] = ':';
            }
        }
    }
    memset(&longopts[BENCH_N_OPTIONS], 0, sizeof longopts[0]);
    shortopts[ns] = '\0';
    o->n = BENCH_N_DEFAULT;
    o->repeats = BENCH_REPEATS_DEFAULT;
    o->n_angles = 0;
    o->only_path = -1;
    o->callgrind = 0;
    while ((c = getopt_long(argc, argv, shortopts, longopts, NULL)) != -1) {
        int rc = take_option(c, optarg, o);
        if (rc >= 0) {
            return rc;
        }
    }
    if (optind < argc) {
        return refuse("argument", argv[optind], "not an option (see --help)");
    }
    if (o->n_angles == 0) {
        o->angles_deg[0] = 270.0;
        o->angles_deg[1] = 300.0;
        o->n_angles = 2;
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
