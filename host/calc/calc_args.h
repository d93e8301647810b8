/*
 * calc_args.h - what afm_calc's units share (internal to host/calc):
 * the option table, the refusal (one line on stderr naming the option and
 * the value; returns EXIT_USAGE), the number checks, and the commands that
 * afm_calc_main dispatches to. Each helper returns 0, or EXIT_USAGE once it
 * has said why.
 */
#ifndef AFM_CALC_ARGS_H
#define AFM_CALC_ARGS_H

#include <stdint.h>
#include <stdio.h>

#include "fw_calib.h"
#include "fw_types.h"

#define EXIT_USAGE 2
#define CALC_PI 3.14159265358979323846
#define LIST_MAX FW_CALIB_LINES_MAX

typedef struct {
    const char *name;     /* "--up" */
    const char *value;    /* NULL if absent */
    int is_flag;          /* no value (--json) */
    int required;
} opt_t;

int calc_refuse(const char *fmt, ...);
int calc_wants_help(int argc, char **argv);
int calc_parse_opts(const char *cmd, int argc, char **argv, opt_t *opts, int n);
int calc_num_opt_range(const char *cmd, const opt_t *o, double lo, double hi, const char *why, double *v);
int calc_num_opt(const char *cmd, const opt_t *o, double *v);
int calc_list_opt(const char *cmd, const opt_t *o, double *out, int max, int *n);
const char *calc_status_name(fw_status_t st);
int calc_write_include(const char *cmd, const char *path, int argc, char **argv, const char *keys);
int calc_to_i32(const char *cmd, const opt_t *o, double v, int32_t *out);

/* The commands: argv holds the options after "GROUP COMMAND". */
int cmd_calib_tilted(int argc, char **argv);
int cmd_calib_lines(int argc, char **argv);
int cmd_model_wire(int argc, char **argv);
int cmd_model_squeeze(int argc, char **argv);
int cmd_calc_force(int argc, char **argv);
int cmd_calc_probe(int argc, char **argv);

#endif /* AFM_CALC_ARGS_H */
