// The operator's turn taking (operator/planner_turns.hpp), without a bus: the
// planner's thread asks for a block, a scan and a fix in turn and waits for
// each answer; the bus side sees one request at a time, in order, and its
// answer is what the planner gets; stop() ends a waiting planner with
// PlanStopped; finish() says done or failed with the planner's exception.
#include <atomic>
#include <stdexcept>
#include <thread>

#include "planner_turns.hpp"

extern "C" {
#include "unity.h"
}

void setUp() {}
void tearDown() {}

using afm::PlannerTurns;

static afm::objects_t model_at(int64_t seq)
{
    afm::objects_t m{};
    m.seq = seq;
    return m;
}

void test_requests_are_served_one_at_a_time_in_order()
{
    PlannerTurns turns;
    std::atomic<int> got_seq{-1}, got_rows{-1};
    std::string note;
    std::thread planner([&] {
        got_seq = static_cast<int>(turns.block({{10, 20}, true, 5}).seq);
        got_rows = turns.scan({0, 0, 100, 8}).rows;
        turns.fix(7, {1, 2}, true, &note);
        turns.finish(nullptr);
    });
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::Block), static_cast<int>(turns.next(2000)));
    TEST_ASSERT_EQUAL_DOUBLE(10, turns.pose().tip_nm.x);
    TEST_ASSERT_TRUE(turns.pose().engaged);
    // the planner waits: no new request until answered
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::Block), static_cast<int>(turns.next(20)));
    turns.answer(model_at(41), 0.041);
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::Scan), static_cast<int>(turns.next(2000)));
    TEST_ASSERT_EQUAL(41, got_seq.load());
    TEST_ASSERT_EQUAL(8, turns.field().px);
    const cv::Mat heights = cv::Mat::zeros(8, 8, CV_64F);
    turns.answer(model_at(41), 0.041, &heights);
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::Fix), static_cast<int>(turns.next(2000)));
    TEST_ASSERT_EQUAL(8, got_rows.load());
    TEST_ASSERT_EQUAL(7, turns.fix_object());
    TEST_ASSERT_TRUE(turns.fix_place());
    turns.answer(model_at(42), 0.042, nullptr, "refused: beyond the firmware's limit");
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::Done), static_cast<int>(turns.next(2000)));
    planner.join();
    TEST_ASSERT_EQUAL_STRING("refused: beyond the firmware's limit", note.c_str());
    TEST_ASSERT_NULL(turns.error());
}

void test_no_request_reads_as_none_after_the_wait()
{
    PlannerTurns turns;
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::None), static_cast<int>(turns.next(5)));
}

void test_stop_ends_a_waiting_planner_and_any_later_call()
{
    PlannerTurns turns;
    std::atomic<int> stopped{0};
    std::thread planner([&] {
        try {
            turns.block({{0, 0}, false, 0});
        } catch (const afm::PlanStopped &) {
            ++stopped;
        }
        try {
            turns.block({{0, 0}, false, 0});
        } catch (const afm::PlanStopped &) {
            ++stopped;
        }
    });
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::Block), static_cast<int>(turns.next(2000)));
    turns.stop();
    planner.join();
    TEST_ASSERT_EQUAL(2, stopped.load());
}

void test_a_failed_planner_hands_its_exception_to_the_bus_side()
{
    PlannerTurns turns;
    std::thread planner([&] {
        try {
            throw std::runtime_error("no path");
        } catch (...) {
            turns.finish(std::current_exception());
        }
    });
    planner.join();
    TEST_ASSERT_EQUAL(static_cast<int>(PlannerTurns::Req::Failed), static_cast<int>(turns.next(10)));
    bool named = false;
    try {
        std::rethrow_exception(turns.error());
    } catch (const std::runtime_error &e) {
        named = std::string(e.what()) == "no path";
    }
    TEST_ASSERT_TRUE(named);
}

static afm::objects_t one_particle(int id, double x, double y)
{
    afm::objects_t m{};
    afm::particle_t p{};
    p.id = id;
    p.x_nm = x;
    p.y_nm = y;
    m.particles.push_back(p);
    m.n_particles = 1;
    return m;
}

// The card answers a fix with its model: a place fix (or the step filter's
// drift fix) puts the particle on the scan; the Kalman filter's drift fix
// moves it by its gain, short of the scan, and is applied all the same; a
// refused fix leaves the model where it was.
void test_a_fix_is_judged_applied_from_the_model_it_leaves()
{
    const double pm = 0.0015;
    afm::object_fix_t f{};
    f.object_id = 3;
    f.scan_x_nm = 110;
    f.scan_y_nm = 50;
    f.kind = afm::object_fix_t::KIND_PLACE;
    const afm::objects_t before = one_particle(3, 100, 50);
    TEST_ASSERT_TRUE(afm::fix_applied(before, one_particle(3, 110, 50), f, pm));
    TEST_ASSERT_FALSE(afm::fix_applied(before, before, f, pm));                       // refused
    TEST_ASSERT_FALSE(afm::fix_applied(before, one_particle(3, 108.5, 50), f, pm));   // a place fix is taken whole
    f.kind = afm::object_fix_t::KIND_DRIFT;
    TEST_ASSERT_TRUE(afm::fix_applied(before, one_particle(3, 110, 50), f, pm));       // step: taken whole
    TEST_ASSERT_TRUE(afm::fix_applied(before, one_particle(3, 108.5, 50), f, pm));     // Kalman: gain 0.85
    TEST_ASSERT_FALSE(afm::fix_applied(before, before, f, pm));                       // refused
    TEST_ASSERT_FALSE(afm::fix_applied(before, one_particle(4, 110, 50), f, pm));      // gone from the model
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_requests_are_served_one_at_a_time_in_order);
    RUN_TEST(test_no_request_reads_as_none_after_the_wait);
    RUN_TEST(test_stop_ends_a_waiting_planner_and_any_later_call);
    RUN_TEST(test_a_failed_planner_hands_its_exception_to_the_bus_side);
    RUN_TEST(test_a_fix_is_judged_applied_from_the_model_it_leaves);
    return UNITY_END();
}
