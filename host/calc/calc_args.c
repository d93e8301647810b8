/*
 * afm_calc's arguments (calc_args.h): options read, numbers checked, refusals
 * said in one line, --write's scene include.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
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
#include "calc_args.h"

/* ---- argument handling ------------------------------------------------- */


/* Says why the arguments are refused (one line on stderr); returns EXIT_USAGE. */
int calc_refuse(const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "afm_calc: ");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return EXIT_USAGE;
}

int calc_wants_help(int argc, char **argv)
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
int calc_parse_opts(const char *cmd, int argc, char **argv, opt_t *opts, int n)
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
                        return calc_refuse("%s: option %s needs a value", cmd, opts[k].name);
                    }
                    opts[k].value = argv[++i];
                }
            }
        }
        if (!found) {
            return calc_refuse("%s: unknown option '%s' (see %s --help)", cmd, argv[i], cmd);
        }
    }
    for (k = 0; k < n; k++) {
        if (opts[k].required && opts[k].value == NULL) {
            return calc_refuse("%s: missing option %s (see %s --help)", cmd, opts[k].name, cmd);
        }
    }
    return 0;
}

int calc_num_opt(const char *cmd, const opt_t *o, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(o->value, &end);
    if (end == o->value || *end != '\0' || errno != 0 || !isfinite(*v)) {
        return calc_refuse("%s: %s %s: not a number", cmd, o->name, o->value);
    }
    return 0;
}

int calc_num_opt_range(const char *cmd, const opt_t *o, double lo, double hi, const char *why, double *v)
{
    if (calc_num_opt(cmd, o, v) != 0) {
        return EXIT_USAGE;
    }
    if (*v < lo || *v > hi) {
        return calc_refuse("%s: %s %s: out of range, %s", cmd, o->name, o->value, why);
    }
    return 0;
}

/* *n: the count of values read into out[0..max) */
int calc_list_opt(const char *cmd, const opt_t *o, double *out, int max, int *n)
{
    const char *p = o->value;
    *n = 0;
    while (*p != '\0') {
        char *end;
        double v;
        if (*n >= max) {
            return calc_refuse("%s: %s %s: at most %d values", cmd, o->name, o->value, max);
        }
        errno = 0;
        v = strtod(p, &end);
        if (end == p || errno != 0 || !isfinite(v) || (*end != ',' && *end != '\0')) {
            return calc_refuse("%s: %s %s: not a comma-separated list of numbers", cmd, o->name, o->value);
        }
        out[(*n)++] = v;
        p = (*end == ',') ? end + 1 : end;
    }
    return 0;
}

const char *calc_status_name(fw_status_t st)
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
int calc_write_include(const char *cmd, const char *path, int argc, char **argv, const char *keys)
{
    char tmp[4096];
    FILE *f;
    int i;
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        return calc_refuse("%s: --write %s: path too long", cmd, path);
    }
    f = fopen(tmp, "w");
    if (f == NULL) {
        return calc_refuse("%s: --write %s: cannot write: %s", cmd, path, strerror(errno));
    }
    fprintf(f, "# The card's calibrated constants, measured by ./afm %s", cmd);
    for (i = 0; i < argc; i++) {
        fprintf(f, " %s", argv[i]);
    }
    fprintf(f, "\n# A scene takes them with  include: %s\nfirmware:\n%s", path, keys);
    if (fclose(f) != 0 || rename(tmp, path) != 0) {
        remove(tmp);
        return calc_refuse("%s: --write %s: cannot write: %s", cmd, path, strerror(errno));
    }
    return 0;
}

int calc_to_i32(const char *cmd, const opt_t *o, double v, int32_t *out)
{
    if (!(v >= -2147483648.0 && v <= 2147483647.0)) {
        return calc_refuse("%s: %s %s: does not fit the firmware's 32-bit units", cmd, o->name, o->value);
    }
    *out = fwu_i32(v);
    return 0;
}
