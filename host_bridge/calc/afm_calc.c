/*
 * afm_calc - the lever calculator. Host code: it converts the command line's
 * decimal numbers into the firmware's integer units and runs the firmware's
 * own fixed-point solvers (firmware/), so what it prints is what the board
 * computes.
 *
 *   afm_calc calib tilted --up R --down R --angle-deg PHI --spring-N-per-m K --deflection-nm-per-V K [--json] [--write FILE]
 *   afm_calc calib lines --depths-nm a,b,.. --offsets-nm a,b,.. --deflection-nm-per-V K [--json] [--write FILE]
 *   afm_calc model wire --length-nm L --diameter-nm D --push-at-nm l [--f-nN-per-um f] [--json]
 *   afm_calc model squeeze --length-nm L --push-at-nm l --gamma-deg G --mu MU --fl-nN FL --fa-ts-nN F [--twist-deg T] [--json]
 *   afm_calc calc force --sn V --sl V --theta-deg T --scan-angle-deg A [--probe FILE] [--json]
 *
 * Exit status: 0 ok, 2 bad or out-of-domain arguments (one message on
 * stderr naming the option and value).
 *
 * afm_calc_main (afm_calc.h) is the whole program; main.c calls it, the fuzz
 * harness (fuzz/fuzz_calc.cpp) calls it in-process: nothing here exits, every
 * refusal returns its status up to afm_calc_main.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fw_calib.h"
#include "fw_force.h"
#include "fw_math.h"
#include "fw_wire.h"
#include "fw_paper_probe.h"
#include "fw_units.h"

#include "afm_calc.h"

#define EXIT_USAGE 2
#define CALC_PI 3.14159265358979323846
#define LIST_MAX FW_CALIB_LINES_MAX

/* ---- argument handling ------------------------------------------------- */

typedef struct {
    const char *name;     /* "--up" */
    const char *value;    /* NULL if absent */
    int is_flag;          /* no value (--json) */
    int required;
} opt_t;

/* Says why the arguments are refused (one line on stderr); returns EXIT_USAGE. */
static int refuse(const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "afm_calc: ");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return EXIT_USAGE;
}

static int wants_help(int argc, char **argv)
{
    int i;
    for (i = 0; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            return 1;
        }
    }
    return 0;
}

/* The helpers below return 0, or EXIT_USAGE once they have said why. */
static int parse_opts(const char *cmd, int argc, char **argv, opt_t *opts, int n)
{
    int i;
    int k;
    for (i = 0; i < argc; i++) {
        int found = 0;
        for (k = 0; k < n; k++) {
            if (strcmp(argv[i], opts[k].name) == 0) {
                found = 1;
                if (opts[k].is_flag) {
                    opts[k].value = "1";
                } else {
                    if (i + 1 >= argc) {
                        return refuse("%s: option %s needs a value", cmd, opts[k].name);
                    }
                    opts[k].value = argv[++i];
                }
            }
        }
        if (!found) {
            return refuse("%s: unknown option '%s' (see %s --help)", cmd, argv[i], cmd);
        }
    }
    for (k = 0; k < n; k++) {
        if (opts[k].required && opts[k].value == NULL) {
            return refuse("%s: missing option %s (see %s --help)", cmd, opts[k].name, cmd);
        }
    }
    return 0;
}

static int num_opt(const char *cmd, const opt_t *o, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(o->value, &end);
    if (end == o->value || *end != '\0' || errno != 0 || !isfinite(*v)) {
        return refuse("%s: %s %s: not a number", cmd, o->name, o->value);
    }
    return 0;
}

static int num_opt_range(const char *cmd, const opt_t *o, double lo, double hi, const char *why, double *v)
{
    if (num_opt(cmd, o, v) != 0) {
        return EXIT_USAGE;
    }
    if (*v < lo || *v > hi) {
        return refuse("%s: %s %s: out of range, %s", cmd, o->name, o->value, why);
    }
    return 0;
}

/* *n: the count of values read into out[0..max) */
static int list_opt(const char *cmd, const opt_t *o, double *out, int max, int *n)
{
    const char *p = o->value;
    *n = 0;
    while (*p != '\0') {
        char *end;
        double v;
        if (*n >= max) {
            return refuse("%s: %s %s: at most %d values", cmd, o->name, o->value, max);
        }
        errno = 0;
        v = strtod(p, &end);
        if (end == p || errno != 0 || !isfinite(v) || (*end != ',' && *end != '\0')) {
            return refuse("%s: %s %s: not a comma-separated list of numbers", cmd, o->name, o->value);
        }
        out[(*n)++] = v;
        p = (*end == ',') ? end + 1 : end;
    }
    return 0;
}

static const char *status_name(fw_status_t st)
{
    switch (st) {
    case FW_OK:
        return "ok";
    case FW_ERR_ARG:
        return "bad argument";
    case FW_ERR_DOMAIN:
        return "out of domain";
    case FW_ERR_CAPACITY:
        return "capacity";
    case FW_ERR_STATE:
        return "state";
    }
    return "unknown";
}

/* --write FILE: a scene include (include: FILE) holding what was measured
 * as the card's calibrated constants (firmware.*), written whole or not at
 * all (a temporary file renamed). `keys` is the YAML mapping's body. */
static int write_include(const char *cmd, const char *path, int argc, char **argv, const char *keys)
{
    char tmp[4096];
    FILE *f;
    int i;
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        return refuse("%s: --write %s: path too long", cmd, path);
    }
    f = fopen(tmp, "w");
    if (f == NULL) {
        return refuse("%s: --write %s: cannot write: %s", cmd, path, strerror(errno));
    }
    fprintf(f, "# The card's calibrated constants, measured by ./afm %s", cmd);
    for (i = 0; i < argc; i++) {
        fprintf(f, " %s", argv[i]);
    }
    fprintf(f, "\n# A scene takes them with  include: %s\nfirmware:\n%s", path, keys);
    if (fclose(f) != 0 || rename(tmp, path) != 0) {
        remove(tmp);
        return refuse("%s: --write %s: cannot write: %s", cmd, path, strerror(errno));
    }
    return 0;
}

static int to_i32(const char *cmd, const opt_t *o, double v, int32_t *out)
{
    if (!(v >= -2147483648.0 && v <= 2147483647.0)) {
        return refuse("%s: %s %s: does not fit the firmware's 32-bit units", cmd, o->name, o->value);
    }
    *out = fwu_i32(v);
    return 0;
}

/* ---- calib tilted ------------------------------------------------------- */

static int cmd_calib_tilted(int argc, char **argv)
{
    const char *cmd = "calib tilted";
    opt_t o[] = {
        { "--up", NULL, 0, 1 }, { "--down", NULL, 0, 1 }, { "--angle-deg", NULL, 0, 1 },
        { "--spring-N-per-m", NULL, 0, 1 }, { "--deflection-nm-per-V", NULL, 0, 1 }, { "--json", NULL, 1, 0 },
        { "--write", NULL, 0, 0 },
    };
    double ru;
    double rd;
    double phi;
    double spring_n_per_m;
    double deflection_nm_per_v;
    double normal_gain_pn_per_v;
    fw_calib_tilted_t t;
    fw_status_t st;
    if (wants_help(argc, argv)) {
        printf("usage: afm_calc calib tilted --up R_U --down R_D --angle-deg PHI --spring-N-per-m N_PER_M --deflection-nm-per-V NM_PER_V [--json] [--write FILE]\n"
               "  Lateral calibration on a tilted surface (physics.md section 2): from the\n"
               "  friction-loop slopes dS_l/dS_n uphill (R_U) and downhill (R_D, may be < 0)\n"
               "  on a surface of slope PHI degrees, gives mu and k_theta K_l / h (nN/V).\n"
               "  Refuses |R_U/R_D| <= 1 (+2^-10), PHI < 0.1 or >= 90 deg, R_U <= 0.\n"
               "  --write FILE: a scene include with firmware.lateral_nN_per_V and firmware.mu.\n"
               "  Paper: --up 0.07 --down 0.02 --angle-deg 9 --spring-N-per-m 0.12 --deflection-nm-per-V 89 -> mu 0.0865, 37.9 nN/V\n");
        return 0;
    }
    if (parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || num_opt_range(cmd, &o[0], -127.0, 127.0, "slopes must lie in (-127, 127)", &ru) != 0
        || num_opt_range(cmd, &o[1], -127.0, 127.0, "slopes must lie in (-127, 127)", &rd) != 0
        || num_opt_range(cmd, &o[2], -360.0, 360.0, "degrees", &phi) != 0
        || num_opt_range(cmd, &o[3], 1e-6, 1e4, "k_n must lie in [1e-6, 1e4] N/m", &spring_n_per_m) != 0
        || num_opt_range(cmd, &o[4], 1e-3, 1e6, "K_n must lie in [1e-3, 1e6] nm/V", &deflection_nm_per_v) != 0) {
        return EXIT_USAGE;
    }
    normal_gain_pn_per_v = spring_n_per_m * deflection_nm_per_v * 1000.0;   /* N/m * nm/V = nN/V, in pN/V */
    if (normal_gain_pn_per_v < 1.0 || normal_gain_pn_per_v > 2147483647.0) {
        return refuse("%s: --spring-N-per-m %s --deflection-nm-per-V %s: k_n K_n = %g nN/V does not fit int32 pN/V", cmd, o[3].value, o[4].value,
            fwu_nn_per_v_from_pn_per_v((int64_t)normal_gain_pn_per_v));
    }
    st = fw_calib_tilted_solve(fwu_q24(ru), fwu_q24(rd), fw_math_bam_from_mdeg(fwu_mdeg_from_deg(phi)),
                               fwu_i32(normal_gain_pn_per_v), &t);
    if (st != FW_OK) {
        /* the firmware names the rule; the options that feed it with it */
        fw_rule_t rule = fw_calib_tilted_rule(fwu_q24(ru), fwu_q24(rd), fw_math_bam_from_mdeg(fwu_mdeg_from_deg(phi)),
                                              fwu_i32(normal_gain_pn_per_v));
        const char *opt = (rule == FW_RULE_TILTED_SLOPE) ? "--angle-deg" : (rule == FW_RULE_TILTED_UPHILL) ? "--up" : "--up --down";
        return refuse("%s: %s (--up %s --down %s --angle-deg %s): the firmware refuses it: %s (fw_calib_tilted_solve: %s, rule %d)",
            cmd, opt, o[0].value, o[1].value, o[2].value, fw_rule_text(rule), status_name(st), (int)rule);
    }
    {
        double mu = fwu_from_q30(t.mu);
        double beta = fwu_deg_from_bam(t.beta);
        double lat = fwu_nn_per_v_from_pn_per_v(t.lateral_gain_pn_per_v);
        if (o[5].value != NULL) {
            printf("{\"command\": \"calib tilted\", \"status\": \"ok\", \"mu\": %.6f, \"mu_ppm\": %ld, "
                   "\"lateral_nN_per_V\": %.3f, \"lateral_pN_per_V\": %ld, \"slope_angle_deg\": %.4f, "
                   "\"friction_angle_deg\": %.4f, \"normal_gain_nN_per_V\": %.4f}\n",
                   mu, (long)t.mu_ppm, lat, (long)t.lateral_gain_pn_per_v, phi, beta, normal_gain_pn_per_v * 1e-3);
        } else {
            printf("tilted-surface calibration (firmware fw_calib_tilted_solve)\n");
            printf("  slope angle phi        %.4f deg\n", phi);
            printf("  k_n K_n                %.4f nN/V\n", normal_gain_pn_per_v * 1e-3);
            printf("  mu                     %.6f\n", mu);
            printf("  friction angle beta    %.4f deg\n", beta);
            printf("  k_theta K_l / h        %.3f nN/V\n", lat);
            printf("  status                 ok\n");
        }
        if (o[6].value != NULL) {
            char keys[256];
            snprintf(keys, sizeof keys, "  lateral_nN_per_V: %.3f   # k_theta K_l / h\n  mu: %.6f                # tip-substrate\n", lat, mu);
            return write_include(cmd, o[6].value, argc, argv, keys);
        }
    }
    return 0;
}

/* ---- calib lines -------------------------------------------------------- */

static int cmd_calib_lines(int argc, char **argv)
{
    const char *cmd = "calib lines";
    opt_t o[] = {
        { "--depths-nm", NULL, 0, 1 }, { "--offsets-nm", NULL, 0, 1 }, { "--deflection-nm-per-V", NULL, 0, 1 },
        { "--json", NULL, 1, 0 }, { "--write", NULL, 0, 0 },
    };
    double dz[LIST_MAX];
    double dd[LIST_MAX];
    int32_t dzp[LIST_MAX];
    int32_t ddp[LIST_MAX];
    int n;
    int m;
    int i;
    double deflection_nm_per_v;
    int32_t disp_n_pm_per_v;
    int32_t res;
    fw_status_t st;
    if (wants_help(argc, argv)) {
        printf("usage: afm_calc calib lines --depths-nm D1,D2,.. --offsets-nm O1,O2,.. --deflection-nm-per-V NM_PER_V [--json] [--write FILE]\n"
               "  C_n from lines inscribed at several push depths (physics.md section 3):\n"
               "  S_n' = depth / K_n, least-squares fit offset = C_n S_n' + b; prints C_n (nm/V)\n"
               "  and the RMS residual (nm). 2..%d points, |values| <= 16777 nm.\n"
               "  --write FILE: a scene include with firmware.disp_n_nm_per_V.\n"
               "  Paper: --depths-nm 500,1000,1500,2000 --offsets-nm 0,130,260,390 --deflection-nm-per-V 89 -> 23.1 nm/V\n",
               LIST_MAX);
        return 0;
    }
    if (parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || list_opt(cmd, &o[0], dz, LIST_MAX, &n) != 0
        || list_opt(cmd, &o[1], dd, LIST_MAX, &m) != 0
        || num_opt_range(cmd, &o[2], 1e-3, 2e6, "K_n must lie in [1e-3, 2e6] nm/V", &deflection_nm_per_v) != 0) {
        return EXIT_USAGE;
    }
    if (n != m) {
        return refuse("%s: --depths-nm %s --offsets-nm %s: %d depths but %d offsets", cmd, o[0].value, o[1].value, n, m);
    }
    if (n < 2) {
        return refuse("%s: --depths-nm %s: at least 2 lines are needed", cmd, o[0].value);
    }
    for (i = 0; i < n; i++) {
        if (fabs(dz[i]) * 1000.0 > FW_CALIB_LINES_RANGE_PM) {
            return refuse("%s: --depths-nm %s: |%g| nm exceeds %d nm", cmd, o[0].value, dz[i], FW_CALIB_LINES_RANGE_PM / 1000);
        }
        if (fabs(dd[i]) * 1000.0 > FW_CALIB_LINES_RANGE_PM) {
            return refuse("%s: --offsets-nm %s: |%g| nm exceeds %d nm", cmd, o[1].value, dd[i], FW_CALIB_LINES_RANGE_PM / 1000);
        }
        dzp[i] = fwu_pm_from_nm(dz[i]);
        ddp[i] = fwu_pm_from_nm(dd[i]);
    }
    st = fw_calib_lines_cn(dzp, ddp, n, fwu_pm_per_v_from_nm_per_v(deflection_nm_per_v), &disp_n_pm_per_v, &res);
    if (st != FW_OK) {
        return refuse("%s: --depths-nm %s: the depths must not all be equal and |offset/depth| must stay below 128 (%s)",
            cmd, o[0].value, status_name(st));
    }
    if (o[3].value != NULL) {
        printf("{\"command\": \"calib lines\", \"status\": \"ok\", \"cn_nm_per_V\": %.3f, \"residual_nm\": %.3f, "
               "\"lines\": %d}\n", fwu_nm_per_v_from_pm_per_v(disp_n_pm_per_v), fwu_nm_from_pm(res), n);
    } else {
        printf("C_n from inscribed lines (firmware fw_calib_lines_cn)\n");
        printf("  lines                  %d\n", n);
        printf("  C_n                    %.3f nm/V\n", fwu_nm_per_v_from_pm_per_v(disp_n_pm_per_v));
        printf("  RMS residual           %.3f nm\n", fwu_nm_from_pm(res));
        printf("  status                 ok\n");
    }
    if (o[4].value != NULL) {
        char keys[128];
        snprintf(keys, sizeof keys, "  disp_n_nm_per_V: %.3f   # C_n\n", fwu_nm_per_v_from_pm_per_v(disp_n_pm_per_v));
        return write_include(cmd, o[4].value, argc, argv, keys);
    }
    return 0;
}

/* ---- model wire --------------------------------------------------------- */

/* model wire's answer: JSON, or lines for people. */
static void print_wire(bool s_defined, int32_t s_pm, double k, double f_min_nn, double f, const char *regime, double lambda, double at,
                       double len, bool json)
{
    if (json) {
        printf("{\"command\": \"model wire\", \"status\": \"ok\", ");
        if (s_defined) {
            printf("\"static_point_nm\": %.3f, ", fwu_nm_from_pm(s_pm));
        } else {
            printf("\"static_point_nm\": null, ");
        }
        printf("\"min_force_per_fL\": %.6f, \"min_force_nN\": %.6f, \"regime\": \"%s\", "
               "\"aspect_ratio\": %.3f, \"rigid_rod_model_valid\": %s}\n",
               k, f_min_nn, regime, lambda, lambda <= 15.0 ? "true" : "false");
    } else {
        printf("rigid rod pushed at l = %g nm of L = %g nm (firmware fw_wire_static_point)\n", at, len);
        if (s_defined) {
            printf("  static point S         %.3f nm from end A\n", fwu_nm_from_pm(s_pm));
        } else {
            printf("  static point S         none: pure translation (bifurcation at L/2)\n");
        }
        printf("  regime                 %s\n", regime);
        printf("  F_min / (f L)          %.6f\n", k);
        printf("  F_min                  %.6f nN (f = %g nN/um)\n", f_min_nn, f);
        printf("  aspect ratio L/d       %.2f%s\n", lambda,
               lambda <= 15.0 ? "" : "  (above 15: the rod bends, rigid model out of scope)");
        printf("  status                 ok\n");
    }
}

static void help_model_wire(void)
{
    printf("usage: afm_calc model wire --length-nm L --diameter-nm D --push-at-nm l [--f-nN-per-um f] [--json]\n"
           "  Rigid rod pushed perpendicular to its axis at l from end A (physics.md section 6):\n"
           "  static point S (distance from A; none at l = L/2), minimum push F_min / (f L)\n"
           "  (0.414 at an end, 1 at the middle) and F_min for friction density f (default 1 nN/um).\n");
}

static int cmd_model_wire(int argc, char **argv)
{
    const char *cmd = "model wire";
    opt_t o[] = {
        { "--length-nm", NULL, 0, 1 }, { "--diameter-nm", NULL, 0, 1 }, { "--push-at-nm", NULL, 0, 1 },
        { "--f-nN-per-um", NULL, 0, 0 }, { "--json", NULL, 1, 0 },
    };
    double len;
    double dia;
    double at;
    double f = 1.0;
    int32_t len_pm;
    int32_t at_pm = 0;
    fw_wire_static_t st;
    fw_status_t s;
    const char *regime;
    double k;
    double f_min_nn;
    double lambda;
    if (wants_help(argc, argv)) {
        help_model_wire();
        return 0;
    }
    if (parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || num_opt_range(cmd, &o[0], 0.001, FW_WIRE_LENGTH_MAX_PM / 1000.0, "0 < L <= 1073741 nm", &len) != 0
        || num_opt_range(cmd, &o[1], 0.001, 1e9, "D must be > 0", &dia) != 0
        || num_opt(cmd, &o[2], &at) != 0
        || (o[3].value != NULL && num_opt_range(cmd, &o[3], 0.0, 1e6, "f must be >= 0", &f) != 0)) {
        return EXIT_USAGE;
    }
    len_pm = fwu_pm_from_nm(len);
    if (at < 0.0 || at > len) {
        return refuse("%s: --push-at-nm %s: must lie on the rod, in [0, %g] nm", cmd, o[2].value, len);
    }
    if (to_i32(cmd, &o[2], at * 1e3, &at_pm) != 0) {
        return EXIT_USAGE;
    }
    s = fw_wire_static_point(len_pm, at_pm, &st);
    if (s != FW_OK) {
        return refuse("%s: --push-at-nm %s: %s", cmd, o[2].value, status_name(s));
    }
    regime = (st.regime == FW_WIRE_TRANSLATE) ? "translate"
             : (st.regime == FW_WIRE_ROTATE_NEAR_B) ? "rotate_about_far_end_side" : "rotate_about_near_end_side";
    k = fwu_from_q30(st.k);
    lambda = len / dia;
    {
        /* F_min = k(l) f L by the firmware's own friction and threshold */
        fw_wire_tip_t tip;
        fw_wire_t w;
        bool sat = false;
        if (fw_wire_tip_init(&tip, 0, 20000, fwu_pn_per_um_from_nn_per_um(f), 0, 0) != FW_OK
            || fw_wire_init(&w, 0, 0, 0, len_pm, len_pm) != FW_OK) {
            return refuse("%s: --f-nN-per-um %s: the firmware refuses this friction or length", cmd, o[3].value ? o[3].value : "1");
        }
        f_min_nn = fwu_nn_from_pn(fw_wire_push_threshold_pn(st.k, fw_wire_friction_pn(&tip, &w), &sat));
    }
    print_wire(st.s_defined, st.s_pm, k, f_min_nn, f, regime, lambda, at, len, o[4].value != NULL);
    return 0;
}

/* ---- calc force --------------------------------------------------------- */

typedef struct {
    double spring_n_per_m;
    double deflection_nm_per_v;
    double lateral_gain_nn_per_v;
    double h_um;
    double l_um;
    double mu;
    double adh_nn;
} probe_t;

static void probe_default(probe_t *p)
{
    /* the paper's probe (fw_paper_probe.h), in the calculator's units */
    p->spring_n_per_m = FW_PAPER_KN_MN_PER_M * 1e-3;
    p->deflection_nm_per_v = FW_PAPER_DEFLECTION_PM_PER_V * 1e-3;
    p->lateral_gain_nn_per_v = FW_PAPER_LATERAL_GAIN_PN_PER_V * 1e-3;
    p->h_um = FW_PAPER_TIP_HEIGHT_NM * 1e-3;
    p->l_um = FW_PAPER_LEVER_LENGTH_NM * 1e-3;
    p->mu = FW_PAPER_MU_PPM * 1e-6;
    p->adh_nn = 0.0;
}

static int probe_read(const char *cmd, const char *path, probe_t *p)
{
    FILE *fp = fopen(path, "r");
    char line[256];
    int lineno = 0;
    if (fp == NULL) {
        return refuse("%s: --probe %s: cannot open (%s)", cmd, path, strerror(errno));
    }
    while (fgets(line, sizeof line, fp) != NULL) {
        char key[64];
        char *eq;
        char *end;
        double v;
        char *s = line;
        size_t n;
        lineno++;
        while (*s == ' ' || *s == '\t') {
            s++;
        }
        if (*s == '#' || *s == '\n' || *s == '\0') {
            continue;
        }
        eq = strchr(s, '=');
        if (eq == NULL) {
            fclose(fp);
            return refuse("%s: --probe %s: line %d: expected 'key = value'", cmd, path, lineno);
        }
        n = (size_t)(eq - s);
        while (n > 0 && (s[n - 1] == ' ' || s[n - 1] == '\t')) {
            n--;
        }
        if (n == 0 || n >= sizeof key) {
            fclose(fp);
            return refuse("%s: --probe %s: line %d: bad key", cmd, path, lineno);
        }
        memcpy(key, s, n);
        key[n] = '\0';
        errno = 0;
        v = strtod(eq + 1, &end);
        while (*end == ' ' || *end == '\t' || *end == '\n' || *end == '\r') {
            end++;
        }
        if (end == eq + 1 || errno != 0 || *end != '\0' || !isfinite(v)) {
            fclose(fp);
            return refuse("%s: --probe %s: line %d: value of %s is not a number", cmd, path, lineno, key);
        }
        if (strcmp(key, "spring_N_per_m") == 0) {
            p->spring_n_per_m = v;
        } else if (strcmp(key, "deflection_nm_per_V") == 0) {
            p->deflection_nm_per_v = v;
        } else if (strcmp(key, "lateral_nN_per_V") == 0) {
            p->lateral_gain_nn_per_v = v;
        } else if (strcmp(key, "tip_height_um") == 0) {
            p->h_um = v;
        } else if (strcmp(key, "lever_length_um") == 0) {
            p->l_um = v;
        } else if (strcmp(key, "mu") == 0) {
            p->mu = v;
        } else if (strcmp(key, "adhesion_nN") == 0) {
            p->adh_nn = v;
        } else {
            fclose(fp);
            return refuse("%s: --probe %s: line %d: unknown key '%s' (spring_N_per_m, deflection_nm_per_V, lateral_nN_per_V, "
                "tip_height_um, lever_length_um, mu, adhesion_nN)", cmd, path, lineno, key);
        }
    }
    fclose(fp);
    return 0;
}

/* calc force's answer: JSON, or lines for people. */
static void print_force(const int32_t fa[3], const int32_t fc[3], uint32_t flags, bool json)
{
    if (json) {
        printf("{\"command\": \"calc force\", \"status\": \"ok\", \"fx_nN\": %.3f, \"fy_nN\": %.3f, \"fz_nN\": %.3f, "
               "\"frame\": \"AFM\", \"fx_cantilever_nN\": %.3f, \"fy_cantilever_nN\": %.3f, "
               "\"fx_unobservable\": %s, \"saturated\": %s}\n",
               fwu_nn_from_pn(fa[0]), fwu_nn_from_pn(fa[1]), fwu_nn_from_pn(fa[2]), fwu_nn_from_pn(fc[0]), fwu_nn_from_pn(fc[1]),
               (flags & FW_FLAG_FX_UNOBSERVABLE) ? "true" : "false",
               (flags & FW_FLAG_SAT_FORCE) ? "true" : "false");
    } else {
        printf("force of the sample on the tip (firmware fw_force_solve_pn), AFM frame\n");
        printf("  F_x                    %.3f nN\n", fwu_nn_from_pn(fa[0]));
        printf("  F_y                    %.3f nN\n", fwu_nn_from_pn(fa[1]));
        printf("  F_z                    %.3f nN\n", fwu_nn_from_pn(fa[2]));
        printf("  cantilever frame       F_x %.3f nN, F_y %.3f nN\n", fwu_nn_from_pn(fc[0]), fwu_nn_from_pn(fc[1]));
        if (flags & FW_FLAG_FX_UNOBSERVABLE) {
            printf("  note                   |sin theta| < 1/4: F_x from the friction fallback (blended)\n");
        }
        if (flags & FW_FLAG_SAT_FORCE) {
            printf("  note                   a force was clamped to the firmware's int32 pN range\n");
        }
        printf("  status                 ok\n");
    }
}

static void help_calc_force(void)
{
    printf("usage: afm_calc calc force --sn V --sl V --theta-deg T --scan-angle-deg A [--probe FILE] [--json]\n"
           "  Force of the sample on the tip (physics.md section 1, eq. 1a-1c, 3) from the\n"
           "  photodiode signals S_n, S_l (volts, |S| < 256), the tip's direction of motion T\n"
           "  in the cantilever frame and the scan angle A (alpha = A - 270 deg); printed in\n"
           "  the AFM frame, nN. Near T = 0 or 180 deg (|sin T| < 1/4) F_x comes (partly) from\n"
           "  the friction fallback mu (F_z + F_adh).\n"
           "  --probe FILE: 'key = value' lines (spring_N_per_m, deflection_nm_per_V, lateral_nN_per_V,\n"
           "  tip_height_um, lever_length_um, mu, adhesion_nN); default: the paper's probe\n"
           "  (0.12 N/m, 89 nm/V, 37.9 nN/V, h 17.3 um, l 100 um, mu 0.0865, no adhesion).\n");
}

static int cmd_calc_force(int argc, char **argv)
{
    const char *cmd = "calc force";
    opt_t o[] = {
        { "--sn", NULL, 0, 1 }, { "--sl", NULL, 0, 1 }, { "--theta-deg", NULL, 0, 1 },
        { "--scan-angle-deg", NULL, 0, 1 }, { "--probe", NULL, 0, 0 }, { "--json", NULL, 1, 0 },
    };
    probe_t p;
    double sn;
    double sl;
    double theta;
    double scan;
    fw_force_t f;
    fw_status_t st;
    q30_t ts;
    q30_t tc;
    q30_t as;
    q30_t ac;
    int32_t fc[3];
    int32_t fa[3];
    uint32_t flags = 0;
    bool sat = false;
    if (wants_help(argc, argv)) {
        help_calc_force();
        return 0;
    }
    if (parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || num_opt_range(cmd, &o[0], -255.0, 255.0, "|S_n| must stay below 256 V", &sn) != 0
        || num_opt_range(cmd, &o[1], -255.0, 255.0, "|S_l| must stay below 256 V", &sl) != 0
        || num_opt_range(cmd, &o[2], -1e6, 1e6, "degrees", &theta) != 0
        || num_opt_range(cmd, &o[3], -1e6, 1e6, "degrees", &scan) != 0) {
        return EXIT_USAGE;
    }
    probe_default(&p);
    if (o[4].value != NULL && probe_read(cmd, o[4].value, &p) != 0) {
        return EXIT_USAGE;
    }
    {
        fw_rule_t rule = fw_force_check(fwu_pn_per_v_from_nn_per_v(p.spring_n_per_m * p.deflection_nm_per_v),
                                        fwu_pn_per_v_from_nn_per_v(p.lateral_gain_nn_per_v), fwu_nm_from_um(p.h_um),
                                        fwu_nm_from_um(p.l_um), fwu_ppm(p.mu), fwu_pn_from_nn(p.adh_nn));
        if (rule != FW_RULE_OK) {
            return refuse("%s: --probe %s: the firmware refuses this probe: %s (fw_force_check, rule %d)", cmd,
                o[4].value != NULL ? o[4].value : "(default)", fw_rule_text(rule), (int)rule);
        }
    }
    (void)fw_force_init(&f, fwu_pn_per_v_from_nn_per_v(p.spring_n_per_m * p.deflection_nm_per_v),
                        fwu_pn_per_v_from_nn_per_v(p.lateral_gain_nn_per_v), fwu_nm_from_um(p.h_um), fwu_nm_from_um(p.l_um),
                        fwu_ppm(p.mu), fwu_pn_from_nn(p.adh_nn));
    fw_math_sincos_q30(fw_math_bam_from_mdeg(fwu_mdeg_from_deg(fmod(theta, 360.0))), &ts, &tc);
    fw_math_sincos_q30(fw_math_bam_from_mdeg(fwu_mdeg_from_deg(fmod(scan, 360.0)) - 270000), &as, &ac);
    /* the direction as the vector (cos T, sin T) in 2.30: the solver takes any length */
    st = fw_force_solve_pn(&f, fwu_q23_from_v(sn), fwu_q23_from_v(sl), tc, ts, fc, &flags);
    if (st != FW_OK) {
        return refuse("%s: fw_force_solve_pn failed (%s)", cmd, status_name(st));
    }
    fw_force_rotate_pn(fc, ac, as, fa, &sat);
    if (sat) {
        flags |= FW_FLAG_SAT_FORCE;
    }
    print_force(fa, fc, flags, o[5].value != NULL);
    return 0;
}

/* The paper's probe as the firmware's header has it (fw_paper_probe.h),
 * under the scene's probe key names: the one copy the bench's scripts read. */
static int cmd_calc_probe(int argc, char **argv)
{
    const char *cmd = "calc probe";
    opt_t o[] = { { "--json", NULL, 1, 0 } };
    probe_t p;
    if (wants_help(argc, argv)) {
        printf("usage: afm_calc calc probe [--json]\n"
               "  The paper's probe (fw_paper_probe.h): what a scene without probe keys gets.\n");
        return 0;
    }
    if (parse_opts(cmd, argc, argv, o, 1) != 0) {
        return EXIT_USAGE;
    }
    probe_default(&p);
    if (o[0].value != NULL) {
        printf("{\"command\": \"%s\", \"status\": \"ok\", \"spring_N_per_m\": %.6f, \"deflection_nm_per_V\": %.3f, "
               "\"lateral_nN_per_V\": %.3f, \"tip_height_um\": %.3f, \"lever_length_um\": %.3f, \"mu\": %.6f, "
               "\"normal_gain_nN_per_V\": %.3f, \"cn_nm_per_V\": %.3f}\n",
               cmd, p.spring_n_per_m, p.deflection_nm_per_v, p.lateral_gain_nn_per_v, p.h_um, p.l_um, p.mu,
               FW_PAPER_NORMAL_GAIN_PN_PER_V * 1e-3, FW_PAPER_DISP_PM_PER_V * 1e-3);
    } else {
        printf("The paper's probe (fw_paper_probe.h)\n");
        printf("  spring_N_per_m         %.4f\n  deflection_nm_per_V    %.1f\n  lateral_nN_per_V       %.1f\n", p.spring_n_per_m,
               p.deflection_nm_per_v, p.lateral_gain_nn_per_v);
        printf("  tip_height_um          %.1f\n  lever_length_um        %.1f\n  mu (tip on glass)      %.4f\n", p.h_um, p.l_um, p.mu);
        printf("  C_n (inscribed lines)  %.1f nm/V\n", FW_PAPER_DISP_PM_PER_V * 1e-3);
    }
    return 0;
}

/* ---- model squeeze ------------------------------------------------------ */

/* model squeeze's answer: JSON, or lines for people. */
static void print_squeeze(q30_t k, double psi_deg, const fw_squeeze_t *sq_in, bool squeezed, double at, double len, bool json)
{
    const fw_squeeze_t sq = *sq_in;
    if (json) {
        printf("{\"command\": \"model squeeze\", \"status\": \"ok\", \"k\": %.6f, \"psi_deg\": %.6f, "
               "\"psi_max_deg\": %.6f, \"squeezed\": %s, ",
               fwu_from_q30(k), psi_deg, fw_math_mdeg_from_bam(sq.psi_max) * 1e-3,
               squeezed ? "true" : "false");
        if (squeezed) {
            printf("\"f_r_nN\": null, \"push_nN\": null, \"df_nN\": null, \"saturated\": false}\n");
        } else {
            printf("\"f_r_nN\": %.6f, \"push_nN\": %.6f, \"df_nN\": %.6f, \"saturated\": %s}\n",
                   fwu_nn_from_pn(sq.f_r_pn), fwu_nn_from_pn(sq.push_pn), fwu_nn_from_pn(sq.df_pn),
                   (sq.flags & FW_FLAG_SAT_FORCE) != 0u ? "true" : "false");
        }
    } else {
        printf("tip-substrate-wire squeeze at l = %g nm of L = %g nm (firmware fw_wire_squeeze_solve)\n", at, len);
        printf("  k(l)                   %.6f\n", fwu_from_q30(k));
        printf("  psi = gamma + |twist|  %.4f deg\n", psi_deg);
        printf("  psi_max                %.4f deg\n", fw_math_mdeg_from_bam(sq.psi_max) * 1e-3);
        if (squeezed) {
            printf("  regime                 squeeze: psi >= psi_max, no push moves the rod\n");
        } else {
            printf("  F_r (29)               %.4f nN%s\n", fwu_nn_from_pn(sq.f_r_pn),
                   (sq.flags & FW_FLAG_SAT_FORCE) != 0u ? "  (saturated)" : "");
            printf("  push F_r cos psi       %.4f nN\n", fwu_nn_from_pn(sq.push_pn));
            printf("  dF (30)                %.4f nN%s\n", fwu_nn_from_pn(sq.df_pn),
                   sq.df_pn <= 0 ? "  (adhesion alone holds the tip)" : "");
        }
        printf("  status                 ok\n");
    }
}

static void help_model_squeeze(void)
{
    printf("usage: afm_calc model squeeze --length-nm L --push-at-nm l --gamma-deg G --mu MU --fl-nN FL\n"
           "                              --fa-ts-nN F [--twist-deg T] [--json]\n"
           "  Tip-substrate-wire squeeze (physics.md section 7, eq. 29-30) by the firmware's\n"
           "  fw_wire_squeeze_solve: a rod of length L pushed at l (k(l) of section 6) by a cone\n"
           "  of half angle G twisted by T (psi = G + |T|), wire-substrate mu, the rod's own\n"
           "  friction FL = mu F_a,os + tau A (nN) and tip-substrate adhesion F_a,ts (nN).\n"
           "  Prints psi_max = atan(1 / (k mu)), F_r (29), its horizontal part (the push that\n"
           "  moves the rod), dF = F_r sin psi - F_a,ts (30), or that the tip squeezes the rod.\n");
}

static int cmd_model_squeeze(int argc, char **argv)
{
    const char *cmd = "model squeeze";
    opt_t o[] = {
        { "--length-nm", NULL, 0, 1 }, { "--push-at-nm", NULL, 0, 1 }, { "--gamma-deg", NULL, 0, 1 },
        { "--mu", NULL, 0, 1 }, { "--fl-nN", NULL, 0, 1 }, { "--fa-ts-nN", NULL, 0, 1 },
        { "--twist-deg", NULL, 0, 0 }, { "--json", NULL, 1, 0 },
    };
    double len;
    double at;
    double gamma;
    double mu;
    double fl;
    double fats;
    double twist = 0.0;
    int32_t at_pm = 0;
    fw_wire_static_t st;
    fw_squeeze_t sq;
    fw_status_t s;
    fw_bam_t psi;
    bool squeezed;
    if (wants_help(argc, argv)) {
        help_model_squeeze();
        return 0;
    }
    if (parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || num_opt_range(cmd, &o[0], 0.001, FW_WIRE_LENGTH_MAX_PM / 1000.0, "0 < L <= 1073741 nm", &len) != 0
        || num_opt(cmd, &o[1], &at) != 0) {
        return EXIT_USAGE;
    }
    if (at < 0.0 || at > len) {
        return refuse("%s: --push-at-nm %s: must lie on the rod, in [0, %g] nm", cmd, o[1].value, len);
    }
    if (num_opt_range(cmd, &o[2], 0.0, 89.999, "0 <= gamma < 90 deg", &gamma) != 0
        || num_opt_range(cmd, &o[3], 0.0, FW_WIRE_MU_MAX_PPM / 1e6, "0 <= mu < 2", &mu) != 0
        || num_opt_range(cmd, &o[4], 0.0, 2.0e6, "0 <= FL <= 2e6 nN", &fl) != 0
        || num_opt_range(cmd, &o[5], 0.0, 2.0e6, "0 <= F_a,ts <= 2e6 nN", &fats) != 0
        || (o[6].value != NULL && num_opt_range(cmd, &o[6], -89.999, 89.999, "|twist| < 90 deg", &twist) != 0)
        || to_i32(cmd, &o[1], at * 1e3, &at_pm) != 0) {
        return EXIT_USAGE;
    }
    s = fw_wire_static_point(fwu_pm_from_nm(len), at_pm, &st);
    if (s != FW_OK) {
        return refuse("%s: --push-at-nm %s: %s", cmd, o[1].value, status_name(s));
    }
    if (gamma + fabs(twist) >= 90.0) {
        return refuse("%s: --gamma-deg %s with --twist-deg %s: psi = gamma + |twist| must stay below 90 deg", cmd, o[2].value,
            o[6].value);
    }
    psi = fw_math_bam_from_mdeg(fwu_mdeg_from_deg(gamma + fabs(twist)));
    s = fw_wire_squeeze_solve(psi, st.k, fwu_q30(mu), fwu_pn_from_nn(fl), fwu_pn_from_nn(fats), &sq);
    if (s == FW_ERR_ARG) {
        return refuse("%s: the firmware refuses these values (%s)", cmd, status_name(s));
    }
    squeezed = s == FW_ERR_DOMAIN;
    print_squeeze(st.k, gamma + fabs(twist), &sq, squeezed, at, len, o[7].value != NULL);
    return 0;
}

/* ---- dispatch ----------------------------------------------------------- */

static void usage(FILE *fp)
{
    fprintf(fp,
            "usage: afm_calc <group> <command> [options]   (each command has --help)\n"
            "  calib tilted   mu and k_theta K_l / h from friction loops on a tilted surface\n"
            "  calib lines    C_n from lines inscribed at several depths\n"
            "  model wire     static point and minimum push of a rigid nanowire\n"
            "  model squeeze  tip-substrate-wire squeeze: psi_max, F_r, the push and dF (eq. 29-30)\n"
            "  calc force     3-D tip force from S_n, S_l, theta and the scan angle\n"
            "  calc probe     the paper's probe (fw_paper_probe.h)\n");
}

int afm_calc_main(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? EXIT_USAGE : 0;
    }
    if (argc < 3) {
        return refuse("'%s' needs a command (see afm_calc --help)", argv[1]);
    }
    if (strcmp(argv[1], "calib") == 0 && strcmp(argv[2], "tilted") == 0) {
        return cmd_calib_tilted(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "calib") == 0 && strcmp(argv[2], "lines") == 0) {
        return cmd_calib_lines(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "model") == 0 && strcmp(argv[2], "wire") == 0) {
        return cmd_model_wire(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "model") == 0 && strcmp(argv[2], "squeeze") == 0) {
        return cmd_model_squeeze(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "calc") == 0 && strcmp(argv[2], "force") == 0) {
        return cmd_calc_force(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "calc") == 0 && strcmp(argv[2], "probe") == 0) {
        return cmd_calc_probe(argc - 3, argv + 3);
    }
    return refuse("unknown command '%s %s' (see afm_calc --help)", argv[1], argv[2]);
}
