// The launcher's children (launch/children.hpp), without a bus: a child's
// exit code, its death by a signal as 128 + the signal, its output in its
// log, the kernel's accounting of its CPU; heartbeats of a process outside
// the run refused, and progress counted only when a heartbeat says
// something new.
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "children.hpp"

extern "C" {
#include "unity.h"
}

using afm::launch::Child;
using afm::launch::Progress;

void setUp() {}
void tearDown() {}

static std::string log_path()
{
    char p[] = "/tmp/afm-test-child-XXXXXX";
    const int fd = mkstemp(p);
    TEST_ASSERT_TRUE(fd >= 0);
    close(fd);
    return p;
}

void test_a_childs_exit_code_and_output_are_kept()
{
    const std::string log = log_path();
    Child c;
    c.name = "sh";
    c.pid = afm::launch::spawn({"/bin/sh", "-c", "echo said; exit 3"}, log, {}, 0, {});
    c.reap(true);
    TEST_ASSERT_TRUE(c.exited);
    TEST_ASSERT_EQUAL(3, c.exit_code);
    std::ifstream f(log);
    std::stringstream text;
    text << f.rdbuf();
    TEST_ASSERT_EQUAL_STRING("said\n", text.str().c_str());
    TEST_ASSERT_EQUAL_STRING("    said\n", afm::launch::slurp_tail(log, 5).c_str());
    std::remove(log.c_str());
}

void test_a_child_killed_reads_as_128_plus_the_signal_and_its_cpu_is_counted()
{
    const std::string log = log_path();
    Child c;
    c.pid = afm::launch::spawn({"/bin/sh", "-c", "i=0; while :; do i=$((i+1)); done"}, log, {}, 0, {});
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    c.reap();   // still running: not reaped
    TEST_ASSERT_FALSE(c.exited);
    kill(c.pid, SIGKILL);
    c.reap(true);
    TEST_ASSERT_EQUAL(128 + SIGKILL, c.exit_code);
    TEST_ASSERT_TRUE(c.cpu_user_s + c.cpu_system_s > 0.05);
    TEST_ASSERT_TRUE(c.max_rss_kb > 0);
    std::remove(log.c_str());
}

void test_a_program_that_cannot_run_exits_127_naming_it()
{
    const std::string log = log_path();
    Child c;
    c.pid = afm::launch::spawn({"/nonexistent/program"}, log, {}, 0, {});
    c.reap(true);
    TEST_ASSERT_EQUAL(127, c.exit_code);
    TEST_ASSERT_TRUE(afm::launch::slurp_tail(log, 5).find("cannot execute /nonexistent/program") != std::string::npos);
    std::remove(log.c_str());
}

void test_progress_follows_the_runs_processes_only()
{
    Progress p;
    p.names = {"sim_afm", "fw_node"};
    afm::heartbeat_t m{};
    m.name = "stranger";
    m.state = "running";
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::out_of_range), static_cast<int>(p.on_hb(m)));
    TEST_ASSERT_EQUAL(0, p.last.size());
    m.name = "sim_afm";
    m.seq = 5;
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::none), static_cast<int>(p.on_hb(m)));
    TEST_ASSERT_TRUE(p.is("sim_afm", afm::RunState::running));
    TEST_ASSERT_FALSE(p.is("fw_node", afm::RunState::running));
    const auto first = p.progress_at["sim_afm"];
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    p.on_hb(m);   // the same block and state again: no progress
    TEST_ASSERT_TRUE(p.progress_at["sim_afm"] == first);
    m.seq = 6;
    p.on_hb(m);
    TEST_ASSERT_TRUE(p.progress_at["sim_afm"] > first);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_a_childs_exit_code_and_output_are_kept);
    RUN_TEST(test_a_child_killed_reads_as_128_plus_the_signal_and_its_cpu_is_counted);
    RUN_TEST(test_a_program_that_cannot_run_exits_127_naming_it);
    RUN_TEST(test_progress_follows_the_runs_processes_only);
    return UNITY_END();
}
