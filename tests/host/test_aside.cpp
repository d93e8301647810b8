// Unity tests of publishing aside (bus/aside.hpp): which channels the
// lockstep reads, and so which a process of it publishes aside (the one
// rule, and its check); and that what is posted aside comes out on the
// bus, every message, in the order posted, once flush() returns or the
// Aside is gone, a full queue holding the poster back instead of dropping.
// Runs inside a private network namespace (run/in_netns.sh, from ctest):
// the bus is real udpm multicast on its loopback.
#include "aside.hpp"   // (with scene.hpp) before unity.h, whose isnan macro breaks nlohmann/json

#include <unity.h>

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "afm/heartbeat_t.hpp"
#include "afm_channels.h"
#include "bus.hpp"
#include "bus_tap.hpp"

namespace {

std::unique_ptr<afm::BusTap> tap;

afm::heartbeat_t beat(int64_t seq)
{
    afm::heartbeat_t h{};
    h.utime = seq;
    h.name = "test";
    h.pid = 1;
    h.state = "running";
    h.seq = seq;
    return h;
}

// The heartbeats' seq the tap holds once `want` have come (or 2 s passed).
std::vector<int64_t> take(std::size_t want)
{
    std::vector<int64_t> got;
    for (int i = 0; i < 200 && got.size() < want; ++i) {
        if (!tap->wait(10)) continue;
        tap->drain([&](const std::string &c, const unsigned char *d, std::size_t n, int64_t) {
            afm::heartbeat_t h;
            if (c == AFM_CH_AFM_HEARTBEAT && h.decode(d, 0, static_cast<int>(n)) >= 0) got.push_back(h.seq);
        });
    }
    return got;
}

void expect_in_order(const std::vector<int64_t> &got, int64_t n)
{
    TEST_ASSERT_EQUAL_INT(static_cast<int>(n), static_cast<int>(got.size()));
    for (int64_t k = 0; k < n; ++k) TEST_ASSERT_EQUAL_INT64(k, got[static_cast<std::size_t>(k)]);
}

}  // namespace

void setUp()
{
    tap = std::make_unique<afm::BusTap>(afm::bus_url());
}
void tearDown() { tap.reset(); }

// The lockstep's own hops, scans, fixes, frames and heartbeats are read by
// a process of the lockstep; the observers' channels are not, except the
// card's objects when the operator plans (the planner reads them every block).
void test_the_lockstep_reads_its_hops_and_the_planner_the_objects()
{
    afm::Scene s;
    s.op.plan.enabled = false;
    for (const char *c : {AFM_CH_AFM_ANALOG, AFM_CH_AFM_CMD, AFM_CH_HAPTIC_FORCE, AFM_CH_HAPTIC_POSE, AFM_CH_AFM_SCAN_REQ,
                          AFM_CH_AFM_SCAN_LINE, AFM_CH_HOST_OBJECT_FIX, AFM_CH_RENDER_FRAME, AFM_CH_AFM_HEARTBEAT})
        TEST_ASSERT_TRUE_MESSAGE(afm::lockstep_reads(s, c), c);
    for (const char *c : {AFM_CH_FW_STATE, AFM_CH_SIM_TRUTH, "NOT_A_CHANNEL", ""})
        TEST_ASSERT_FALSE_MESSAGE(afm::lockstep_reads(s, c), c);
    s.op.plan.enabled = true;
    TEST_ASSERT_TRUE(afm::lockstep_reads(s, AFM_CH_FW_STATE));
    TEST_ASSERT_FALSE(afm::lockstep_reads(s, AFM_CH_SIM_TRUTH));
}

// A process of the lockstep that subscribes to a channel published aside
// fails at start, naming itself and the channel.
void test_a_lockstep_process_reading_an_aside_channel_is_refused_by_name()
{
    afm::Scene s;
    s.op.plan.enabled = false;
    afm::check_lockstep_reads(s, {AFM_CH_HAPTIC_FORCE, AFM_CH_AFM_HEARTBEAT}, "operator");   // fine
    afm::check_lockstep_reads(s, {}, "operator");
    try {
        afm::check_lockstep_reads(s, {AFM_CH_HAPTIC_FORCE, AFM_CH_FW_STATE}, "operator");
        TEST_FAIL_MESSAGE("FW_STATE without the planner was accepted");
    } catch (const std::logic_error &e) {
        const std::string what = e.what();
        TEST_ASSERT_NOT_EQUAL(std::string::npos, what.find("operator"));
        TEST_ASSERT_NOT_EQUAL(std::string::npos, what.find("FW_STATE"));
    }
    s.op.plan.enabled = true;
    afm::check_lockstep_reads(s, {AFM_CH_HAPTIC_FORCE, AFM_CH_FW_STATE}, "operator");
}

// Every message posted is on the bus once flush() returns, in the order posted.
void test_what_is_posted_is_published_in_order_by_flush()
{
    afm::Aside aside({}, 200000);   // batches 0.2 s apart: flush must not wait for one
    const int64_t n = 300;
    for (int64_t k = 0; k < n; ++k) aside.post(AFM_CH_AFM_HEARTBEAT, beat(k));
    aside.flush();
    TEST_ASSERT_EQUAL_INT64(n, aside.published());
    TEST_ASSERT_EQUAL_INT64(0, aside.failed());
    TEST_ASSERT_EQUAL_INT64(0, aside.waits());
    expect_in_order(take(n), n);
}

// Unflushed messages come out on their batch, without flush().
void test_a_batch_goes_out_without_flush()
{
    afm::Aside aside({}, 1000);
    for (int64_t k = 0; k < 5; ++k) aside.post(AFM_CH_AFM_HEARTBEAT, beat(k));
    expect_in_order(take(5), 5);
    TEST_ASSERT_EQUAL_INT64(5, aside.published());
}

// A full queue holds the poster back until the thread has published; nothing is dropped.
void test_a_full_queue_holds_the_poster_back_and_drops_nothing()
{
    afm::Aside aside({}, 200000, 4);
    const int64_t n = 40;
    for (int64_t k = 0; k < n; ++k) aside.post(AFM_CH_AFM_HEARTBEAT, beat(k));
    aside.flush();
    TEST_ASSERT_TRUE(aside.waits() >= (n - 4) / 4);   // a wait at every full queue, at least
    TEST_ASSERT_EQUAL_INT64(n, aside.published());
    // the reports' figures are the same counts
    const nlohmann::json r = aside.report();
    TEST_ASSERT_EQUAL_INT64(n, r.at("published").get<int64_t>());
    TEST_ASSERT_EQUAL_INT64(0, r.at("failed").get<int64_t>());
    TEST_ASSERT_EQUAL_INT64(aside.waits(), r.at("waits").get<int64_t>());
    TEST_ASSERT_EQUAL_INT(3, static_cast<int>(r.size()));
    expect_in_order(take(n), n);
}

// What is still queued when the Aside goes is published first; flush() with
// nothing posted returns at once.
void test_what_is_queued_is_published_before_the_aside_goes()
{
    {
        afm::Aside aside({}, 200000);
        aside.flush();
        for (int64_t k = 0; k < 7; ++k) aside.post(AFM_CH_AFM_HEARTBEAT, beat(k));
    }
    expect_in_order(take(7), 7);
}

// A pin the kernel refuses (a CPU that does not exist) is reported, and
// the thread publishes unpinned.
void test_a_pin_refused_still_publishes()
{
    afm::Aside aside({1000}, 1000);
    aside.post(AFM_CH_AFM_HEARTBEAT, beat(0));
    aside.flush();
    expect_in_order(take(1), 1);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_lockstep_reads_its_hops_and_the_planner_the_objects);
    RUN_TEST(test_a_lockstep_process_reading_an_aside_channel_is_refused_by_name);
    RUN_TEST(test_what_is_posted_is_published_in_order_by_flush);
    RUN_TEST(test_a_batch_goes_out_without_flush);
    RUN_TEST(test_a_full_queue_holds_the_poster_back_and_drops_nothing);
    RUN_TEST(test_what_is_queued_is_published_before_the_aside_goes);
    RUN_TEST(test_a_pin_refused_still_publishes);
    return UNITY_END();
}
