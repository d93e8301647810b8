// The operator's turn taking (operator/turn_bench.hpp), without a bus: the
// planner's thread asks for a block, a scan and a fix in turn and waits for
// each answer; the bus side sees one request at a time, in order, and its
// answer is what the planner gets; stop() ends a waiting planner with
// PlanStopped; finish() says done or failed with the planner's exception.
#include <atomic>
#include <stdexcept>
#include <thread>

#include "turn_bench.hpp"

extern "C" {
#include "unity.h"
}

void setUp() {}
void tearDown() {}

using afm::TurnBench;

static afm::objects_t model_at(int64_t seq)
{
    afm::objects_t m{};
    m.seq = seq;
    return m;
}

void test_requests_are_served_one_at_a_time_in_order()
{
    TurnBench bench;
    std::atomic<int> got_seq{-1}, got_rows{-1};
    std::string note;
    std::thread planner([&] {
        got_seq = static_cast<int>(bench.block({{10, 20}, true, 5}).seq);
        got_rows = bench.scan({0, 0, 100, 8}).rows;
        bench.fix(7, {1, 2}, true, &note);
        bench.finish(nullptr);
    });
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::Block), static_cast<int>(bench.next(2000)));
    TEST_ASSERT_EQUAL_DOUBLE(10, bench.pose().tip_nm.x);
    TEST_ASSERT_TRUE(bench.pose().engaged);
    // the planner waits: no new request until answered
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::Block), static_cast<int>(bench.next(20)));
    bench.answer(model_at(41), 0.041);
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::Scan), static_cast<int>(bench.next(2000)));
    TEST_ASSERT_EQUAL(41, got_seq.load());
    TEST_ASSERT_EQUAL(8, bench.field().px);
    const cv::Mat heights = cv::Mat::zeros(8, 8, CV_64F);
    bench.answer(model_at(41), 0.041, &heights);
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::Fix), static_cast<int>(bench.next(2000)));
    TEST_ASSERT_EQUAL(8, got_rows.load());
    TEST_ASSERT_EQUAL(7, bench.fix_object());
    TEST_ASSERT_TRUE(bench.fix_place());
    bench.answer(model_at(42), 0.042, nullptr, "refused: beyond the firmware's limit");
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::Done), static_cast<int>(bench.next(2000)));
    planner.join();
    TEST_ASSERT_EQUAL_STRING("refused: beyond the firmware's limit", note.c_str());
    TEST_ASSERT_NULL(bench.error());
}

void test_no_request_reads_as_none_after_the_wait()
{
    TurnBench bench;
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::None), static_cast<int>(bench.next(5)));
}

void test_stop_ends_a_waiting_planner_and_any_later_call()
{
    TurnBench bench;
    std::atomic<int> stopped{0};
    std::thread planner([&] {
        try {
            bench.block({{0, 0}, false, 0});
        } catch (const afm::PlanStopped &) {
            ++stopped;
        }
        try {
            bench.block({{0, 0}, false, 0});
        } catch (const afm::PlanStopped &) {
            ++stopped;
        }
    });
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::Block), static_cast<int>(bench.next(2000)));
    bench.stop();
    planner.join();
    TEST_ASSERT_EQUAL(2, stopped.load());
}

void test_a_failed_planner_hands_its_exception_to_the_bus_side()
{
    TurnBench bench;
    std::thread planner([&] {
        try {
            throw std::runtime_error("no path");
        } catch (...) {
            bench.finish(std::current_exception());
        }
    });
    planner.join();
    TEST_ASSERT_EQUAL(static_cast<int>(TurnBench::Req::Failed), static_cast<int>(bench.next(10)));
    bool named = false;
    try {
        std::rethrow_exception(bench.error());
    } catch (const std::runtime_error &e) {
        named = std::string(e.what()) == "no path";
    }
    TEST_ASSERT_TRUE(named);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_requests_are_served_one_at_a_time_in_order);
    RUN_TEST(test_no_request_reads_as_none_after_the_wait);
    RUN_TEST(test_stop_ends_a_waiting_planner_and_any_later_call);
    RUN_TEST(test_a_failed_planner_hands_its_exception_to_the_bus_side);
    return UNITY_END();
}
