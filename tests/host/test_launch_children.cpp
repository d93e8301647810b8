// The launcher's children (launch/children.hpp), without a bus: a child's
// exit code, its death by a signal as 128 + the signal, its output in its
// log, the kernel's accounting of its CPU; heartbeats of a process outside
// the run refused, and progress counted only when a heartbeat says
// something new; the run's key and one passed descriptor the only ones a
// child inherits, each at its slot, wherever the launcher held them.
#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iterator>
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

// The CPU seconds (user + system) the kernel has counted for a running
// process so far (/proc/PID/stat's utime and stime), or -1 once it is gone.
static double cpu_so_far_s(pid_t pid)
{
    std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
    std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const auto close_paren = text.rfind(')');
    if (close_paren == std::string::npos) return -1;
    std::istringstream rest(text.substr(close_paren + 2));
    std::string field;
    double ticks = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i)   // fields 14 and 15: utime, stime
        if (i >= 14) ticks += std::stod(field);
    return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

void test_a_child_killed_reads_as_128_plus_the_signal_and_its_cpu_is_counted()
{
    const std::string log = log_path();
    Child c;
    c.pid = afm::launch::spawn({"/bin/sh", "-c", "i=0; while :; do i=$((i+1)); done"}, log, {}, 0, {});
    // Until it has spun 0.1 s of CPU (on a loaded machine that takes longer
    // than 0.1 s of wall time), at most 20 s.
    for (int i = 0; i < 2000 && cpu_so_far_s(c.pid) < 0.1; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
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

// A descriptor at `slot` (moved there from `fd`), or at any free place
// above 9 when slot is -1; close-on-exec, as the launcher holds its own.
static int at_slot(int fd, int slot)
{
    const int to = slot < 0 ? fcntl(fd, F_DUPFD_CLOEXEC, 10) : dup3(fd, slot, O_CLOEXEC);
    TEST_ASSERT_TRUE(to >= 0);
    if (to != fd) close(fd);
    return to;
}

// What the child of spawn(key at key_slot, the pipe's write end at
// pass_slot) says: the key's bytes it reads at 3, and which of 5..9 it
// holds open; the pipe carries what it wrote at 4.
static void check_inherited(int key_slot, int pass_slot)
{
    int key = memfd_create("key", MFD_CLOEXEC);
    TEST_ASSERT_EQUAL(3, write(key, "KEY", 3));
    lseek(key, 0, SEEK_SET);
    int p[2];
    TEST_ASSERT_EQUAL(0, pipe2(p, O_CLOEXEC));
    // the slots free first: what was there is the test's own, moved above
    key = at_slot(key, -1);
    p[0] = at_slot(p[0], -1);
    p[1] = at_slot(p[1], -1);
    const int devnull = open("/dev/null", O_RDONLY);
    const int stray = dup2(devnull, 7);   // without close-on-exec: still inherited by nothing
    close(devnull);
    key = at_slot(key, key_slot);
    const int pass = at_slot(p[1], pass_slot);
    const std::string log = log_path();
    Child c;
    c.pid = afm::launch::spawn({"/bin/sh", "-c",
                                "head -c 3 <&3; echo \" env=$AFM_BUS_KEY_FD\"; echo passed >&4; "
                                "for n in 5 6 7 8 9; do [ -e /dev/fd/$n ] && echo \"open $n\"; done; exit 0"},
                               log, {}, 0, {}, {}, key, pass);
    c.reap(true);
    close(key);
    close(pass);
    close(stray);
    char got[64] = {0};
    TEST_ASSERT_TRUE(read(p[0], got, sizeof got - 1) > 0);
    close(p[0]);
    std::ifstream f(log);
    std::stringstream text;
    text << f.rdbuf();
    std::remove(log.c_str());
    TEST_ASSERT_EQUAL(0, c.exit_code);
    TEST_ASSERT_EQUAL_STRING("KEY env=3\n", text.str().c_str());
    TEST_ASSERT_EQUAL_STRING("passed\n", got);
}

void test_the_key_and_a_passed_descriptor_reach_their_slots_and_nothing_else()
{
    check_inherited(-1, -1);   // both above the slots
    check_inherited(3, 4);     // each at its own slot already
    check_inherited(4, 3);     // each at the other's slot
    check_inherited(4, -1);    // the key at the passed one's slot
    check_inherited(-1, 3);    // the passed one at the key's slot
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_a_childs_exit_code_and_output_are_kept);
    RUN_TEST(test_a_child_killed_reads_as_128_plus_the_signal_and_its_cpu_is_counted);
    RUN_TEST(test_a_program_that_cannot_run_exits_127_naming_it);
    RUN_TEST(test_progress_follows_the_runs_processes_only);
    RUN_TEST(test_the_key_and_a_passed_descriptor_reach_their_slots_and_nothing_else);
    return UNITY_END();
}
