// z_drift (sim_afm/effects.cpp): the deflection signal's zero drifts at its
// rate and random walk; the true load leaves the set point by k_n times it
// while S_n reads the set point's volts.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "../scene_text.hpp"
#include "world.hpp"

using afm::sim::World;

namespace {

const char *kScene = R"(name: zdrift
seed: SEED
duration_s: 60
sample_rate_hz: RATE
block_hz: RATE
effects: [EFFECTS]
sample:
  substrate: glass
  field_nm: 2000
afm:
  z_drift: {rate_nm_per_min: DRIFT, walk_nm_per_sqrt_min: WALK}
operator:
  load_nN: 5
  path_nm: [[0, 0]]
)";

afm::Scene scene(const std::string &effects, double drift, double walk, int seed = 1, int rate = 1000)
{
    std::string t = with(kScene, "EFFECTS", effects);
    t = with(with(t, "RATE", std::to_string(rate)), "RATE", std::to_string(rate));
    t = with(with(t, "DRIFT", std::to_string(drift)), "WALK", std::to_string(walk));
    return scene_from_text(with(t, "SEED", std::to_string(seed)));
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_true_load_falls_at_the_drift_rate_while_sn_stays()
{
    // 6 nm/min of the deflection's zero over one minute at 1 kHz: after
    // sample i the true load (the next sample's mechanics act with it) is
    // 5 nN - k_n 6 nm (i dt / 60 s); S_n equals the plain world's, the set
    // point's (each sample's S_n and mechanics with the zero of the one before).
    World w(scene("z_drift", 6, 0)), plain(scene("", 6, 0));
    const double k = w.lever().spring;
    w.command(Eigen::Vector2d(0, 0), 5, true);
    plain.command(Eigen::Vector2d(0, 0), 5, true);
    double load30 = 0;
    for (int i = 1; i <= 60000; ++i) {
        const afm::sim::Sample s = w.step(), p = plain.step();
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, p.sn_v, s.sn_v);
        if (i == 30000) load30 = w.tip_force().z();
    }
    const double load60 = w.tip_force().z();
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 5 - k * 6, load60);
    const double rate = (load30 - load60) / k / 0.5;   // nm of zero per minute
    std::printf("z_drift: 6 nm/min of the deflection's zero: true load %.4f nN after a minute (k_n %.3f N/m, set point 5),"
                " rate measured %.4f nm/min\n", load60, k, rate);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 6.0, rate);
}

void test_random_walk_spreads_as_its_level()
{
    // 200 worlds (seeds), 2 nm/sqrt(min), no rate, one minute at 100 Hz:
    // the zero's rms after a minute is 2 nm within 20 % (the estimate's
    // standard error 1 / sqrt(2 * 200) = 5 %, times 4).
    const int worlds = 200;
    double sum2 = 0;
    for (int seed = 1; seed <= worlds; ++seed) {
        World w(scene("z_drift", 0, 2, seed, 100));
        w.command(Eigen::Vector2d(0, 0), 5, true);
        for (int i = 0; i <= 6000; ++i) w.step();
        const double zero = (5 - w.tip_force().z()) / w.lever().spring;
        sum2 += zero * zero;
    }
    const double rms = std::sqrt(sum2 / worlds);
    std::printf("z_drift: walk 2 nm/sqrt(min): rms of the zero after a minute over %d seeds %.3f nm\n", worlds, rms);
    TEST_ASSERT_DOUBLE_WITHIN(0.4, 2.0, rms);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_true_load_falls_at_the_drift_rate_while_sn_stays);
    RUN_TEST(test_random_walk_spreads_as_its_level);
    return UNITY_END();
}
