/*
 * bench_sweep.c - the inputs bench_fw measures on (bench_fw.h): a random
 * sweep of the paper's probe, in segments of constant heading, with the
 * true apex angle and the double-precision reference's outputs beside.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fw_paper_probe.h"
#include "bench_fw.h"

/* ---- the sweep ---------------------------------------------------------- */

static uint64_t rng_state;

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
void paper_config(fw_board_config_t *c, int32_t scan_mdeg)
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

void make_sweep(bench_angle_t *a, size_t n, uint64_t seed)
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
