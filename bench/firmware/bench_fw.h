/*
 * bench_fw.h - what bench_fw.c (the measured loops, the command line, the
 * table) and bench_sweep.c (the inputs it measures on) share: the sweep's
 * constants, one angle's buffers and chains, and the sweep's makers.
 */
#ifndef BENCH_FW_H
#define BENCH_FW_H

#include <stddef.h>
#include <stdint.h>

#include "fw_board.h"
#include "fw_board16.h"
#include "bench_ref.h"

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

/* The paper's board configuration at scan angle scan_mdeg (millidegrees). */
void paper_config(fw_board_config_t *c, int32_t scan_mdeg);
/* n samples of a random sweep for angle a (segments, loads, pushes, noise), from seed. */
void make_sweep(bench_angle_t *a, size_t n, uint64_t seed);

#endif /* BENCH_FW_H */
