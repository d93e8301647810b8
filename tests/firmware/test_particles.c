/* test_particles.c - fw_particles: contact test, projection along the line
 * of centres, zero-length vectors, chains, capacity. */
#include <math.h>
#include "unity.h"
#include "fw_particles.h"
#include "fw_math.h"
#include "test_util.h"

#define CAP 8
#define R_TIP 20000      /* 20 nm */
#define R_P 50000        /* 50 nm latex */
#define THR 2000         /* 2 nN */

static fw_particle_t store[CAP];
static fw_particles_t m;

void setUp(void)
{
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_init(&m, store, CAP, R_TIP));
}
void tearDown(void) {}

/* The contact force the card passes with no tip-substrate friction:
 * |F_xy| (fw_force_lateral_excess_pn with mu = 0). */
static int64_t excess_of(const int32_t force[3])
{
    return (int64_t)llround(sqrt((double)force[0] * force[0] + (double)force[1] * force[1]));
}

static fw_status_t update(const int32_t tip[3], const int32_t force[3])
{
    return fw_particles_update(&m, tip, force, excess_of(force));
}

static double dist_to(const fw_particle_t *p, double x, double y)
{
    return sqrt((p->x_pm - x) * (p->x_pm - x) + (p->y_pm - y) * (p->y_pm - y));
}

static void test_particles_init_and_add_validate_and_fill_capacity(void)
{
    fw_particles_t x;
    int i;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_init(&x, store, -1, R_TIP));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_init(&x, NULL, 0, R_TIP));   /* a model that holds none */
    TEST_ASSERT_EQUAL_INT(FW_ERR_CAPACITY, fw_particles_add(&x, 1, 0, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_init(&x, NULL, 4, R_TIP));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_init(&x, store, 4, -1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_add(&m, 1, 0, 0, 0, THR));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_add(&m, 1, 0, 0, R_P, -1));
    for (i = 0; i < CAP; i++) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, i, i * 1000000, 0, R_P, THR));
    }
    TEST_ASSERT_EQUAL_INT(FW_ERR_CAPACITY, fw_particles_add(&m, 99, 0, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT32(CAP, fw_particles_count(&m));
    TEST_ASSERT_EQUAL_INT32(3, fw_particles_get(&m, 3)->id);
    TEST_ASSERT_NULL(fw_particles_get(&m, CAP));
    TEST_ASSERT_NULL(fw_particles_get(&m, -1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_set_margin(&m, -1));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_init(&x, store, 4, (1 << 30) + 1));
}

static void test_particles_overlap_without_contact_force_does_not_move(void)
{
    const int32_t tip[3] = { 0, 0, 0 };
    const int32_t force[3] = { -900, 0, 1000 };   /* below THR / 2 */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 7, 60000, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, update(tip, force));
    TEST_ASSERT_EQUAL_INT32(60000, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_TRUE((fw_particles_get(&m, 0)->flags & FW_PARTICLE_OVERLAP) != 0u);
    TEST_ASSERT_EQUAL_UINT32(0u, fw_particles_flags(&m));
}

static void test_particles_push_projects_along_line_of_centres(void)
{
    /* apex 60 nm from the centre at 36.87 deg, contact force 1.5 nN > 1 nN */
    const int32_t tip[3] = { 0, 0, -5000 };
    const int32_t force[3] = { -1500, 0, 0 };
    const fw_particle_t *p;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 7, 48000, 36000, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, update(tip, force));
    p = fw_particles_get(&m, 0);
    /* new centre = 70 nm * (0.8, 0.6) */
    TEST_ASSERT_EQUAL_INT32(56000, p->x_pm);
    TEST_ASSERT_EQUAL_INT32(42000, p->y_pm);
    TEST_ASSERT_TRUE((p->flags & FW_PARTICLE_PUSHED) != 0u);
    TEST_ASSERT_EQUAL_UINT32(FW_FLAG_CONTACT, fw_particles_flags(&m));
}

static void test_particles_apex_on_centre_uses_push_direction(void)
{
    const int32_t tip[3] = { 1000, 2000, 0 };
    const int32_t force[3] = { 0, -1500, 0 };    /* tip pushed along +y */
    const fw_particle_t *p;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, 1000, 2000, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, update(tip, force));
    p = fw_particles_get(&m, 0);
    TEST_ASSERT_EQUAL_INT32(1000, p->x_pm);
    TEST_ASSERT_EQUAL_INT32(2000 + R_TIP + R_P, p->y_pm);
}

static void test_particles_zero_force_and_zero_threshold_never_moves(void)
{
    const int32_t tip[3] = { 0, 0, 0 };
    const int32_t force[3] = { 0, 0, 0 };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, 0, 0, R_P, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, update(tip, force));
    TEST_ASSERT_EQUAL_INT32(0, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_EQUAL_INT32(0, fw_particles_get(&m, 0)->y_pm);
}

static void test_particles_contact_exactly_at_half_threshold_and_one_pn_over(void)
{
    /* excess = THR / 2 exactly: no contact; one pN over: pushed */
    const int32_t tip[2] = { 0, 0 };
    const int32_t force[2] = { -2500, 0 };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, 60000, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_update(&m, tip, force, THR / 2));
    TEST_ASSERT_EQUAL_INT32(60000, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_TRUE((fw_particles_get(&m, 0)->flags & FW_PARTICLE_OVERLAP) != 0u);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_update(&m, tip, force, THR / 2 + 1));
    TEST_ASSERT_EQUAL_INT32(R_TIP + R_P, fw_particles_get(&m, 0)->x_pm);
    /* a margin moves the decision by its size */
    setUp();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_set_margin(&m, 300));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, 60000, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_update(&m, tip, force, THR / 2 + 300));
    TEST_ASSERT_EQUAL_INT32(60000, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_update(&m, tip, force, THR / 2 + 301));
    TEST_ASSERT_EQUAL_INT32(R_TIP + R_P, fw_particles_get(&m, 0)->x_pm);
    /* a negative excess (the tip's friction above |F_xy|) is no contact */
    setUp();
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, 60000, 0, R_P, 0));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_update(&m, tip, force, -5));
    TEST_ASSERT_EQUAL_INT32(60000, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_particles_update(&m, NULL, force, 0));
}

static void test_particles_chain_pushes_overlapping_neighbours(void)
{
    const int32_t tip[3] = { 0, 0, 0 };
    const int32_t force[3] = { -1500, 0, 0 };
    int32_t i;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, 60000, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 2, 165000, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 3, 268000, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 4, 900000, 0, R_P, THR));
    TEST_ASSERT_EQUAL_INT(FW_OK, update(tip, force));
    TEST_ASSERT_EQUAL_INT32(70000, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_EQUAL_INT32(170000, fw_particles_get(&m, 1)->x_pm);
    TEST_ASSERT_EQUAL_INT32(270000, fw_particles_get(&m, 2)->x_pm);
    TEST_ASSERT_EQUAL_INT32(900000, fw_particles_get(&m, 3)->x_pm);
    TEST_ASSERT_TRUE((fw_particles_get(&m, 2)->flags & FW_PARTICLE_CHAINED) != 0u);
    TEST_ASSERT_TRUE((fw_particles_get(&m, 3)->flags & (FW_PARTICLE_CHAINED | FW_PARTICLE_PUSHED)) == 0u);
    /* coincident neighbours: pushed along the push direction, no division by 0 */
    setUp();
    for (i = 0; i < 3; i++) {
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, i, 60000, 0, R_P, THR));
    }
    TEST_ASSERT_EQUAL_INT(FW_OK, update(tip, force));
    TEST_ASSERT_EQUAL_INT32(70000, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_TRUE(fw_particles_get(&m, 1)->x_pm >= 170000);
}

static void test_particles_projection_sweep_distance_exact(void)
{
    tu_rng_t rng;
    tu_err_t ed;
    tu_err_t ep;
    long i;
    tu_rng_seed(&rng, 51);
    tu_err_init(&ed, "particles_contact_dist", "pm", 1.0);
    tu_err_init(&ep, "particles_centre_vs_double", "pm", 1.0);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        int32_t r = tu_rng_range(&rng, 1, 10000000);
        int32_t dmax = R_TIP + r;
        int32_t cx = tu_rng_range(&rng, -2000000000, 2000000000);
        int32_t cy = tu_rng_range(&rng, -2000000000, 2000000000);
        int32_t tip[3] = { cx + tu_rng_range(&rng, -dmax + 1, dmax - 1) / 2,
                           cy + tu_rng_range(&rng, -dmax + 1, dmax - 1) / 2, 0 };
        const int32_t force[3] = { 0, -3000, 0 };
        const fw_particle_t *p;
        double vx = (double)cx - tip[0];
        double vy = (double)cy - tip[1];
        double len = sqrt(vx * vx + vy * vy);
        (void)fw_particles_init(&m, store, 1, R_TIP);
        (void)fw_particles_add(&m, 0, cx, cy, r, THR);
        (void)update(tip, force);
        p = fw_particles_get(&m, 0);
        TEST_ASSERT_TRUE((p->flags & FW_PARTICLE_PUSHED) != 0u);
        tu_err_add(&ed, dist_to(p, tip[0], tip[1]) - (R_TIP + r));
        if (len > 0.0) {
            tu_err_add(&ep, p->x_pm - (tip[0] + (R_TIP + r) * vx / len));
            tu_err_add(&ep, p->y_pm - (tip[1] + (R_TIP + r) * vy / len));
        }
    }
    tu_err_print(&ed);
    tu_err_print(&ep);
    TEST_ASSERT_TRUE(ed.worst <= 1.0);
    TEST_ASSERT_TRUE(ep.worst <= 1.0);
}

static void test_particles_shift_saturates_with_flag(void)
{
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_particles_add(&m, 1, INT32_MAX - 5, 0, R_P, THR));
    fw_particles_shift(&m, 10, -3);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_particles_get(&m, 0)->x_pm);
    TEST_ASSERT_EQUAL_INT32(-3, fw_particles_get(&m, 0)->y_pm);
    TEST_ASSERT_TRUE((fw_particles_get(&m, 0)->flags & FW_PARTICLE_SAT_POS) != 0u);
}

static void test_particles_down_threshold_edges(void)
{
    /* H_th = base / (1 - mu tan psi); at psi_max = atan(1 / mu) none moves it */
    const fw_bam_t deg20 = fw_math_bam_from_mdeg(20000);
    const fw_bam_t deg45 = FW_BAM_QUARTER_TURN / 2u;
    double ref = 10000.0 / (1.0 - 0.3 * tan(20.0 * TU_PI / 180.0));
    TEST_ASSERT_DOUBLE_WITHIN(1.0, ref, (double)fw_particles_down_threshold_pn(10000, 300000, deg20));
    TEST_ASSERT_EQUAL_INT32(10000, fw_particles_down_threshold_pn(10000, 300000, 0u));     /* flat: F_down = 0 */
    TEST_ASSERT_EQUAL_INT32(10000, fw_particles_down_threshold_pn(10000, 0, deg20));       /* no friction to raise */
    TEST_ASSERT_EQUAL_INT32(0, fw_particles_down_threshold_pn(0, 300000, deg20));
    TEST_ASSERT_EQUAL_INT32(0, fw_particles_down_threshold_pn(-5, 300000, deg20));         /* a caller bug: clamped */
    /* mu 1: psi_max = 45 deg exactly; one LSB below is finite, and saturates */
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_particles_down_threshold_pn(10000, 1000000, deg45));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_particles_down_threshold_pn(10000, 1000000, deg45 + 1u));
    TEST_ASSERT_TRUE(fw_particles_down_threshold_pn(10, 1000000, deg45 - 100000u) < INT32_MAX);
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_particles_down_threshold_pn(INT32_MAX, 300000, deg20));   /* saturated */
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_particles_down_threshold_pn(10000, 300000, FW_BAM_QUARTER_TURN));
    TEST_ASSERT_EQUAL_INT32(10000, fw_particles_down_threshold_pn(10000, -1, deg20));     /* negative mu as 0 */
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_particles_init_and_add_validate_and_fill_capacity);
    RUN_TEST(test_particles_overlap_without_contact_force_does_not_move);
    RUN_TEST(test_particles_push_projects_along_line_of_centres);
    RUN_TEST(test_particles_apex_on_centre_uses_push_direction);
    RUN_TEST(test_particles_zero_force_and_zero_threshold_never_moves);
    RUN_TEST(test_particles_contact_exactly_at_half_threshold_and_one_pn_over);
    RUN_TEST(test_particles_chain_pushes_overlapping_neighbours);
    RUN_TEST(test_particles_projection_sweep_distance_exact);
    RUN_TEST(test_particles_shift_saturates_with_flag);
    RUN_TEST(test_particles_down_threshold_edges);
    return UNITY_END();
}
