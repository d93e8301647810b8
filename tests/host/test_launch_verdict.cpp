// The run's verdict (launch/verdict.hpp), judged from run.json as the
// launcher puts it together: every check it can fail is one a scene's
// expect: may name (scene.hpp's verdict_checks); the assembly check fails
// on a site left empty or a rod off its target (fidelity.json "assembly")
// and passes when all are placed; an expected failure that happens passes,
// one that does not happen fails.
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "scene.hpp"
#include "verdict.hpp"

extern "C" {
#include "unity.h"
}

using nlohmann::json;

void setUp() {}
void tearDown() {}

// A run.json whose planner filled `placed` of 4 sites, with one rod placed or not.
static json run_with_assembly(int placed, bool rod_placed)
{
    json run;
    run["fidelity"] = {{"pass", true}, {"max_position_error_nm", 1.0}, {"rms_height_error_nm", 0.5}, {"target_nm", 5.0}};
    run["fidelity"]["assembly"] = {
        {"particles", {{"sites", 4}, {"placed", placed}, {"missing", 4 - placed}, {"tolerance_nm", 20.0}}},
        {"rods", json::array({{{"id", 7}, {"placed", rod_placed}}})}};
    run["fw"] = {{"interlock_trips", 0}, {"saturated_samples", 0}, {"unobservable_push_blocks", 0}};
    return run;
}

static std::set<std::string> failed_checks(const json &verdict)
{
    std::set<std::string> out;
    for (const auto &f : verdict["failed"]) out.insert(f["check"].get<std::string>());
    return out;
}

void test_every_check_that_can_fail_is_one_a_scene_may_expect()
{
    json run = run_with_assembly(3, false);
    run["fidelity"]["pass"] = false;
    run["fw"] = {{"interlock_trips", 2}, {"saturated_samples", 5}, {"unobservable_push_blocks", 9}};
    run["sim"]["solver"] = {{"unconverged_samples", 3}, {"cap", 200}, {"force_tolerance_nN", 0.002}, {"gap_tolerance_nm", 0.01}};
    const std::set<std::string> failed = failed_checks(afm::judge(run, {}));
    const auto &names = afm::verdict_checks();
    TEST_ASSERT_EQUAL(static_cast<int>(names.size()), static_cast<int>(failed.size()));
    for (const auto &n : names) TEST_ASSERT_TRUE_MESSAGE(failed.count(n), n.c_str());
}

void test_assembly_with_an_empty_site_fails_naming_the_sites()
{
    const json v = afm::judge(run_with_assembly(3, true), {});
    TEST_ASSERT_FALSE(v["pass"].get<bool>());
    TEST_ASSERT_EQUAL(1, static_cast<int>(v["failed"].size()));
    TEST_ASSERT_EQUAL_STRING("assembly", v["failed"][0]["check"].get<std::string>().c_str());
    TEST_ASSERT_EQUAL_STRING("3 of 4 sites hold a particle within 20.0 nm", v["failed"][0]["detail"].get<std::string>().c_str());
}

void test_assembly_with_a_rod_off_its_target_fails()
{
    const json v = afm::judge(run_with_assembly(4, false), {});
    TEST_ASSERT_TRUE(failed_checks(v) == std::set<std::string>{"assembly"});
    TEST_ASSERT_EQUAL_STRING("rod 7 off its target", v["failed"][0]["detail"].get<std::string>().c_str());
}

void test_assembly_all_placed_passes()
{
    const json v = afm::judge(run_with_assembly(4, true), {});
    TEST_ASSERT_TRUE(v["pass"].get<bool>());
    TEST_ASSERT_EQUAL_STRING("run: verdict: pass", afm::verdict_line(v).c_str());
}

void test_an_expected_failure_passes_and_an_unmet_one_fails()
{
    const json met = afm::judge(run_with_assembly(3, true), {"assembly"});
    TEST_ASSERT_TRUE(met["pass"].get<bool>());
    TEST_ASSERT_EQUAL_STRING("run: verdict: pass (failed as the scene expects: assembly)", afm::verdict_line(met).c_str());
    const json unmet = afm::judge(run_with_assembly(4, true), {"assembly"});
    TEST_ASSERT_TRUE(failed_checks(unmet) == std::set<std::string>{"expect"});
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_every_check_that_can_fail_is_one_a_scene_may_expect);
    RUN_TEST(test_assembly_with_an_empty_site_fails_naming_the_sites);
    RUN_TEST(test_assembly_with_a_rod_off_its_target_fails);
    RUN_TEST(test_assembly_all_placed_passes);
    RUN_TEST(test_an_expected_failure_passes_and_an_unmet_one_fails);
    return UNITY_END();
}
