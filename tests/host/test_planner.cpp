// Unity tests of the planner's pure parts (host/planner, pattern):
// the assignment against brute force on small cases, more sites than
// particles and the reverse, pinned sites (and their scene key), free and
// blocked pushes, a site walled in, text rasterised into sites, strokes
// kept short near another particle, lifted moves off the lever's axis.
#include <unity.h>

#include "../scene_text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "pattern.hpp"
#include "planner.hpp"

namespace {

double dist(afm::Vec2 a, afm::Vec2 b) { return std::hypot(a.x - b.x, a.y - b.y); }

// The default geometry: 100 nm particles, a 10 nm tip, no lever constraint.
const afm::PushGeometry kG{};

struct Rng {   // uniform in [0, 1)
    std::mt19937_64 g;
    explicit Rng(uint64_t seed) : g(seed) {}
    double operator()() { return std::uniform_real_distribution<double>(0.0, 1.0)(g); }
};

// The least total distance over every way of giving each site its own
// particle (particles >= sites), by enumeration.
double brute_force(const std::vector<afm::Vec2> &parts, const std::vector<afm::Vec2> &sites)
{
    std::vector<int> idx(parts.size());
    std::iota(idx.begin(), idx.end(), 0);
    double best = 1e300;
    do {
        double sum = 0;
        for (std::size_t j = 0; j < sites.size(); ++j) sum += dist(parts[static_cast<std::size_t>(idx[j])], sites[j]);
        best = std::min(best, sum);
    } while (std::next_permutation(idx.begin(), idx.end()));
    return best;
}


}  // namespace

void setUp() {}
void tearDown() {}

void test_assignment_matches_brute_force()
{
    Rng r(99);
    for (int trial = 0; trial < 60; ++trial) {
        const int ns = 1 + trial % 5, np = ns + trial % 3;   // up to 7 particles
        std::vector<afm::Vec2> parts, sites;
        for (int i = 0; i < np; ++i) parts.push_back({1000 * r(), 1000 * r()});
        for (int j = 0; j < ns; ++j) sites.push_back({1000 * r(), 1000 * r()});
        const std::vector<int> a = afm::assign_sites(parts, sites);
        TEST_ASSERT_EQUAL(sites.size(), a.size());
        double sum = 0;
        std::vector<int> used;
        for (std::size_t j = 0; j < a.size(); ++j) {
            TEST_ASSERT_TRUE(a[j] >= 0 && a[j] < np);
            TEST_ASSERT_TRUE(std::find(used.begin(), used.end(), a[j]) == used.end());   // each particle once
            used.push_back(a[j]);
            sum += dist(parts[static_cast<std::size_t>(a[j])], sites[j]);
        }
        // costs are whole 0.1 nm: within the rounding of each pair
        TEST_ASSERT_DOUBLE_WITHIN(0.05 * ns + 1e-9, brute_force(parts, sites), sum);
    }
}

void test_assignment_is_not_greedy()
{
    // Greedy, site by site, gives site 0 its nearest particle (particle 0,
    // 1 nm away) and leaves site 1 particle 1, 6 nm away: 7 nm in all.
    // The least total crosses over: particle 1 to site 0 (2 nm), particle 0
    // to site 1 (3 nm): 5 nm.
    const std::vector<afm::Vec2> parts = {{1, 0}, {-2, 0}};
    const std::vector<afm::Vec2> sites = {{0, 0}, {4, 0}};
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 7.0, dist(parts[0], sites[0]) + dist(parts[1], sites[1]));
    const std::vector<int> a = afm::assign_sites(parts, sites);
    TEST_ASSERT_EQUAL_INT(1, a[0]);
    TEST_ASSERT_EQUAL_INT(0, a[1]);
}

void test_more_sites_than_particles_is_a_clear_error_the_reverse_is_not()
{
    const std::vector<afm::Vec2> two = {{0, 0}, {100, 0}}, three = {{0, 0}, {100, 0}, {200, 0}};
    try {
        afm::assign_sites(two, three);
        TEST_FAIL_MESSAGE("3 sites for 2 particles must be refused");
    } catch (const afm::PlanError &e) {
        TEST_ASSERT_EQUAL_STRING("3 target sites but only 2 particles: give at most as many sites as particles", e.what());
    }
    try {
        afm::assign_sites(two, {});
        TEST_FAIL_MESSAGE("no sites must be refused");
    } catch (const afm::PlanError &e) {
        TEST_ASSERT_EQUAL_STRING("no target sites to fill", e.what());
    }
    // Three particles, two sites: the two nearest serve, the third stays.
    const std::vector<int> a = afm::assign_sites(three, {{0, 10}, {100, 10}});
    TEST_ASSERT_EQUAL_INT(0, a[0]);
    TEST_ASSERT_EQUAL_INT(1, a[1]);
}

void test_free_push_is_straight()
{
    const afm::PushPath p = afm::plan_push({0, 0}, {1000, 0}, kG, {{{500, 400}, 50, 2}});
    TEST_ASSERT_TRUE(p.ok());
    TEST_ASSERT_EQUAL(2u, p.legs.size());
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 1000, p.length_nm);
    // No distance to go: a trivial path.
    TEST_ASSERT_TRUE(afm::plan_push({5, 5}, {5, 5}, kG, {}).ok());
}

void test_blocked_push_bends_around_the_obstacle()
{
    // A particle on the line: the straight push would sweep it.
    const std::vector<afm::Disc> obs = {{{500, 0}, 50, 2}};
    const afm::PushPath p = afm::plan_push({0, 0}, {1000, 0}, kG, obs);
    TEST_ASSERT_TRUE(p.ok());
    TEST_ASSERT_EQUAL(3u, p.legs.size());
    TEST_ASSERT_TRUE(p.length_nm > 1000);
    // Each leg keeps the particle 50 + 50 + 40 nm from the obstacle's centre.
    for (std::size_t k = 1; k < p.legs.size(); ++k) {
        const afm::Vec2 a = p.legs[k - 1], b = p.legs[k];
        for (int i = 0; i <= 100; ++i) {
            const afm::Vec2 q{a.x + (b.x - a.x) * i / 100.0, a.y + (b.y - a.y) * i / 100.0};
            TEST_ASSERT_TRUE(dist(q, obs[0].c) >= 140 - 1e-9);
        }
    }
}

void test_a_walled_in_site_has_no_free_push()
{
    // Eight particles in a ring of radius 160 nm around the site: no way in
    // (the gaps are 25 nm, the particle 100 nm across).
    std::vector<afm::Disc> ring;
    for (int k = 0; k < 8; ++k) ring.push_back({{160 * std::cos(k * M_PI / 4), 160 * std::sin(k * M_PI / 4)}, 50, k + 10});
    const afm::PushPath p = afm::plan_push({2000, 0}, {0, 0}, kG, ring);
    TEST_ASSERT_FALSE(p.ok());
    // With the ring's near side open (three removed) it is reachable.
    std::vector<afm::Disc> open = {ring[2], ring[3], ring[4], ring[5], ring[6]};
    TEST_ASSERT_TRUE(afm::plan_push({2000, 0}, {0, 0}, kG, open).ok());
}

void test_no_leg_runs_along_the_lever()
{
    // The lever along x, 25 deg kept clear: a push along x becomes a zigzag
    // of two legs at 30 deg either side; one across the lever stays straight.
    afm::PushGeometry g;
    g.min_lever_angle_deg = 25;
    const afm::PushPath p = afm::plan_push({0, 0}, {1000, 0}, g, {});
    TEST_ASSERT_TRUE(p.ok());
    TEST_ASSERT_EQUAL(3u, p.legs.size());
    for (std::size_t k = 1; k < p.legs.size(); ++k) {
        const double dx = p.legs[k].x - p.legs[k - 1].x, dy = p.legs[k].y - p.legs[k - 1].y;
        const double angle = std::atan2(std::fabs(dy), std::fabs(dx)) * 180 / M_PI;
        TEST_ASSERT_DOUBLE_WITHIN(1e-6, 30.0, angle);
    }
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 1000 / std::cos(M_PI / 6), p.length_nm);
    TEST_ASSERT_EQUAL(2u, afm::plan_push({0, 0}, {300, 1000}, g, {}).legs.size());
    // At scan angle 300 deg the lever's axis is turned by 30 deg.
    g.lever_axis = {std::cos(M_PI / 6), std::sin(M_PI / 6)};
    TEST_ASSERT_EQUAL(3u, afm::plan_push({0, 0}, {866, 500}, g, {}).legs.size());
    TEST_ASSERT_EQUAL(2u, afm::plan_push({0, 0}, {1000, 0}, g, {}).legs.size());
}

void test_assembly_order_keeps_every_site_reachable()
{
    // A filled 5 x 5 block of sites 150 nm apart (particles 100 nm): placed
    // from the outside in, the middle would be walled in. The order places
    // each site while it can still be reached, checked by replaying it.
    std::vector<afm::Vec2> sites;
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j) sites.push_back({150.0 * i, 150.0 * j});
    afm::PushGeometry g;
    g.clearance_nm = 20;
    const std::vector<int> order = afm::assembly_order(sites, g);
    TEST_ASSERT_EQUAL(sites.size(), order.size());
    std::vector<afm::Disc> placed;
    for (int j : order) {
        bool reachable = false;
        for (int k = 0; k < 16 && !reachable; ++k) {
            const afm::Vec2 from{sites[j].x + 800 * std::cos(k * M_PI / 8), sites[j].y + 800 * std::sin(k * M_PI / 8)};
            const afm::PushPath p = afm::plan_push(from, sites[j], g, placed);
            reachable = p.ok() && p.legs.size() == 2;
        }
        TEST_ASSERT_TRUE_MESSAGE(reachable, "a site walled in when its turn came");
        placed.push_back({sites[j], 50, j});
    }
    // Outside in would fail: the centre last is walled in.
    std::vector<afm::Disc> ring;
    for (int j = 0; j < 25; ++j)
        if (j != 12) ring.push_back({sites[j], 50, j});
    TEST_ASSERT_FALSE(afm::plan_push({2000, 300}, sites[12], g, ring).ok());
}

void test_text_is_rasterised_into_rows_of_sites()
{
    const std::string base = "name: t\nseed: 1\nduration_s: 1\nsample: {substrate: glass, field_nm: 10000}\n"
                              "objects:\n  scatter: {count: 200, radius_nm: 50, min_gap_nm: 100}\n";
    const afm::Scene s = scene_from_text(base + "  targets: {text: \"I\", pitch_nm: 250, height_nm: 2500}\noperator:\n  plan: {}\n");
    const std::vector<afm::Vec2> sites = afm::target_sites(s);
    // An I: one column of sites (about height / pitch of them), all on the pitch grid.
    TEST_ASSERT_TRUE(sites.size() >= 8 && sites.size() <= 12);
    for (const auto &v : sites) {
        TEST_ASSERT_DOUBLE_WITHIN(1e-6, sites[0].x, v.x);
        const double k = (v.y - sites[0].y) / 250;
        TEST_ASSERT_DOUBLE_WITHIN(1e-6, std::round(k), k);
    }
    // Off the field: named.
    try {
        afm::target_sites(scene_from_text(base + "  targets: {text: \"WWWWWW\", pitch_nm: 250, height_nm: 5000}\noperator:\n  plan: {}\n"));
        TEST_FAIL_MESSAGE("a pattern larger than the field must be refused");
    } catch (const afm::PatternError &e) {
        TEST_ASSERT_TRUE(std::string(e.what()).find("objects.targets.text: a site at") != std::string::npos);
    }
    // More sites than particles: the launcher's refusal names both counts.
    const std::string why = afm::targets_refusal(scene_from_text(
        "name: t\nseed: 1\nduration_s: 1\nsample: {substrate: glass, field_nm: 10000}\nobjects:\n  scatter: {count: 5}\n"
        "  targets: {text: \"H\", pitch_nm: 250, height_nm: 2500}\noperator:\n  plan: {}\n"));
    TEST_ASSERT_TRUE(why.find("sites but the scene has only 5 particles") != std::string::npos);
    // Sites too close for two particles: named with the pitch to change.
    const std::string close = afm::targets_refusal(scene_from_text(
        "name: t\nseed: 1\nduration_s: 1\nsample: {substrate: glass, field_nm: 10000}\nobjects:\n  scatter: {count: 5}\n"
        "  targets: [[0, 0], [120, 0]]\noperator:\n  plan: {}\n"));
    TEST_ASSERT_TRUE(close.find("closer than a particle's diameter and operator.plan.clearance_nm (140 nm): give a larger pitch_nm") !=
                     std::string::npos);
}

void test_a_pinned_site_gets_its_particle_the_rest_the_least_travel()
{
    // Unpinned, site 0 takes particle 1 (test_assignment_is_not_greedy).
    const std::vector<afm::Vec2> parts = {{1, 0}, {-2, 0}, {9, 0}};
    const std::vector<afm::Vec2> sites = {{0, 0}, {4, 0}};
    TEST_ASSERT_EQUAL_INT(1, afm::assign_sites(parts, sites)[0]);
    // Site 1 pinned to particle 1 (6 nm off): site 0 takes the nearest of the rest, particle 0.
    const std::vector<int> a = afm::assign_sites(parts, sites, {-1, 1});
    TEST_ASSERT_EQUAL_INT(0, a[0]);
    TEST_ASSERT_EQUAL_INT(1, a[1]);
    // Pinned to the farthest particle: it goes there all the same.
    const std::vector<int> b = afm::assign_sites(parts, sites, {2, -1});
    TEST_ASSERT_EQUAL_INT(2, b[0]);
    TEST_ASSERT_EQUAL_INT(0, b[1]);
    // No pins: the plain assignment.
    TEST_ASSERT_EQUAL_INT(1, afm::assign_sites(parts, sites, {-1, -1})[0]);
    try {
        afm::assign_sites(parts, sites, {2, 2});
        TEST_FAIL_MESSAGE("one particle pinned to two sites must be refused");
    } catch (const afm::PlanError &) {
    }
}

void test_a_pinned_site_is_read_and_its_mistakes_named()
{
    const std::string base = "name: t\nseed: 1\nduration_s: 1\nsample: {substrate: glass, field_nm: 4000}\n"
                             "objects:\n  particles:\n    - {id: 4, x_nm: 0, y_nm: 0, radius_nm: 50}\n"
                             "    - {id: 7, x_nm: 600, y_nm: 0, radius_nm: 50}\n  targets:\n";
    const std::string plan = "operator:\n  plan: {}\n";
    const afm::Scene s = scene_from_text(base + "    - [0, 300]\n    - {x_nm: 300, y_nm: 300, particle: 7}\n" + plan);
    TEST_ASSERT_EQUAL(2u, s.targets.pinned.size());
    TEST_ASSERT_EQUAL_INT(-1, s.targets.pinned[0]);
    TEST_ASSERT_EQUAL_INT(7, s.targets.pinned[1]);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 300, s.targets.sites_nm[1].x);
    const struct { const char *site, *says; int line; } bad[] = {
        {"    - {x_nm: 0, y_nm: 300, particle: 9}\n", "objects.targets[0].particle: names no particle of the scene", __LINE__},
        {"    - {x_nm: 0, y_nm: 300, particle: 4.5}\n", "objects.targets[0].particle: must be an integer particle id, got '4.5'", __LINE__},
        {"    - {x_nm: 0, y_nm: 300}\n", "objects.targets[0].particle: missing", __LINE__},
        {"    - {x_nm: 0, y_nm: 300, particle: 4}\n    - {x_nm: 0, y_nm: -300, particle: 4}\n",
         "objects.targets[1].particle: particle 4 is pinned to objects.targets[0] already", __LINE__},
        {"    - {x_nm: 0, y_nm: 300, id: 4}\n", "objects.targets[0]", __LINE__},
        {"    - {x_nm: 9000, y_nm: 300, particle: 4}\n", "objects.targets[0]: target", __LINE__},
    };
    for (const auto &b : bad) {
        const std::string why = scene_error(base + b.site + plan);
        UnityAssertEqualNumber(1, why.find(b.says) != std::string::npos, why.c_str(), static_cast<UNITY_UINT>(b.line), UNITY_DISPLAY_STYLE_INT);
        TEST_ASSERT_TRUE(why.find("afm-test-scene") != std::string::npos);   // the file named
    }
}

void test_a_stroke_near_another_particle_is_short()
{
    // 100 nm particles, a 10 nm tip, 40 nm clearance: a pushed particle
    // may turn r + tip_r = 60 nm off the line before it slips off.
    const afm::PushGeometry g{};
    const afm::Vec2 from{0, 0}, to{2000, 0};
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 600, afm::stroke_length(from, to, 600, 180, g, {}));
    // A particle 170 nm off the line: clear of a straight push (140 nm)
    // but not of one turned 60 nm aside (200 nm): the stroke is short.
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 180, afm::stroke_length(from, to, 600, 180, g, {{{400, 170}, 50, 2}}));
    // 210 nm off: long.
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 600, afm::stroke_length(from, to, 600, 180, g, {{{400, 210}, 50, 2}}));
    // Beyond the stroke's reach it does not count; a leg within 1.5 strokes is taken whole.
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 600, afm::stroke_length(from, to, 600, 180, g, {{{1400, 100}, 50, 2}}));
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 250, afm::stroke_length(from, {250, 0}, 180, 180, g, {{{100, 150}, 50, 2}}));
}

void test_a_particle_inside_the_clearance_may_leave_but_not_come_closer()
{
    // A particle 120 nm from another (less than 100 + 40): pushed away
    // (the tip landing clear of the other) it goes straight; pushed past
    // the other, it never comes closer than it was.
    const std::vector<afm::Disc> other = {{{120, 0}, 50, 2}};
    TEST_ASSERT_EQUAL(2u, afm::plan_push({0, 0}, {-300, -1000}, kG, other).legs.size());
    const afm::PushPath past = afm::plan_push({0, 0}, {1000, 0}, kG, other);
    for (std::size_t k = 1; k < past.legs.size(); ++k)
        for (int i = 0; i <= 100; ++i) {
            const afm::Vec2 a = past.legs[k - 1], b = past.legs[k];
            const afm::Vec2 q{a.x + (b.x - a.x) * i / 100.0, a.y + (b.y - a.y) * i / 100.0};
            TEST_ASSERT_TRUE(dist(q, other[0].c) >= 120 - 1e-6);
        }
}

void test_lifted_moves_never_run_along_the_lever()
{
    // Lever along x (and turned 30 deg): every leg of a lifted move keeps
    // 25 deg off the axis; a move across it stays straight.
    afm::PushGeometry g;
    g.min_lever_angle_deg = 25;
    Rng r(7);
    for (int turn = 0; turn < 2; ++turn) {
        g.lever_axis = turn ? afm::Vec2{std::cos(M_PI / 6), std::sin(M_PI / 6)} : afm::Vec2{1, 0};
        int bent = 0;
        for (int trial = 0; trial < 400; ++trial) {
            const afm::Vec2 from{4000 * r() - 2000, 4000 * r() - 2000}, to{4000 * r() - 2000, 4000 * r() - 2000};
            const std::vector<afm::Vec2> route = afm::lifted_route(from, to, g, {0, 0});
            TEST_ASSERT_TRUE(route.size() == 1 || route.size() == 2);
            TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0, dist(route.back(), to));
            bent += route.size() == 2;
            afm::Vec2 at = from;
            for (const afm::Vec2 &next : route) {
                const double dx = next.x - at.x, dy = next.y - at.y;
                const double c = std::fabs(dx * g.lever_axis.x + dy * g.lever_axis.y) / std::hypot(dx, dy);
                TEST_ASSERT_TRUE(c <= std::cos(25 * M_PI / 180) + 1e-12);
                at = next;
            }
        }
        TEST_ASSERT_TRUE(bent > 0);   // some moves needed the corner (about 28 %)
    }
    TEST_ASSERT_EQUAL(1u, afm::lifted_route({0, 0}, {100, 1000}, g, {0, 0}).size());
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_assignment_matches_brute_force);
    RUN_TEST(test_assignment_is_not_greedy);
    RUN_TEST(test_more_sites_than_particles_is_a_clear_error_the_reverse_is_not);
    RUN_TEST(test_free_push_is_straight);
    RUN_TEST(test_blocked_push_bends_around_the_obstacle);
    RUN_TEST(test_a_walled_in_site_has_no_free_push);
    RUN_TEST(test_no_leg_runs_along_the_lever);
    RUN_TEST(test_assembly_order_keeps_every_site_reachable);
    RUN_TEST(test_text_is_rasterised_into_rows_of_sites);
    RUN_TEST(test_a_pinned_site_gets_its_particle_the_rest_the_least_travel);
    RUN_TEST(test_a_pinned_site_is_read_and_its_mistakes_named);
    RUN_TEST(test_a_stroke_near_another_particle_is_short);
    RUN_TEST(test_a_particle_inside_the_clearance_may_leave_but_not_come_closer);
    RUN_TEST(test_lifted_moves_never_run_along_the_lever);
    return UNITY_END();
}
