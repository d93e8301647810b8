// Unity tests of what paces a run besides the bus: where its processes run
// (common/placement: the lockstep's CPU and the observers', taken through
// lock files so that concurrent runs take different CPUs) and how far the
// simulator may run ahead of the renderer (common/scene:
// local_scan_frame, frames_to_wait_for).
#include <unity.h>

#include <sched.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "placement.hpp"
#include "lockstep.hpp"
#include "scene.hpp"

namespace {

std::string lock_dir;

void setUp_dir()
{
    char d[] = "/tmp/afm-test-placement-XXXXXX";
    TEST_ASSERT_NOT_NULL(mkdtemp(d));
    lock_dir = d;
}

void remove_dir()
{
    for (int c = 0; c < 8; ++c) unlink((lock_dir + "/afm-lockstep-cpu" + std::to_string(c) + ".lock").c_str());
    rmdir(lock_dir.c_str());
}

// A scene of `seconds` at 1 kHz blocks and 25 frames per second, with local
// scans at the given times.
afm::Scene scene_of(double seconds, const std::vector<double> &scans_at_s = {})
{
    afm::Scene s;
    s.duration_s = seconds;
    s.block_hz = 1000;
    s.frame_rate_hz = 25;
    for (double t : scans_at_s) {
        afm::LocalScanSpec ls;
        ls.at_s = t;
        s.op.local_scans.push_back(ls);
    }
    return s;
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_cpu_list_is_written_as_the_kernel_writes_it()
{
    TEST_ASSERT_EQUAL_STRING("", afm::cpu_list({}).c_str());
    TEST_ASSERT_EQUAL_STRING("0", afm::cpu_list({0}).c_str());
    TEST_ASSERT_EQUAL_STRING("0-2,5", afm::cpu_list({0, 1, 2, 5}).c_str());
    TEST_ASSERT_EQUAL_STRING("1,3,5-6", afm::cpu_list({1, 3, 5, 6}).c_str());
}

// parse_cpu_list reads what cpu_list writes, and refuses anything else
// (the processes' --aside-cpus and --writer-cpus) without touching its output.
void test_a_cpu_list_reads_back_and_anything_else_is_refused()
{
    for (const std::vector<int> &c : {std::vector<int>{}, {0}, {1}, {0, 1, 2, 5}, {1, 3, 5, 6}}) {
        std::vector<int> back = {99};
        TEST_ASSERT_TRUE(afm::parse_cpu_list(afm::cpu_list(c), &back));
        TEST_ASSERT_TRUE(back == c);
    }
    for (const char *bad : {"x", "1,", ",1", "1-", "-1", "2-1", "1,1", "3,2", "1 2", "1-2-3", "99999", "1,,2"}) {
        std::vector<int> out = {7};
        TEST_ASSERT_FALSE_MESSAGE(afm::parse_cpu_list(bad, &out), bad);
        TEST_ASSERT_EQUAL_INT(1, static_cast<int>(out.size()));
        TEST_ASSERT_EQUAL_INT(7, out[0]);
    }
}

void test_one_cpu_or_none_places_nothing()
{
    setUp_dir();
    const afm::Placement one({3}, lock_dir);
    TEST_ASSERT_FALSE(one.on());
    TEST_ASSERT_TRUE(one.cpus_for("sim_afm").empty());
    TEST_ASSERT_TRUE(one.cpus_for("renderer").empty());
    TEST_ASSERT_NOT_EQUAL(std::string::npos, one.why().find("one CPU"));
    const afm::Placement none({}, lock_dir);
    TEST_ASSERT_FALSE(none.on());
    const afm::Placement off;
    TEST_ASSERT_FALSE(off.on());
    TEST_ASSERT_EQUAL_STRING("placement off", off.why().c_str());
    remove_dir();
}

void test_the_lockstep_shares_one_cpu_and_the_observers_take_the_rest()
{
    setUp_dir();
    const afm::Placement p({0, 1, 2}, lock_dir);
    TEST_ASSERT_TRUE(p.on());
    TEST_ASSERT_EQUAL_STRING("", p.why().c_str());
    TEST_ASSERT_EQUAL_STRING("0", afm::cpu_list(p.cpus_for("sim_afm")).c_str());
    TEST_ASSERT_EQUAL_STRING("0", afm::cpu_list(p.cpus_for("fw_node")).c_str());
    TEST_ASSERT_EQUAL_STRING("0", afm::cpu_list(p.cpus_for("operator")).c_str());
    TEST_ASSERT_EQUAL_STRING("1-2", afm::cpu_list(p.cpus_for("renderer")).c_str());
    TEST_ASSERT_EQUAL_STRING("1-2", afm::cpu_list(p.cpus_for("lcm-spy")).c_str());
    TEST_ASSERT_EQUAL_STRING("1-2", afm::cpu_list(p.observers()).c_str());
    TEST_ASSERT_EQUAL_STRING("0-2", afm::cpu_list(p.all()).c_str());
    TEST_ASSERT_TRUE(afm::Placement().all().empty());
    remove_dir();
}

// Concurrent runs (a sweep's points) take different CPUs for their
// lockstep; when all are taken the next run is not placed; a run that ends
// frees its CPU.
void test_concurrent_runs_take_different_cpus()
{
    setUp_dir();
    afm::Placement a({4, 7}, lock_dir);
    afm::Placement b({4, 7}, lock_dir);
    TEST_ASSERT_TRUE(a.on() && b.on());
    TEST_ASSERT_EQUAL_STRING("4", afm::cpu_list(a.lockstep()).c_str());
    TEST_ASSERT_EQUAL_STRING("7", afm::cpu_list(b.lockstep()).c_str());
    TEST_ASSERT_EQUAL_STRING("4", afm::cpu_list(b.observers()).c_str());
    {
        const afm::Placement c({4, 7}, lock_dir);
        TEST_ASSERT_FALSE(c.on());
        TEST_ASSERT_NOT_EQUAL(std::string::npos, c.why().find("another run's lockstep"));
    }
    a = afm::Placement();   // the first run ends
    const afm::Placement d({4, 7}, lock_dir);
    TEST_ASSERT_EQUAL_STRING("4", afm::cpu_list(d.lockstep()).c_str());
    // a moved placement keeps its lock
    afm::Placement e(std::move(b));
    TEST_ASSERT_FALSE(afm::Placement({4, 7}, lock_dir).on());
    remove_dir();
}

// A lock directory that cannot hold files: nothing is placed, nothing fails.
void test_a_lock_dir_that_cannot_be_written_places_nothing()
{
    const afm::Placement p({0, 1}, "/nonexistent-afm-dir");
    TEST_ASSERT_FALSE(p.on());
    // and says why, naming the file: not "taken by another run"
    TEST_ASSERT_NOT_EQUAL(std::string::npos, p.why().find("/nonexistent-afm-dir/afm-lockstep-cpu1.lock"));
    TEST_ASSERT_EQUAL(std::string::npos, p.why().find("another run"));
}

void test_this_process_can_be_pinned_and_read_back()
{
    const std::vector<int> mine = afm::allowed_cpus();
    TEST_ASSERT_FALSE(mine.empty());
    TEST_ASSERT_TRUE(afm::pin_self({mine.front()}));
    TEST_ASSERT_EQUAL_STRING(std::to_string(mine.front()).c_str(), afm::cpu_list(afm::cpus_of(getpid())).c_str());
    TEST_ASSERT_TRUE(afm::pin_self(mine));   // back
    TEST_ASSERT_EQUAL_STRING(afm::cpu_list(mine).c_str(), afm::cpu_list(afm::allowed_cpus()).c_str());
    TEST_ASSERT_TRUE(afm::pin_self({}));     // nothing to do
    TEST_ASSERT_FALSE(afm::pin_self({CPU_SETSIZE + 5}));   // no such CPU: the kernel refuses an empty set
}

// Frame k is at k * 40 ms; a local scan at at_s is taken before the first
// frame at or after it.
void test_local_scan_frame_is_the_first_frame_at_or_after_it()
{
    const afm::Scene s = scene_of(3, {0.0, 0.04, 0.041, 1.0, 2.999, 3.0});
    TEST_ASSERT_EQUAL_INT(0, afm::local_scan_frame(s, 0));
    TEST_ASSERT_EQUAL_INT(1, afm::local_scan_frame(s, 1));   // exactly on frame 1
    TEST_ASSERT_EQUAL_INT(2, afm::local_scan_frame(s, 2));
    TEST_ASSERT_EQUAL_INT(25, afm::local_scan_frame(s, 3));
    TEST_ASSERT_EQUAL_INT(75, afm::local_scan_frame(s, 4));   // after the run's last frame (74)
    TEST_ASSERT_EQUAL_INT(75, afm::local_scan_frame(s, 5));
}

// Without scans the simulator stays at most two frames ahead of the
// renderer; at the last block it waits for every frame.
void test_the_renderer_may_fall_two_frames_behind()
{
    const afm::Scene s = scene_of(3);
    const int64_t blocks = s.total_blocks();
    TEST_ASSERT_EQUAL_INT(3000, blocks);
    TEST_ASSERT_EQUAL_INT(1, afm::frames_due(s, afm::block_end_utime(s, 0)));   // frame 0 at t = 0
    TEST_ASSERT_EQUAL_INT(0, afm::frames_to_wait_for(s, 0, blocks));
    // block 399 ends at 400 ms: frames 0..10 due, so 9 must be written
    TEST_ASSERT_EQUAL_INT(11, afm::frames_due(s, afm::block_end_utime(s, 399)));
    TEST_ASSERT_EQUAL_INT(9, afm::frames_to_wait_for(s, 399, blocks));
    TEST_ASSERT_EQUAL_INT(75, afm::frames_to_wait_for(s, blocks - 1, blocks));
    // the last frame (74, at 2.96 s) asks for the final scan: the
    // simulator waits for it at the first block it is due (block 2959 ends at 2.96 s)
    TEST_ASSERT_EQUAL_INT(72, afm::frames_to_wait_for(s, 2958, blocks));
    TEST_ASSERT_EQUAL_INT(75, afm::frames_to_wait_for(s, 2959, blocks));
    for (int64_t n = 0; n < blocks; ++n) {
        const int due = afm::frames_due(s, afm::block_end_utime(s, n));
        const int need = afm::frames_to_wait_for(s, n, blocks);
        TEST_ASSERT_TRUE(need <= due && need >= due - afm::kRendererWindowFrames);
    }
}

// At a local scan's frame the simulator waits for that frame, at the block
// where it is first due, whatever the window.
void test_a_local_scan_holds_the_simulator_at_its_frame()
{
    const afm::Scene s = scene_of(3, {1.0, 1.0, 1.5});
    const int64_t blocks = s.total_blocks();
    // frame 25 at 1.0 s: first due at block 999
    TEST_ASSERT_EQUAL_INT(23, afm::frames_to_wait_for(s, 998, blocks));
    TEST_ASSERT_EQUAL_INT(26, afm::frames_to_wait_for(s, 999, blocks));
    TEST_ASSERT_EQUAL_INT(26, afm::frames_to_wait_for(s, 1000, blocks));
    TEST_ASSERT_EQUAL_INT(26, afm::frames_to_wait_for(s, 1079, blocks));   // frames 26, 27 may lag
    TEST_ASSERT_EQUAL_INT(27, afm::frames_to_wait_for(s, 1119, blocks));   // 29 due
    TEST_ASSERT_EQUAL_INT(36, afm::frames_to_wait_for(s, 1499, blocks));   // frame 37 at 1.48 s; 38 at 1.52 s
    const int f = afm::local_scan_frame(s, 2);
    TEST_ASSERT_EQUAL_INT(38, f);
    TEST_ASSERT_EQUAL_INT(f + 1, afm::frames_to_wait_for(s, 1519, blocks));
}

// The planner finished early: the run now has fewer blocks, and its last
// frame (the final scan's) holds the simulator.
void test_a_shorter_run_waits_at_its_own_last_frame()
{
    const afm::Scene s = scene_of(3);
    const int64_t blocks = 1190;   // ends at 1.19 s: frames 0..29
    TEST_ASSERT_EQUAL_INT(30, afm::frames_due(s, afm::block_end_utime(s, blocks - 1)));
    TEST_ASSERT_EQUAL_INT(30, afm::frames_to_wait_for(s, 1189, blocks));
    TEST_ASSERT_EQUAL_INT(30, afm::frames_to_wait_for(s, 1159, blocks));   // frame 29 (1.16 s) first due
    TEST_ASSERT_EQUAL_INT(27, afm::frames_to_wait_for(s, 1158, blocks));
    // a run of one block waits for its one frame
    TEST_ASSERT_EQUAL_INT(1, afm::frames_to_wait_for(s, 0, 1));
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_cpu_list_is_written_as_the_kernel_writes_it);
    RUN_TEST(test_a_cpu_list_reads_back_and_anything_else_is_refused);
    RUN_TEST(test_one_cpu_or_none_places_nothing);
    RUN_TEST(test_the_lockstep_shares_one_cpu_and_the_observers_take_the_rest);
    RUN_TEST(test_concurrent_runs_take_different_cpus);
    RUN_TEST(test_a_lock_dir_that_cannot_be_written_places_nothing);
    RUN_TEST(test_this_process_can_be_pinned_and_read_back);
    RUN_TEST(test_local_scan_frame_is_the_first_frame_at_or_after_it);
    RUN_TEST(test_the_renderer_may_fall_two_frames_behind);
    RUN_TEST(test_a_local_scan_holds_the_simulator_at_its_frame);
    RUN_TEST(test_a_shorter_run_waits_at_its_own_last_frame);
    return UNITY_END();
}
