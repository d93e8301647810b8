// The process skeleton (common/process.hpp, bus/run_process.hpp,
// bus/lifecycle.hpp): the run states and their text (held against
// heartbeat_t.lcm's comment, the bus's documentation of them), run_over,
// write_report's refusal naming the file, run_process's exit codes, a
// process's channels held to channels.yaml, its report written however its
// body ends, the waiting loop's states.
#include <unistd.h>

#include <cstdlib>
#include <vector>

#include <cstdio>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "process.hpp"
#include "afm_channels.h"
#include "lifecycle.hpp"
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

// ---- a process's description: its channels and its report ----------------

namespace {

struct NoOptions {
    bool quiet = false;
};

// A process named `name` with the channels given and a report at `report` ("": none).
afm::Process<NoOptions> process(const char *name, std::vector<std::string> reads, std::vector<std::string> publishes, std::string report = "")
{
    return {{name, "usage: t\n", {{{"--quiet", nullptr, "options:", "quiet"}, afm::cli::flag(&NoOptions::quiet)}}},
            std::move(reads),
            std::move(publishes),
            [report](const NoOptions &) { return report; }};
}

template <class Body>
int run(const afm::Process<NoOptions> &p, const Body &body)
{
    char prog[] = "t";
    char *argv[] = {prog, nullptr};
    return afm::run_process(p, 1, argv, body);
}

std::string slurp(const std::string &path)
{
    std::ifstream f(path);
    std::stringstream text;
    text << f.rdbuf();
    return text.str();
}

}  // namespace

void test_a_process_publishing_a_channel_channels_yaml_does_not_give_it_is_refused_naming_it()
{
    bool ran = false;
    const auto body = [&](const NoOptions &, afm::Lifecycle &) { ran = true; return 0; };
    TEST_ASSERT_EQUAL(afm::kExitFailure, run(process("renderer", {AFM_CH_FW_STATE}, {AFM_CH_RENDER_FRAME, AFM_CH_AFM_CMD}), body));
    TEST_ASSERT_FALSE_MESSAGE(ran, "refused before its body runs");
    const std::string why = afm::channels_refusal("renderer", {}, {AFM_CH_AFM_CMD});
    TEST_ASSERT_TRUE_MESSAGE(why.find("publishes AFM_CMD") != std::string::npos, why.c_str());
    TEST_ASSERT_TRUE_MESSAGE(why.find("fw_node") != std::string::npos, why.c_str());   // who channels.yaml gives it to
    TEST_ASSERT_EQUAL_STRING("", afm::channels_refusal("renderer", {AFM_CH_FW_STATE}, {AFM_CH_RENDER_FRAME, AFM_CH_AFM_HEARTBEAT}).c_str());
    TEST_ASSERT_TRUE(afm::channels_refusal("fw_node", {"NO_SUCH"}, {}).find("reads NO_SUCH") != std::string::npos);
    // readers: the truth is no process's to read; a channel read by others is refused naming them
    const std::string truth = afm::channels_refusal("operator", {AFM_CH_SIM_TRUTH}, {});
    TEST_ASSERT_TRUE_MESSAGE(truth.find("reads SIM_TRUTH") != std::string::npos && truth.find("readers: none") != std::string::npos, truth.c_str());
    const std::string analog = afm::channels_refusal("renderer", {AFM_CH_AFM_ANALOG}, {});
    TEST_ASSERT_TRUE_MESSAGE(analog.find("its readers: fw_node") != std::string::npos, analog.c_str());
    TEST_ASSERT_EQUAL_STRING("", afm::channels_refusal("afm_view_bridge", {AFM_CH_VIEW_FRAME, AFM_CH_AFM_HEARTBEAT}, {}).c_str());
    TEST_ASSERT_TRUE(afm::channels_refusal("fw_node", {}, {"NO_SUCH"}).find("publishes NO_SUCH") != std::string::npos);
    TEST_ASSERT_EQUAL(0, run(process("renderer", {AFM_CH_FW_STATE}, {AFM_CH_RENDER_FRAME}), body));
    TEST_ASSERT_TRUE(ran);
}

void test_an_inbox_subscription_the_description_does_not_declare_is_refused()
{
    afm::Lifecycle life("t", "", {AFM_CH_FW_STATE});
    life.check_subscriptions({AFM_CH_FW_STATE});
    bool named = false;
    try {
        life.check_subscriptions({AFM_CH_FW_STATE, AFM_CH_AFM_CMD});
    } catch (const std::runtime_error &e) {
        named = std::string(e.what()).find(AFM_CH_AFM_CMD) != std::string::npos;
    }
    TEST_ASSERT_TRUE(named);
}

// The report holds what the body's fill answers as the body leaves, and how it ended.
void test_the_report_is_written_however_the_body_ends()
{
    setenv("LCM_DEFAULT_URL", "memq://", 1);   // done() says "done" on a bus of its own
    char dir[] = "/tmp/afm-test-process-XXXXXX";
    TEST_ASSERT_NOT_NULL(mkdtemp(dir));
    const std::string path = std::string(dir) + "/t_report.json";
    const auto p = process("renderer", {}, {}, path);
    struct Case {
        int line;
        int code;
        std::function<int(afm::Lifecycle &, int *)> body;
        const char *ended;
        const char *error;
    } cases[] = {
        {__LINE__, 0, [](afm::Lifecycle &l, int *n) { *n = 7; l.done(*n, 0); return 0; }, "done", nullptr},
        {__LINE__, 0, [](afm::Lifecycle &, int *n) { *n = 7; return 0; }, "ok", nullptr},
        {__LINE__, afm::kExitRunOverEarly, [](afm::Lifecycle &, int *n) { *n = 7; return 3; }, "run_over_early", nullptr},
        {__LINE__, afm::kExitInput, [](afm::Lifecycle &, int *n) -> int { *n = 7; throw afm::InputError("scene.yaml: x: bad"); }, "input_error", "scene.yaml: x: bad"},
        {__LINE__, afm::kExitFailure, [](afm::Lifecycle &, int *n) -> int { *n = 7; throw std::runtime_error("disk"); }, "failure", "disk"},
    };
    for (const auto &c : cases) {
        std::remove(path.c_str());
        const int code = run(p, [&](const NoOptions &, afm::Lifecycle &life) {
            int n = 0;
            const auto report = life.report_from([&] { return nlohmann::json{{"n", n}}; });
            return c.body(life, &n);
        });
        const std::string row = "row at line " + std::to_string(c.line);
        TEST_ASSERT_EQUAL_MESSAGE(c.code, code, row.c_str());
        const nlohmann::json j = nlohmann::json::parse(slurp(path), nullptr, false);
        TEST_ASSERT_TRUE_MESSAGE(j.is_object(), row.c_str());
        TEST_ASSERT_EQUAL_MESSAGE(7, j.value("n", -1), row.c_str());   // nothing the body counted is lost
        TEST_ASSERT_EQUAL_STRING_MESSAGE(c.ended, j.value("ended", "").c_str(), row.c_str());
        TEST_ASSERT_EQUAL_STRING_MESSAGE(c.error ? c.error : "", j.value("error", "").c_str(), row.c_str());
    }
    // no report declared: nothing written
    std::remove(path.c_str());
    TEST_ASSERT_EQUAL(0, run(process("renderer", {}, {}, ""), [](const NoOptions &, afm::Lifecycle &) { return 0; }));
    TEST_ASSERT_FALSE(std::ifstream(path).good());
    rmdir(dir);
    unsetenv("LCM_DEFAULT_URL");
}

// serve(): ready until the body has started (every kReadyPeriodUs at
// most), then running, until over; done() after; the states in that order.
void test_serve_says_ready_then_running_then_done()
{
    lcm::LCM lc("memq://");
    std::vector<std::string> heard;
    struct Sub {
        std::vector<std::string> *heard;
        void on(const lcm::ReceiveBuffer *, const std::string &, const afm::heartbeat_t *m) { heard->push_back(m->state); }
    } sub{&heard};
    lc.subscribe(AFM_CH_AFM_HEARTBEAT, &Sub::on, &sub);
    afm::Lifecycle life("t", lc);
    life.starting("setting up");
    int polls = 0;
    life.serve([&] { return afm::Progress{polls >= 3, polls, 0}; },
               [&](int ms) {
                   TEST_ASSERT_EQUAL(polls < 3 ? afm::kReadyPeriodMs : 100, ms);
                   ++polls;
                   usleep(afm::kReadyPeriodUs);
                   while (lc.handleTimeout(0) > 0) {}
               },
               [&] { return polls >= 6; });
    life.done(polls, 0);
    while (lc.handleTimeout(0) > 0) {}
    TEST_ASSERT_EQUAL(6, polls);
    const std::vector<std::string> want = {"starting", "ready", "ready", "ready", "running", "done"};
    std::string got;
    for (const auto &s : heard) got += s + " ";
    TEST_ASSERT_EQUAL_MESSAGE(want.size(), heard.size(), got.c_str());
    for (std::size_t i = 0; i < want.size(); ++i) TEST_ASSERT_EQUAL_STRING_MESSAGE(want[i].c_str(), heard[i].c_str(), got.c_str());
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_lcm_comment_lists_exactly_the_states_sent);
    RUN_TEST(test_run_over_is_the_simulators_done_or_the_launchers_stop);
    RUN_TEST(test_write_report_writes_whole_and_names_a_file_it_cannot_write);
    RUN_TEST(test_run_process_answers_the_exit_code_contract);
    RUN_TEST(test_a_process_publishing_a_channel_channels_yaml_does_not_give_it_is_refused_naming_it);
    RUN_TEST(test_an_inbox_subscription_the_description_does_not_declare_is_refused);
    RUN_TEST(test_the_report_is_written_however_the_body_ends);
    RUN_TEST(test_serve_says_ready_then_running_then_done);
    return UNITY_END();
}
