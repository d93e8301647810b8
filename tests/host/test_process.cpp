// The process skeleton (common/process.hpp): the run states and their text
// (held against heartbeat_t.lcm's comment, the bus's documentation of them),
// run_over, write_report's refusal naming the file, run_process's exit codes.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "process.hpp"
#include "run_process.hpp"
#include "scene.hpp"

extern "C" {
#include "unity.h"
}

void setUp() {}
void tearDown() {}

static std::set<std::string> states_of_enum()
{
    std::set<std::string> s;
    for (afm::RunState r : afm::kRunStates) s.insert(afm::state_text(r));
    return s;
}

// "string state; // one of (...): a, b, c" in lcmtypes/heartbeat_t.lcm
static std::set<std::string> states_of_lcm_comment()
{
    std::ifstream f(AFM_HEARTBEAT_LCM);
    TEST_ASSERT_TRUE_MESSAGE(f.good(), AFM_HEARTBEAT_LCM);
    std::string line;
    std::set<std::string> s;
    while (std::getline(f, line)) {
        std::smatch m;
        if (!std::regex_search(line, m, std::regex(R"(string\s+state;\s*//[^:]*:\s*(.*)$)"))) continue;
        std::stringstream list(m[1].str());
        std::string word;
        while (std::getline(list, word, ',')) {
            word = std::regex_replace(word, std::regex(R"(^\s+|\s+$)"), "");
            if (!word.empty()) s.insert(word);
        }
    }
    return s;
}

void test_the_lcm_comment_lists_exactly_the_states_sent()
{
    const auto a = states_of_enum(), b = states_of_lcm_comment();
    std::string only_enum, only_lcm;
    for (const auto &x : a)
        if (!b.count(x)) only_enum += x + " ";
    for (const auto &x : b)
        if (!a.count(x)) only_lcm += x + " ";
    TEST_ASSERT_EQUAL_STRING_MESSAGE("", only_enum.c_str(), "states sent but not in heartbeat_t.lcm's comment");
    TEST_ASSERT_EQUAL_STRING_MESSAGE("", only_lcm.c_str(), "states in heartbeat_t.lcm's comment that the code never sends");
    TEST_ASSERT_EQUAL(7, a.size());
}

void test_run_over_is_the_simulators_done_or_the_launchers_stop()
{
    afm::heartbeat_t m{};
    m.name = "sim_afm", m.state = "done";
    TEST_ASSERT_TRUE(afm::run_over(m));
    m.name = "launcher", m.state = "stop";
    TEST_ASSERT_TRUE(afm::run_over(m));
    m.name = "fw_node", m.state = "done";   // a peer's own end is not the run's
    TEST_ASSERT_FALSE(afm::run_over(m));
    m.name = "sim_afm", m.state = "ending";
    TEST_ASSERT_FALSE(afm::run_over(m));
    m.name = "launcher", m.state = "running";
    TEST_ASSERT_FALSE(afm::run_over(m));
}

void test_write_report_writes_whole_and_names_a_file_it_cannot_write()
{
    char dir[] = "/tmp/afm-test-process-XXXXXX";
    TEST_ASSERT_NOT_NULL(mkdtemp(dir));
    const std::string path = std::string(dir) + "/r.json";
    afm::write_report(path, nlohmann::json{{"a", 1}});
    std::ifstream f(path);
    std::stringstream text;
    text << f.rdbuf();
    TEST_ASSERT_EQUAL_STRING("{\n  \"a\": 1\n}\n", text.str().c_str());
    bool threw = false;
    try {
        afm::write_report(std::string(dir) + "/no/such/folder/r.json", nlohmann::json{{"a", 1}});
    } catch (const std::runtime_error &e) {
        threw = std::string(e.what()).find("no/such/folder/r.json") != std::string::npos;
    }
    TEST_ASSERT_TRUE_MESSAGE(threw, "the refusal names the file");
    std::remove(path.c_str());
    rmdir(dir);
}

void test_run_process_answers_the_exit_code_contract()
{
    TEST_ASSERT_EQUAL(0, afm::run_process("t", [] { return 0; }));
    TEST_ASSERT_EQUAL(afm::kExitInput, afm::run_process("t", []() -> int { throw afm::SceneError("scene.yaml: x: bad"); }));
    TEST_ASSERT_EQUAL(afm::kExitInput, afm::run_process("t", []() -> int { throw afm::InputError("a pattern"); }));
    TEST_ASSERT_EQUAL(afm::kExitFailure, afm::run_process("t", []() -> int { throw std::runtime_error("disk"); }));
    TEST_ASSERT_EQUAL(afm::kExitRunOverEarly, afm::run_process("t", [] { return static_cast<int>(afm::kExitRunOverEarly); }));
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_lcm_comment_lists_exactly_the_states_sent);
    RUN_TEST(test_run_over_is_the_simulators_done_or_the_launchers_stop);
    RUN_TEST(test_write_report_writes_whole_and_names_a_file_it_cannot_write);
    RUN_TEST(test_run_process_answers_the_exit_code_contract);
    return UNITY_END();
}
