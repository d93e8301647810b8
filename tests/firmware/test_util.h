/*
 * test_util.h - helpers shared by the firmware tests: a small fixed-seed
 * PRNG (xorshift64*), double conversions of the Q formats, and a
 * worst-error tracker that prints in LSB and in physical units.
 */
#ifndef TEST_UTIL_H
#define TEST_UTIL_H

#include <stdint.h>
#include <stdio.h>
#include <math.h>
#include "fw_types.h"

#ifndef AFM_SWEEP_N
#define AFM_SWEEP_N 1000000
#endif

#define TU_PI 3.14159265358979323846
#define TU_TWO_POW(n) ((double)((uint64_t)1 << (n)))

typedef struct { uint64_t s; } tu_rng_t;

static inline void tu_rng_seed(tu_rng_t *r, uint64_t seed)
{
    r->s = seed ? seed : 0x9E3779B97F4A7C15ull;
}

static inline uint64_t tu_rng_u64(tu_rng_t *r)
{
    r->s ^= r->s >> 12;
    r->s ^= r->s << 25;
    r->s ^= r->s >> 27;
    return r->s * 0x2545F4914F6CDD1Dull;
}

static inline uint32_t tu_rng_u32(tu_rng_t *r)
{
    return (uint32_t)(tu_rng_u64(r) >> 32);
}

/* uniform int32 in [lo, hi] */
static inline int32_t tu_rng_range(tu_rng_t *r, int32_t lo, int32_t hi)
{
    uint64_t span = (uint64_t)((int64_t)hi - lo) + 1u;
    return (int32_t)((int64_t)lo + (int64_t)(tu_rng_u64(r) % span));
}

/* uniform double in [0, 1) */
static inline double tu_rng_unit(tu_rng_t *r)
{
    return (double)(tu_rng_u64(r) >> 11) * (1.0 / 9007199254740992.0);
}

static inline double tu_q(int64_t v, int frac)
{
    return (double)v / TU_TWO_POW(frac);
}

static inline double tu_bam_rad(fw_bam_t a)
{
    return (double)a / 4294967296.0 * 2.0 * TU_PI;
}

static inline double tu_wrap_pi(double a)
{
    while (a >= TU_PI) {
        a -= 2.0 * TU_PI;
    }
    while (a < -TU_PI) {
        a += 2.0 * TU_PI;
    }
    return a;
}

typedef struct {
    const char *what;
    const char *unit;
    double lsb;        /* one LSB in the physical unit */
    double worst;      /* worst |error|, physical unit */
    double sum2;
    long n;
} tu_err_t;

static inline void tu_err_init(tu_err_t *e, const char *what, const char *unit, double lsb)
{
    e->what = what;
    e->unit = unit;
    e->lsb = lsb;
    e->worst = 0.0;
    e->sum2 = 0.0;
    e->n = 0;
}

static inline void tu_err_add(tu_err_t *e, double err)
{
    double a = fabs(err);
    if (a > e->worst) {
        e->worst = a;
    }
    e->sum2 += err * err;
    e->n++;
}

static inline double tu_err_worst_lsb(const tu_err_t *e)
{
    return e->worst / e->lsb;
}

static inline void tu_err_print(const tu_err_t *e)
{
    printf("SWEEP %-28s n=%ld worst=%.3f LSB (%.4g %s) rms=%.3f LSB\n", e->what, e->n,
           e->worst / e->lsb, e->worst, e->unit,
           (e->n ? sqrt(e->sum2 / (double)e->n) : 0.0) / e->lsb);
}

#endif /* TEST_UTIL_H */
