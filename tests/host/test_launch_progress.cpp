// The run's progress (launch/progress.hpp), from heartbeats fed at given
// times: a stall is a live process with nothing new for the stall time
// (since the start when it never spoke), a heartbeat that repeats the last
// is no progress, a process done never stalls; the end of the simulator's
// loop; the progress line and the stage it names.
#include <chrono>
#include <string>

#include "progress.hpp"
#include "scene.hpp"

extern "C" {
#include "unity.h"
}

using afm::launch::Progress;
using Clock = Progress::Clock;
using std::chrono::milliseconds;

void setUp() {}
void tearDown() {}

static afm::heartbeat_t hb(const char *name, int64_t seq, const char *state = "running", int64_t sim_utime = 0)
{
    afm::heartbeat_t m{};
    m.name = name;
    m.seq = seq;
    m.state = state;
    m.sim_utime = sim_utime;
    return m;
}

static const std::vector<std::string> kLive = {"sim_afm", "fw_node"};

void test_a_process_never_heard_stalls_from_the_start()
{
    Progress p;
    p.names = {"sim_afm", "fw_node"};
    const auto t0 = Clock::now();
    p.on_hb(hb("sim_afm", 1), t0 + milliseconds(1000));
    TEST_ASSERT_EQUAL_STRING("", p.stalled(kLive, 5, t0, t0 + milliseconds(4000)).c_str());
    TEST_ASSERT_EQUAL_STRING("fw_node", p.stalled(kLive, 5, t0, t0 + milliseconds(5500)).c_str());
}

void test_a_repeated_heartbeat_is_no_progress_and_a_new_block_is()
{
    Progress p;
    p.names = {"sim_afm", "fw_node"};
    const auto t0 = Clock::now();
    p.on_hb(hb("sim_afm", 1), t0);
    p.on_hb(hb("fw_node", 1), t0);
    p.on_hb(hb("sim_afm", 1), t0 + milliseconds(4000));   // the same block again
    p.on_hb(hb("fw_node", 2), t0 + milliseconds(4000));   // a new one
    TEST_ASSERT_EQUAL_STRING("sim_afm", p.stalled(kLive, 5, t0, t0 + milliseconds(5100)).c_str());
    p.on_hb(hb("sim_afm", 1, "done"), t0 + milliseconds(5200));   // a new state
    TEST_ASSERT_EQUAL_STRING("", p.stalled(kLive, 5, t0, t0 + milliseconds(9000)).c_str());
    TEST_ASSERT_EQUAL_STRING("fw_node", p.stalled(kLive, 5, t0, t0 + milliseconds(9100)).c_str());
    // a process done is never stalled, nor one no longer live
    TEST_ASSERT_EQUAL_STRING("", p.stalled({"sim_afm"}, 5, t0, t0 + milliseconds(60000)).c_str());
}

void test_the_start_restarts_every_clock()
{
    Progress p;
    p.names = {"sim_afm", "fw_node"};
    const auto t0 = Clock::now();
    p.on_hb(hb("sim_afm", 1, "ready"), t0);
    p.on_hb(hb("fw_node", 1, "ready"), t0);
    p.restart_clocks(t0 + milliseconds(30000));   // a long scan before the start
    TEST_ASSERT_EQUAL_STRING("", p.stalled(kLive, 5, t0, t0 + milliseconds(34000)).c_str());
    TEST_ASSERT_EQUAL_STRING("sim_afm", p.stalled(kLive, 5, t0, t0 + milliseconds(35100)).c_str());
}

void test_heartbeats_of_others_are_refused()
{
    Progress p;
    p.names = {"sim_afm"};
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::out_of_range), static_cast<int>(p.on_hb(hb("stranger", 1))));
    TEST_ASSERT_EQUAL(0, p.last.size());
    TEST_ASSERT_EQUAL(0, p.progress_at.size());
}

void test_the_loop_is_over_at_its_last_block_or_when_done()
{
    Progress p;
    p.names = {"sim_afm", "renderer"};
    TEST_ASSERT_FALSE(p.sim_loop_over(100));
    p.on_hb(hb("sim_afm", 98, "running", 490000));
    TEST_ASSERT_FALSE(p.sim_loop_over(100));
    TEST_ASSERT_EQUAL_DOUBLE(0.49, p.sim_seconds());
    p.on_hb(hb("sim_afm", 99));
    TEST_ASSERT_TRUE(p.sim_loop_over(100));
    p.on_hb(hb("sim_afm", 3, "done"));
    TEST_ASSERT_TRUE(p.sim_loop_over(100));
}

void test_the_progress_line_says_time_and_frames()
{
    afm::Scene s;
    Progress p;
    p.names = {"sim_afm", "renderer"};
    TEST_ASSERT_EQUAL_STRING("run: initial scan, processes starting   wall 1.5 s   ", p.line(s, false, 1.5).c_str());
    p.on_hb(hb("sim_afm", 10, "running", 250000));
    const std::string l = p.line(s, true, 2.0);
    TEST_ASSERT_TRUE_MESSAGE(l.rfind("run: loop   sim 0.25 / ", 0) == 0, l.c_str());
    TEST_ASSERT_TRUE_MESSAGE(l.find("frames 0 / ") != std::string::npos && l.find("wall 2.0 s") != std::string::npos, l.c_str());
}

static afm::heartbeat_t scanning(int64_t seq, const char *state, const char *detail)
{
    afm::heartbeat_t m = hb("sim_afm", seq, state);
    m.detail = detail;
    return m;
}

void test_the_progress_line_names_the_stage()
{
    // 3 s at 1 kHz blocks, 25 frames a second: the last frame period is the
    // last 40 blocks. Each stage by what the simulator last said.
    afm::Scene s;
    s.duration_s = 3;
    s.block_hz = 1000;
    s.frame_rate_hz = 25;
    Progress p;
    p.names = {"sim_afm"};
    p.on_hb(scanning(-1, "ready", "scan 120 / 512 lines"));
    TEST_ASSERT_EQUAL_STRING("initial scan (120 / 512 lines)", p.stage(s, false).c_str());
    p.on_hb(hb("sim_afm", 500));
    TEST_ASSERT_EQUAL_STRING("loop", p.stage(s, true).c_str());
    p.on_hb(scanning(700, "running", "scan 3 / 64 lines"));
    TEST_ASSERT_EQUAL_STRING("loop, a local scan (3 / 64 lines)", p.stage(s, true).c_str());
    p.on_hb(scanning(2970, "running", "scan 300 / 512 lines"));
    TEST_ASSERT_EQUAL_STRING("final scan (300 / 512 lines)", p.stage(s, true).c_str());
    TEST_ASSERT_TRUE(p.line(s, true, 9.0).rfind("run: final scan (300 / 512 lines)   sim ", 0) == 0);
    p.on_hb(hb("sim_afm", 2999));
    TEST_ASSERT_EQUAL_STRING("end (processes finish)", p.stage(s, true).c_str());
}

void test_after_the_loop_the_line_names_what_it_waits_for()
{
    afm::Scene s;
    Progress p;
    p.names = {"sim_afm", "fw_node", "renderer"};
    const int64_t n = s.total_blocks();
    p.on_hb(hb("fw_node", n / 2, "running"));
    p.on_hb(hb("renderer", n - 1, "done"));
    p.on_hb(hb("sim_afm", n - 2, "running"));
    std::string l = p.line(s, true, 3.0);
    TEST_ASSERT_TRUE_MESSAGE(l.find("finishing") == std::string::npos, l.c_str());
    p.on_hb(hb("sim_afm", n - 1, "running"));
    l = p.line(s, true, 3.0);
    const std::string want = "simulation over; finishing: fw_node (block " + std::to_string(n / 2 + 1) + " / " + std::to_string(n) + ")";
    TEST_ASSERT_TRUE_MESSAGE(l.find(want) != std::string::npos, l.c_str());
    TEST_ASSERT_TRUE_MESSAGE(l.find("renderer") == std::string::npos, l.c_str());
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_a_process_never_heard_stalls_from_the_start);
    RUN_TEST(test_a_repeated_heartbeat_is_no_progress_and_a_new_block_is);
    RUN_TEST(test_the_start_restarts_every_clock);
    RUN_TEST(test_heartbeats_of_others_are_refused);
    RUN_TEST(test_the_loop_is_over_at_its_last_block_or_when_done);
    RUN_TEST(test_the_progress_line_says_time_and_frames);
    RUN_TEST(test_the_progress_line_names_the_stage);
    RUN_TEST(test_after_the_loop_the_line_names_what_it_waits_for);
    return UNITY_END();
}
