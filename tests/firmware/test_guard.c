/* test_guard.c - fw_guard, the force interlock, alone (through the card:
 * test_guard_card.c):
 * the limits' rules and defaults; the trip at the edges (exactly at the
 * limit, one pN over, the sign flipped, the lateral channel alone, a
 * saturated ADC sample, INT32 extremes); the card's unrounded lateral
 * comparison against the rounded force; the latch while the set point
 * stays; the release one LSB either side of the hysteresis, of the xy
 * distance, and by lifting; a trip again after the release; the lateral
 * force against a double reference. */
#include <string.h>
#include "unity.h"
#include "fw_guard.h"
#include "fw_card.h"
#include "fw_paper_probe.h"
#include "test_util.h"

#define LIM_N 85440     /* the paper's lever: 80 % of 10680 pN/V x 10 V */
#define LIM_L 303200    /* 80 % of 37900 pN/V x 10 V */
#define HYST (LIM_N >> FW_GUARD_HYST_SHIFT)

static fw_guard_t g;

void setUp(void)
{
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_guard_init(&g, LIM_N, LIM_L, FW_PAPER_NORMAL_GAIN_PN_PER_V,
                                               FW_PAPER_LATERAL_GAIN_PN_PER_V));
}
void tearDown(void) {}

static fw_guard_pose_t pose(int32_t load_pn, int32_t x_pm, int32_t y_pm, bool engaged)
{
    fw_guard_pose_t p;
    p.load_pn = load_pn;
    p.xy_pm[0] = x_pm;
    p.xy_pm[1] = y_pm;
    p.engaged = engaged;
    return p;
}

/* The guard's whole state, field by field (no memcmp: padding). */
static void assert_guard_equal(const fw_guard_t *a, const fw_guard_t *b, int line)
{
    UNITY_TEST_ASSERT_EQUAL_INT32(a->normal_limit_pn, b->normal_limit_pn, line, "normal_limit_pn");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->lateral_limit_pn, b->lateral_limit_pn, line, "lateral_limit_pn");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->lateral_gain_pn_per_v, b->lateral_gain_pn_per_v, line, "lateral_gain_pn_per_v");
    UNITY_TEST_ASSERT_EQUAL_INT64(a->lateral_over_q23, b->lateral_over_q23, line, "lateral_over_q23");
    UNITY_TEST_ASSERT_EQUAL_INT(a->latched, b->latched, line, "latched");
    UNITY_TEST_ASSERT_EQUAL_UINT32(a->causes, b->causes, line, "causes");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->release_load_pn, b->release_load_pn, line, "release_load_pn");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->trip_xy_pm[0], b->trip_xy_pm[0], line, "trip_xy_pm[0]");
    UNITY_TEST_ASSERT_EQUAL_INT32(a->trip_xy_pm[1], b->trip_xy_pm[1], line, "trip_xy_pm[1]");
    UNITY_TEST_ASSERT_EQUAL_UINT32(a->trips, b->trips, line, "trips");
}

static void test_guard_defaults_are_80_percent_of_full_scale_and_below_it(void)
{
    TEST_ASSERT_EQUAL_INT64(106800, fw_guard_full_scale_pn(FW_PAPER_NORMAL_GAIN_PN_PER_V));
    TEST_ASSERT_EQUAL_INT32(LIM_N, fw_guard_default_limit_pn(FW_PAPER_NORMAL_GAIN_PN_PER_V));
    TEST_ASSERT_EQUAL_INT32(LIM_L, fw_guard_default_limit_pn(FW_PAPER_LATERAL_GAIN_PN_PER_V));
    /* the smallest gain: 10 pN full scale, 8 pN; the largest: saturated to
     * INT32_MAX, still below 10 x 2^31 pN */
    TEST_ASSERT_EQUAL_INT32(8, fw_guard_default_limit_pn(1));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_guard_default_limit_pn(INT32_MAX));
    TEST_ASSERT_EQUAL_INT32(0, fw_guard_default_limit_pn(0));
    TEST_ASSERT_EQUAL_INT32(0, fw_guard_default_limit_pn(-5));
    /* every default passes its own rule */
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, fw_guard_check(fw_guard_default_limit_pn(1), fw_guard_default_limit_pn(INT32_MAX), 1,
                                                     INT32_MAX));
}

static void test_guard_refuses_limits_at_or_below_zero_and_at_or_above_full_scale(void)
{
    static const struct {
        int line;
        int32_t n;
        int32_t l;
        fw_rule_t rule;
    } rows[] = {
        { __LINE__, 0, LIM_L, FW_RULE_INTERLOCK_NORMAL },
        { __LINE__, -1, LIM_L, FW_RULE_INTERLOCK_NORMAL },
        { __LINE__, INT32_MIN, LIM_L, FW_RULE_INTERLOCK_NORMAL },
        { __LINE__, 106800, LIM_L, FW_RULE_INTERLOCK_NORMAL },   /* full scale exactly */
        { __LINE__, 106799, LIM_L, FW_RULE_OK },                 /* one pN below */
        { __LINE__, 1, LIM_L, FW_RULE_OK },
        { __LINE__, LIM_N, 0, FW_RULE_INTERLOCK_LATERAL },
        { __LINE__, LIM_N, 379000, FW_RULE_INTERLOCK_LATERAL },
        { __LINE__, LIM_N, 378999, FW_RULE_OK },
        { __LINE__, LIM_N, INT32_MAX, FW_RULE_INTERLOCK_LATERAL },
        { __LINE__, 0, 0, FW_RULE_INTERLOCK_NORMAL },            /* the normal one is named first */
    };
    size_t i;
    fw_guard_t before;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        UNITY_TEST_ASSERT_EQUAL_INT(rows[i].rule,
                                    fw_guard_check(rows[i].n, rows[i].l, FW_PAPER_NORMAL_GAIN_PN_PER_V,
                                                   FW_PAPER_LATERAL_GAIN_PN_PER_V),
                                    rows[i].line, "rule");
    }
    /* a refused init leaves the instance as it was */
    before = g;
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_guard_init(&g, 106800, LIM_L, FW_PAPER_NORMAL_GAIN_PN_PER_V,
                                                    FW_PAPER_LATERAL_GAIN_PN_PER_V));
    assert_guard_equal(&before, &g, __LINE__);
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_guard_init(NULL, LIM_N, LIM_L, 1, 1));
    /* a gain of 2^31 - 1 pN/V: full scale past int32, every positive limit passes */
    TEST_ASSERT_EQUAL_INT(FW_RULE_OK, fw_guard_check(INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX));
    /* a gain <= 0 leaves no limit */
    TEST_ASSERT_EQUAL_INT(FW_RULE_INTERLOCK_NORMAL, fw_guard_check(1, 1, 0, 1));
    TEST_ASSERT_EQUAL_INT(FW_RULE_INTERLOCK_LATERAL, fw_guard_check(1, 1, 1, -1));
}

static void test_guard_trips_one_pn_over_the_limit_not_at_it_either_sign(void)
{
    static const struct {
        int line;
        int32_t fz;
        int32_t fy;
        uint32_t flags;
        uint32_t causes;
    } rows[] = {
        { __LINE__, LIM_N, 0, 0u, 0u },                                         /* exactly at the limit */
        { __LINE__, LIM_N + 1, 0, 0u, FW_GUARD_CAUSE_NORMAL },                  /* one LSB over */
        { __LINE__, -LIM_N, 0, 0u, 0u },                                        /* the sign flipped */
        { __LINE__, -LIM_N - 1, 0, 0u, FW_GUARD_CAUSE_NORMAL },
        { __LINE__, 0, LIM_L, 0u, 0u },                                         /* the lateral channel alone */
        { __LINE__, 0, LIM_L + 1, 0u, FW_GUARD_CAUSE_LATERAL },
        { __LINE__, 0, -LIM_L, 0u, 0u },
        { __LINE__, 0, -LIM_L - 1, 0u, FW_GUARD_CAUSE_LATERAL },
        { __LINE__, LIM_N + 1, -LIM_L - 1, 0u, FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL },
        { __LINE__, 0, 0, FW_FLAG_SAT_SN, FW_GUARD_CAUSE_NORMAL },              /* saturated: over, whatever the force */
        { __LINE__, 0, 0, FW_FLAG_SAT_SL, FW_GUARD_CAUSE_LATERAL },
        { __LINE__, -5, 7, FW_FLAG_SAT_SN | FW_FLAG_SAT_SL, FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL },
        { __LINE__, 0, 0, ~(FW_FLAG_SAT_SN | FW_FLAG_SAT_SL), 0u },             /* no other flag trips */
        { __LINE__, INT32_MIN, 0, 0u, FW_GUARD_CAUSE_NORMAL },                  /* extremes: no |INT32_MIN| */
        { __LINE__, INT32_MAX, 0, 0u, FW_GUARD_CAUSE_NORMAL },
        { __LINE__, 0, INT32_MIN, 0u, FW_GUARD_CAUSE_LATERAL },
        { __LINE__, 0, INT32_MAX, 0u, FW_GUARD_CAUSE_LATERAL },
    };
    size_t i;
    for (i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        UNITY_TEST_ASSERT_EQUAL_UINT32(rows[i].causes, fw_guard_over(&g, rows[i].fz, rows[i].fy, rows[i].flags), rows[i].line,
                                       "causes");
    }
    /* the largest limit an int32 holds: INT32_MAX does not trip it, INT32_MIN does */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_guard_init(&g, INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_guard_over(&g, INT32_MAX, INT32_MAX, 0u));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_guard_over(&g, -INT32_MAX, -INT32_MAX, 0u));
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL, fw_guard_over(&g, INT32_MIN, INT32_MIN, 0u));
    /* the smallest limit: 1 pN */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_guard_init(&g, 1, 1, 1, 1));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_guard_over(&g, 1, -1, 0u));
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL, fw_guard_over(&g, -2, 2, 0u));
}

static void test_guard_latches_and_holds_while_the_set_point_stays(void)
{
    fw_guard_pose_t p = pose(120000, 1000, -2000, true);
    int i;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, fw_guard_step(&g, 0u, &p));
    TEST_ASSERT_FALSE(g.latched);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, &p));
    TEST_ASSERT_TRUE(g.latched);
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_NORMAL, g.causes);
    TEST_ASSERT_EQUAL_INT32(LIM_N - HYST, g.release_load_pn);   /* min(limit, 120 nN) - limit / 8 */
    TEST_ASSERT_EQUAL_INT32(1000, g.trip_xy_pm[0]);
    TEST_ASSERT_EQUAL_INT32(-2000, g.trip_xy_pm[1]);
    TEST_ASSERT_EQUAL_UINT32(1u, g.trips);
    /* the tip is off: no more causes; the set point stays, and so does the
     * latch; a normal trip ignores the xy set point */
    for (i = 0; i < 1000; i++) {
        TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    }
    p.xy_pm[0] += 10 * FW_GUARD_RELEASE_MOVE_PM;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    TEST_ASSERT_TRUE(fw_guard_retracts(FW_GUARD_TRIPPED));
    TEST_ASSERT_TRUE(fw_guard_retracts(FW_GUARD_HOLDING));
    TEST_ASSERT_FALSE(fw_guard_retracts(FW_GUARD_ARMED));
    TEST_ASSERT_FALSE(fw_guard_retracts(FW_GUARD_RELEASED));
    /* NULL: nothing happens */
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, fw_guard_step(NULL, FW_GUARD_CAUSE_NORMAL, &p));
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, NULL));
    TEST_ASSERT_EQUAL_UINT32(1u, g.trips);
}

static void test_guard_releases_one_pn_past_the_hysteresis_not_at_it(void)
{
    /* from a trip at a load above the limit: R = limit - limit / 8 */
    fw_guard_pose_t p = pose(100000, 0, 0, true);
    int32_t r = LIM_N - HYST;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, &p));
    p.load_pn = r;                 /* at R: holds */
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    p.load_pn = r - 1;             /* one pN below: released */
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, fw_guard_step(&g, 0u, &p));
    TEST_ASSERT_FALSE(g.latched);
    TEST_ASSERT_EQUAL_UINT32(0u, g.causes);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, fw_guard_step(&g, 0u, &p));
    /* a trip at a light load (the tip ran into something): R from that load */
    p.load_pn = 5000;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, &p));
    TEST_ASSERT_EQUAL_INT32(5000 - HYST, g.release_load_pn);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    p.load_pn = 5000 - HYST;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    p.load_pn = 5000 - HYST - 1;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, fw_guard_step(&g, 0u, &p));
    /* the operator lifts the tip: released whatever the load */
    p.load_pn = 200000;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, &p));
    p.engaged = false;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, fw_guard_step(&g, 0u, &p));
    /* the release load at the extremes: no overflow, saturated exactly */
    TEST_ASSERT_EQUAL_INT32(INT32_MIN, fw_guard_release_load_pn(LIM_N, INT32_MIN));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX - (INT32_MAX >> 3), fw_guard_release_load_pn(INT32_MAX, INT32_MAX));
    TEST_ASSERT_EQUAL_INT32(-(INT32_MAX >> 3), fw_guard_release_load_pn(INT32_MAX, 0));
    TEST_ASSERT_EQUAL_INT32(1, fw_guard_release_load_pn(1, 5));   /* limit / 8 = 0 */
    TEST_ASSERT_EQUAL_INT32(LIM_N - HYST, fw_guard_release_load_pn(LIM_N, INT32_MAX));
}

static void test_guard_lateral_trip_releases_past_the_distance_one_pm_either_side(void)
{
    fw_guard_pose_t p = pose(5000, -3000, 4000, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_LATERAL, &p));
    /* along x: 50 nm - 1 pm holds, 50 nm releases */
    p.xy_pm[0] = -3000 - (FW_GUARD_RELEASE_MOVE_PM - 1);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    p.xy_pm[0] = -3000 - FW_GUARD_RELEASE_MOVE_PM;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, fw_guard_step(&g, 0u, &p));
    /* diagonal: (30, 40) nm is exactly 50 nm; one pm short holds */
    p = pose(5000, 0, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_LATERAL, &p));
    p.xy_pm[0] = 30000;
    p.xy_pm[1] = 39999;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    p.xy_pm[1] = 40000;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, fw_guard_step(&g, 0u, &p));
    /* a lateral trip also releases by the load, as a normal one */
    p = pose(90000, 0, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_LATERAL, &p));
    p.load_pn = LIM_N - HYST - 1;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, fw_guard_step(&g, 0u, &p));
    /* normal and lateral together (or one after the other while latched):
     * the xy set point alone does not release */
    p = pose(90000, 0, 0, true);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_LATERAL, &p));
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, &p));
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL, g.causes);
    p.xy_pm[0] = 10 * FW_GUARD_RELEASE_MOVE_PM;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    /* the distance at the extremes: opposite corners of int32 */
    {
        const int32_t a[2] = { INT32_MIN, INT32_MIN };
        const int32_t b[2] = { INT32_MAX, INT32_MAX };
        const int32_t c[2] = { INT32_MIN + 1, INT32_MIN };
        TEST_ASSERT_TRUE(fw_guard_moved(a, b, INT32_MAX));
        TEST_ASSERT_FALSE(fw_guard_moved(a, c, INT32_MAX));
        TEST_ASSERT_FALSE(fw_guard_moved(a, c, 2));
        TEST_ASSERT_TRUE(fw_guard_moved(a, c, 1));
        TEST_ASSERT_TRUE(fw_guard_moved(a, a, 0));
    }
}

static void test_guard_trips_again_after_the_release(void)
{
    fw_guard_pose_t p = pose(100000, 0, 0, true);
    fw_guard_t ref;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, &p));
    p.load_pn = 5000;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_RELEASED, fw_guard_step(&g, 0u, &p));
    p.load_pn = 100000;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_ARMED, fw_guard_step(&g, 0u, &p));
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_NORMAL, &p));
    TEST_ASSERT_EQUAL_UINT32(2u, g.trips);
    TEST_ASSERT_EQUAL_INT(FW_GUARD_HOLDING, fw_guard_step(&g, 0u, &p));
    /* reset: as after init */
    fw_guard_reset(&g);
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_guard_init(&ref, LIM_N, LIM_L, FW_PAPER_NORMAL_GAIN_PN_PER_V, FW_PAPER_LATERAL_GAIN_PN_PER_V));
    assert_guard_equal(&ref, &g, __LINE__);
    /* the trip counter saturates */
    g.trips = UINT32_MAX;
    TEST_ASSERT_EQUAL_INT(FW_GUARD_TRIPPED, fw_guard_step(&g, FW_GUARD_CAUSE_LATERAL, &p));
    TEST_ASSERT_EQUAL_UINT32(UINT32_MAX, g.trips);
}

static void test_guard_lateral_force_matches_a_double_reference(void)
{
    /* round(gain s / 2^23) half up, within 0.5 pN of the exact product
     * (the double holds the 59-bit product within far less than 0.5 pN) */
    tu_rng_t r;
    long i;
    double worst = 0.0;
    tu_rng_seed(&r, 14);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        int32_t gain = (i & 1) ? tu_rng_range(&r, 1, 1 << 20) : FW_PAPER_LATERAL_GAIN_PN_PER_V;
        q23_t s = tu_rng_range(&r, -20 * FW_Q23_ONE, 20 * FW_Q23_ONE);
        double ref = (double)gain * (double)s / TU_TWO_POW(FW_Q23_FRAC);
        double e = fabs((double)fw_guard_lateral_pn(gain, s) - ref);
        if (e > worst) {
            worst = e;
        }
    }
    TEST_ASSERT_TRUE(worst <= 0.5 + 1e-6);
    /* exact at the edges, saturated past int32 */
    TEST_ASSERT_EQUAL_INT32(379000, fw_guard_lateral_pn(FW_PAPER_LATERAL_GAIN_PN_PER_V, 10 * FW_Q23_ONE));
    TEST_ASSERT_EQUAL_INT32(-379000, fw_guard_lateral_pn(FW_PAPER_LATERAL_GAIN_PN_PER_V, -10 * FW_Q23_ONE));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, fw_guard_lateral_pn(INT32_MAX, 20 * FW_Q23_ONE));
    TEST_ASSERT_EQUAL_INT32(INT32_MIN, fw_guard_lateral_pn(INT32_MAX, -20 * FW_Q23_ONE));
}

/* The lateral cause of fw_guard_over_q23 against fw_guard_over on the
 * rounded force, for one gain, limit and signal. */
static void check_q23(int32_t gain, int32_t limit, q23_t s, int line)
{
    fw_guard_t h;
    uint32_t ref;
    UNITY_TEST_ASSERT_EQUAL_INT(FW_OK, fw_guard_init(&h, 1, limit, INT32_MAX, gain), line, "init");
    ref = fw_guard_over(&h, 0, fw_guard_lateral_pn(gain, s), 0u);
    UNITY_TEST_ASSERT_EQUAL_UINT32(ref, fw_guard_over_q23(&h, 0, s, 0u), line, "lateral cause");
}

static void test_guard_over_q23_gives_the_causes_of_the_rounded_force(void)
{
    /* random gains, limits below full scale and signals within +-20 V;
     * and every signal near the edges, where gain s / 2^23 = +-(L + 1/2):
     * exactly L + 1/2 rounds (half up) to L + 1 and trips, -(L + 1/2)
     * rounds to -L and does not */
    tu_rng_t r;
    long i;
    fw_guard_t h;
    q23_t s;
    tu_rng_seed(&r, 1409);
    for (i = 0; i < AFM_SWEEP_N; i++) {
        int32_t gain = tu_rng_range(&r, 1, 1 << 20);
        int32_t limit = tu_rng_range(&r, 1, gain * 10 - 1);
        check_q23(gain, limit, tu_rng_range(&r, -20 * FW_Q23_ONE, 20 * FW_Q23_ONE), __LINE__);
    }
    /* gain 2^13 pN/V: F_y = s / 2^10 exactly, so L + 1/2 is s = (2 L + 1) 2^9 */
    for (s = (2 * 1000 + 1) * 512 - 600; s <= (2 * 1000 + 1) * 512 + 600; s++) {
        check_q23(1 << 13, 1000, s, __LINE__);
        check_q23(1 << 13, 1000, -s, __LINE__);
    }
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_guard_init(&h, 1, 1000, INT32_MAX, 1 << 13));
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_LATERAL, fw_guard_over_q23(&h, 0, 2001 * 512, 0u));       /* 1000.5 pN: 1001 */
    TEST_ASSERT_EQUAL_UINT32(0u, fw_guard_over_q23(&h, 0, 2001 * 512 - 1, 0u));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_guard_over_q23(&h, 0, -2001 * 512, 0u));                          /* -1000.5: -1000 */
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_LATERAL, fw_guard_over_q23(&h, 0, -2001 * 512 - 1, 0u));
    /* the normal channel and the saturation flags as fw_guard_over */
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_NORMAL, fw_guard_over_q23(&h, -2, 0, 0u));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_guard_over_q23(&h, 1, 0, 0u));
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL,
                             fw_guard_over_q23(&h, 0, 0, FW_FLAG_SAT_SN | FW_FLAG_SAT_SL));
    /* the extremes: the largest gain and signal, the largest limit */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_guard_init(&h, 1, INT32_MAX, 1, INT32_MAX));
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_LATERAL, fw_guard_over_q23(&h, 0, 20 * FW_Q23_ONE, 0u));
    TEST_ASSERT_EQUAL_UINT32(FW_GUARD_CAUSE_LATERAL, fw_guard_over_q23(&h, 0, -20 * FW_Q23_ONE, 0u));
    TEST_ASSERT_EQUAL_UINT32(0u, fw_guard_over_q23(&h, 0, FW_Q23_ONE / 10, 0u));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_guard_defaults_are_80_percent_of_full_scale_and_below_it);
    RUN_TEST(test_guard_refuses_limits_at_or_below_zero_and_at_or_above_full_scale);
    RUN_TEST(test_guard_trips_one_pn_over_the_limit_not_at_it_either_sign);
    RUN_TEST(test_guard_latches_and_holds_while_the_set_point_stays);
    RUN_TEST(test_guard_releases_one_pn_past_the_hysteresis_not_at_it);
    RUN_TEST(test_guard_lateral_trip_releases_past_the_distance_one_pm_either_side);
    RUN_TEST(test_guard_trips_again_after_the_release);
    RUN_TEST(test_guard_lateral_force_matches_a_double_reference);
    RUN_TEST(test_guard_over_q23_gives_the_causes_of_the_rounded_force);
    return UNITY_END();
}
