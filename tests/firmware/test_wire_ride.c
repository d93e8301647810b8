/*
 * test_wire_ride.c - the ride-over judgement of fw_wire_update (fw_wire.h,
 * "The ride-over judgement"): eq. 30 the prior, the climb the evidence, the
 * contradiction that lets a predicted ride-over push.
 *
 * The paper's rod (1.3 um x 100 nm) along x at the origin, the apex over its
 * middle (k = 1), r_tip 10 nm: the reach is 60 nm. gamma 20 deg, wire mu
 * 0.3, f L = 26 nN, no adhesion: eq. 29's push 29188 pN, eq. 30's dF 10623
 * pN. Thresholds for d = 100 nm: the climb 37.5 nm, the contradiction r_tip +
 * 12.5 nm = 22.5 nm inside the reach.
 */
#include "unity.h"
#include "fw_wire.h"
#include "fw_math.h"
#include "test_util.h"

#include <math.h>

#define L_PM 1300000
#define REACH_PM 60000
#define CLIMB_PM 37500
#define CONTRA_PM 22500

static fw_wire_t w;
static fw_wire_tip_t tip;
static fw_squeeze_t sq;

void setUp(void)
{
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, L_PM, 100000));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(&tip, 10000, 20000, 20000, 300000, 0));
    tip.down_force = true;
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_squeeze_solve(tip.tip_half_angle, FW_Q30_ONE, tip.mu, 26000, 0, &sq));
}

void tearDown(void) {}

/* The load at x dF (eq. 30, the card's own solver). */
static int32_t load_at(double x)
{
    return (int32_t)lround(x * sq.df_pn);
}

/* One sample with the apex depth_pm inside the reach (negative: outside it)
 * on the rod's -n side, at height z_pm; the rod's flags. */
static uint32_t sample(int32_t depth_pm, int32_t z_pm, int64_t excess_pn, int32_t load_pn)
{
    const int32_t apex[3] = { 0, w.y_pm - (REACH_PM - depth_pm), z_pm };
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, apex, excess_pn, 0, load_pn));
    return w.flags & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN | FW_WIRE_SQUEEZED | FW_WIRE_RIDE_PENDING);
}

static void test_wire_ride_thresholds_scale_with_the_diameter(void)
{
    TEST_ASSERT_EQUAL_INT32(CLIMB_PM, fw_wire_climb_on_pm(100000));
    TEST_ASSERT_EQUAL_INT32(CONTRA_PM - 10000, fw_wire_contra_extra_pm(100000));
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_CLIMB_FLOOR_PM, fw_wire_climb_on_pm(5000));   /* a thin rod: the floor */
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_CLIMB_FLOOR_PM, fw_wire_climb_on_pm(1));
    TEST_ASSERT_EQUAL_INT32(3 * ((int32_t)1 << 27), fw_wire_climb_on_pm((int32_t)1 << 30));   /* 3 d in 64 bits */
    TEST_ASSERT_EQUAL_INT32(805306367, fw_wire_climb_on_pm(INT32_MAX));
}

static void test_wire_ride_a_climb_is_flagged_and_the_rod_stays(void)
{
    const int32_t low = load_at(0.9);
    const int32_t ride = fw_wire_ride_push_pn(tip.tip_half_angle, low, 0);
    int i;
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 500, 300, low));   /* off the rod: the baseline, 500 pm */
    /* eq. 30 predicts the ride-over: pending, not flagged, the rod stays */
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, sample(5000, 900, (ride >> 1) + 1, low));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, sample(10000, 500 + CLIMB_PM - 1, (ride >> 1) + 1, low));
    /* the climb: declared */
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDDEN, sample(11000, 500 + CLIMB_PM, 300, low));
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_JUDGE_RIDE, w.judge);
    /* over the top and down its far side, while the apex is in reach: still ridden, the rod never moved */
    for (i = 0; i < 100; i++) {
        TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDDEN, sample(12000 + 1000 * i, 500 + 50000 - 500 * i, 300, low));
    }
    TEST_ASSERT_EQUAL_INT32(0, w.x_pm);
    TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
    /* out of reach: the contact and its judgement end */
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-130000, 500, 300, low));
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_JUDGE_NONE, w.judge);
}

static void test_wire_ride_a_push_near_the_threshold_is_not_flagged(void)
{
    /* 1.01 dF: eq. 30 predicts the push; the tip stays down while its height
     * wanders by the push's F_x bending (26 nm, the worst ./afm bench
     * rideover saw) and the rod goes on */
    const int32_t load = load_at(1.01);
    int i;
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 0, 300, load));
    for (i = 0; i < 200; i++) {
        uint32_t f = sample(1000, 26000 * i / 200, (sq.push_pn >> 1) + 1 + (i % 7) * 300, load);
        TEST_ASSERT_EQUAL_UINT32(FW_WIRE_PUSHED, f);
    }
    TEST_ASSERT_EQUAL_INT32(200 * 1000, w.y_pm);
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_JUDGE_NONE, w.judge);
}

static void test_wire_ride_predicted_but_contradicted_pushes_not_flags(void)
{
    /* 0.99 dF: eq. 30 predicts the ride-over, but the apex goes in past the
     * rod's edge with no climb and the push still on: it is pushed, caught up */
    const int32_t load = load_at(0.99);
    const int32_t ride = fw_wire_ride_push_pn(tip.tip_half_angle, load, 0);
    int32_t d;
    TEST_ASSERT_TRUE(ride < sq.push_pn);
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 0, 300, load));
    for (d = 1000; d < CONTRA_PM; d += 1000) {
        TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, sample(d, 3000, ride, load));
        TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
    }
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, sample(CONTRA_PM - 1, 3000, ride, load));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_PUSHED, sample(CONTRA_PM, 3000, ride, load));
    TEST_ASSERT_EQUAL_INT32(CONTRA_PM, w.y_pm);   /* caught up to the apex's surface at once */
    TEST_ASSERT_EQUAL_INT32(FW_WIRE_JUDGE_PUSH, w.judge);
    /* the rest of the contact pushes, at half of the lesser of push and H_ride */
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_PUSHED, sample(1000, 3500, (ride >> 1) + 1, load));
    TEST_ASSERT_EQUAL_UINT32(0u, sample(1000, 3500, ride >> 1, load));
    /* below the contradiction's depth the same signals leave it pending */
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 0, 300, load));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, sample(CONTRA_PM - 1, 0, ride, load));
}

static void test_wire_ride_a_push_that_lets_go_without_a_climb_is_not_flagged(void)
{
    /* the truth's rod slips ahead of the tip (a stroke's end): the lateral
     * force falls with the apex deep in where the model's rod lies; without
     * the climb that is no ride-over */
    const int32_t low = load_at(0.9);
    const int32_t ride = fw_wire_ride_push_pn(tip.tip_half_angle, low, 0);
    int32_t d;
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 0, 300, low));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING, sample(3000, 0, (ride >> 1) + 1, low));
    for (d = 10000; d < 110000; d += 5000) {
        TEST_ASSERT_EQUAL_UINT32(0u, sample(d, 0, ride >> 3, low) & (FW_WIRE_RIDDEN | FW_WIRE_PUSHED));
    }
    TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
}

static void test_wire_ride_noise_at_the_climb_does_not_chatter(void)
{
    /* heights alternating one LSB about the threshold: the first at it
     * declares, and every later sample of the contact stays flagged */
    const int32_t low = load_at(0.9);
    int i;
    int flagged = 0;
    int first = -1;
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 0, 300, low));
    for (i = 0; i < 64; i++) {
        int32_t z = CLIMB_PM + ((i % 2 == 0) ? -1 : 0) - ((i < 9) ? 1 : 0);
        uint32_t f = sample(5000 + 100 * i, z, 300, low);
        if ((f & FW_WIRE_RIDDEN) != 0u) {
            flagged++;
            if (first < 0) {
                first = i;
            }
        }
        TEST_ASSERT_EQUAL_UINT32(0u, f & FW_WIRE_PUSHED);
    }
    TEST_ASSERT_EQUAL_INT(9, first);
    TEST_ASSERT_EQUAL_INT(64 - 9, flagged);
}

static void test_wire_ride_a_climb_undoes_the_approachs_pushes(void)
{
    /* 1.1 dF: eq. 30 predicts the push, the model pushes the rod 8 nm,
     * then the tip climbs: the rod is put back where the contact began */
    const int32_t high = load_at(1.1);
    int i;
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 0, 300, high));
    for (i = 0; i < 8; i++) {
        TEST_ASSERT_EQUAL_UINT32(FW_WIRE_PUSHED, sample(1000, 0, sq.push_pn, high));
    }
    TEST_ASSERT_EQUAL_INT32(8000, w.y_pm);
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDDEN, sample(1000, 40000, 300, high));
    TEST_ASSERT_EQUAL_INT32(0, w.y_pm);
    TEST_ASSERT_EQUAL_INT32(0, w.x_pm);
    /* pushed further than the reach, the rod moved for real: it stays put */
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-130000, 0, 300, high));
    for (i = 0; i < 61; i++) {
        TEST_ASSERT_EQUAL_UINT32(FW_WIRE_PUSHED, sample(1000, 0, sq.push_pn, high));
    }
    TEST_ASSERT_EQUAL_INT32(61000, w.y_pm);
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDDEN, sample(1000, 40000, 300, high));
    TEST_ASSERT_EQUAL_INT32(61000, w.y_pm);
}

static void test_wire_ride_absurd_inputs(void)
{
    const int32_t low = load_at(0.9);
    const int32_t apex[3] = { 0, -50000, 0 };
    /* NULL pointers */
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_update(&w, &tip, NULL, 0, 0, low));
    TEST_ASSERT_EQUAL_INT(FW_ERR_ARG, fw_wire_update(NULL, &tip, apex, 0, 0, low));
    /* heights at the ends of int32: the climb in 64 bits, no wrap */
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, INT32_MIN, 300, low));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDDEN, sample(5000, INT32_MAX, 300, low));
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, INT32_MAX, 300, low));
    TEST_ASSERT_EQUAL_UINT32(0u, sample(5000, INT32_MIN, 0, low) & FW_WIRE_RIDDEN);
    /* a negative or enormous excess, a negative load, a wild twist */
    TEST_ASSERT_EQUAL_UINT32(0u, sample(-10000, 0, 300, low));
    TEST_ASSERT_EQUAL_UINT32(0u, sample(5000, 0, INT64_MIN, low) & (FW_WIRE_PUSHED | FW_WIRE_RIDDEN));
    TEST_ASSERT_EQUAL_UINT32(0u, sample(5000, 0, INT64_MAX, -INT32_MAX) & FW_WIRE_RIDDEN);
    {
        const int32_t a[3] = { 0, w.y_pm - 50000, 0 };
        TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_update(&w, &tip, a, INT64_MAX, INT32_MIN, low));
        TEST_ASSERT_EQUAL_UINT32(0u, w.flags & FW_WIRE_RIDDEN);
    }
    /* the first sample already on the rod: its own height is the baseline */
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(&w, 0, 0, 0u, L_PM, 100000));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDE_PENDING,
                             sample(5000, 90000, (fw_wire_ride_push_pn(tip.tip_half_angle, low, 0) >> 1) + 1, low));
    TEST_ASSERT_EQUAL_UINT32(FW_WIRE_RIDDEN, sample(6000, 90000 + CLIMB_PM, 300, low));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_wire_ride_thresholds_scale_with_the_diameter);
    RUN_TEST(test_wire_ride_a_climb_is_flagged_and_the_rod_stays);
    RUN_TEST(test_wire_ride_a_push_near_the_threshold_is_not_flagged);
    RUN_TEST(test_wire_ride_predicted_but_contradicted_pushes_not_flags);
    RUN_TEST(test_wire_ride_a_push_that_lets_go_without_a_climb_is_not_flagged);
    RUN_TEST(test_wire_ride_noise_at_the_climb_does_not_chatter);
    RUN_TEST(test_wire_ride_a_climb_undoes_the_approachs_pushes);
    RUN_TEST(test_wire_ride_absurd_inputs);
    return UNITY_END();
}
