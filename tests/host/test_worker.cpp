// Unity tests of the worker-thread template (common/worker.hpp): items come
// out in the order pushed; flush() waits for everything queued before it; a
// periodic worker batches and a flush hurries it; a producer faster than the
// consumer waits (Full::block) or replaces what waits (Full::replace);
// stop() with a full queue drains or discards it and frees a blocked
// producer; a worker destroyed without stop() joins; an error (the handler's,
// on_start's, a producing thread's) reaches the other side by name.
// Each test stops its worker before it asserts: a failed assert leaves the
// test by longjmp, past the worker's destructor.
#include "worker.hpp"

#include <unity.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

// Holds the handler until opened.
struct Gate {
    std::mutex m;
    std::condition_variable cv;
    bool open = false;
    int waiting = 0;
    void pass()
    {
        std::unique_lock<std::mutex> l(m);
        ++waiting;
        cv.notify_all();
        cv.wait(l, [&] { return open; });
    }
    // Waits until the handler is held in pass().
    void until_held()
    {
        std::unique_lock<std::mutex> l(m);
        cv.wait(l, [&] { return waiting > 0; });
    }
    void release()
    {
        std::lock_guard<std::mutex> l(m);
        open = true;
        cv.notify_all();
    }
};

// The items a handler saw, in order, and the drops it was told of.
struct Seen {
    std::mutex m;
    std::vector<int> items;
    std::vector<std::size_t> batches;
    int64_t dropped = 0;
    void add(const std::vector<int> &batch, int64_t d)
    {
        std::lock_guard<std::mutex> l(m);
        items.insert(items.end(), batch.begin(), batch.end());
        batches.push_back(batch.size());
        dropped += d;
    }
};

void expect_zero_to(const std::vector<int> &got, int n)
{
    TEST_ASSERT_EQUAL_INT(n, static_cast<int>(got.size()));
    for (int k = 0; k < n; ++k) TEST_ASSERT_EQUAL_INT(k, got[static_cast<std::size_t>(k)]);
}

double ms_since(Clock::time_point t0)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace

void setUp() {}
void tearDown() {}

// One at a time or in batches, bounded or not: the order pushed.
void test_items_come_out_in_the_order_pushed()
{
    for (std::size_t max_batch : {std::size_t{1}, std::size_t{0}}) {
        Seen seen;
        afm::Worker<int> w({3, afm::Full::block, 0, max_batch}, [&](std::vector<int> &b, int64_t d) { seen.add(b, d); });
        w.start({}, "test");
        for (int k = 0; k < 500; ++k) w.post(k);
        w.stop(afm::Stop::drain);
        expect_zero_to(seen.items, 500);
        for (std::size_t n : seen.batches) TEST_ASSERT_TRUE(n >= 1 && (max_batch == 0 || n <= max_batch));
        const afm::QueueCounts c = w.counts();
        TEST_ASSERT_EQUAL_INT64(500, c.queued);
        TEST_ASSERT_EQUAL_INT64(500, c.handled);
        TEST_ASSERT_EQUAL_INT64(0, c.dropped);
        TEST_ASSERT_TRUE(c.high_water >= 1 && c.high_water <= 3);
    }
}

// flush() returns once every item posted before it is handled, however slow the handler.
void test_flush_waits_for_everything_queued()
{
    std::atomic<int> handled{0};
    afm::Worker<int> w({0, afm::Full::block, 0, 1}, [&](std::vector<int> &, int64_t) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        ++handled;
    });
    w.start({}, "test");
    for (int k = 0; k < 30; ++k) w.post(k);
    w.flush();
    const int seen = handled.load();
    w.flush();   // nothing new: at once
    w.stop(afm::Stop::discard);
    TEST_ASSERT_EQUAL_INT(30, seen);
    TEST_ASSERT_EQUAL_INT64(30, w.counts().handled);
    TEST_ASSERT_EQUAL_INT64(30, w.counts().queued);
}

// A periodic worker takes what is queued once a period, in one batch; a
// flush() hurries it and does not wait for the period.
void test_a_periodic_worker_batches_and_a_flush_hurries_it()
{
    Seen seen;
    afm::Worker<int> w({0, afm::Full::block, 2000000, 0}, [&](std::vector<int> &b, int64_t d) { seen.add(b, d); });
    w.start({}, "test");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));   // the thread waits in its period
    for (int k = 0; k < 50; ++k) w.post(k);
    const auto t0 = Clock::now();
    w.flush();
    const double waited_ms = ms_since(t0);
    w.stop(afm::Stop::discard);
    TEST_ASSERT_TRUE_MESSAGE(waited_ms < 1000, "flush waited for the period");
    expect_zero_to(seen.items, 50);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(seen.batches.size()));
}

// Full::block: a producer faster than the consumer waits for room; nothing is dropped.
void test_a_faster_producer_waits_and_nothing_is_dropped()
{
    Seen seen;
    afm::Worker<int> w({2, afm::Full::block, 0, 1}, [&](std::vector<int> &b, int64_t d) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        seen.add(b, d);
    });
    w.start({}, "test");
    for (int k = 0; k < 40; ++k) w.post(k);
    w.flush();
    w.stop(afm::Stop::discard);
    expect_zero_to(seen.items, 40);
    const afm::QueueCounts c = w.counts();
    TEST_ASSERT_TRUE(c.waits > 10);
    TEST_ASSERT_TRUE(c.wait_s > 0);
    TEST_ASSERT_EQUAL_INT64(0, c.dropped);
    TEST_ASSERT_TRUE(c.high_water <= 2);
}

// Full::replace: what waits is replaced by the newer item, counted, and the
// handler told how many went before the item it gets.
void test_a_faster_producer_replaces_what_waits()
{
    Gate gate;
    Seen seen;
    afm::Worker<int> w({1, afm::Full::replace, 0, 1}, [&](std::vector<int> &b, int64_t d) {
        if (b.front() == 0) gate.pass();
        seen.add(b, d);
    });
    w.start({}, "test");
    w.post(0);
    gate.until_held();   // 0 is taken; 1..9 replace one another
    for (int k = 1; k < 10; ++k) w.post(k);
    gate.release();
    w.flush();
    w.stop(afm::Stop::discard);
    TEST_ASSERT_EQUAL_INT(2, static_cast<int>(seen.items.size()));
    TEST_ASSERT_EQUAL_INT(0, seen.items[0]);
    TEST_ASSERT_EQUAL_INT(9, seen.items[1]);
    TEST_ASSERT_EQUAL_INT64(8, seen.dropped);
    TEST_ASSERT_EQUAL_INT64(8, w.counts().dropped);
    TEST_ASSERT_EQUAL_INT64(2, w.counts().handled);
}

// stop() with a full queue and a producer waiting on it: the producer is
// freed (its item dropped: the queue takes no more); drain handles what was
// queued, discard drops it; both counted.
void test_stop_with_a_full_queue_drains_or_discards()
{
    for (afm::Stop how : {afm::Stop::drain, afm::Stop::discard}) {
        Gate gate;
        Seen seen;
        afm::Worker<int> w({2, afm::Full::block, 0, 1}, [&](std::vector<int> &b, int64_t d) {
            if (b.front() == 0) gate.pass();
            seen.add(b, d);
        });
        w.start({}, "test");
        w.post(0);
        gate.until_held();
        w.post(1);
        w.post(2);   // full
        std::thread producer([&] { w.post(3); });   // waits for room
        while (w.counts().waits == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        std::thread stopper([&] { w.stop(how); });
        producer.join();   // freed by the stop, before the handler is
        gate.release();
        stopper.join();
        const afm::QueueCounts c = w.counts();
        if (how == afm::Stop::drain) {
            expect_zero_to(seen.items, 3);
            TEST_ASSERT_EQUAL_INT64(1, c.dropped);   // 3, which came to a closed queue
        } else {
            expect_zero_to(seen.items, 1);
            TEST_ASSERT_EQUAL_INT64(3, c.dropped);   // 1 and 2 discarded, and 3
        }
        TEST_ASSERT_EQUAL_INT64(3, c.queued);   // 3 was not taken
        w.post(4);   // after stop: dropped, not handled
        TEST_ASSERT_EQUAL_INT64(c.dropped + 1, w.counts().dropped);
        TEST_ASSERT_EQUAL_INT64(c.handled, w.counts().handled);
    }
}

// A worker destroyed without stop() joins its thread, once the handler
// returns, without handling what waits; one never started goes at once.
void test_destruction_without_stop_joins()
{
    Gate gate;
    Seen seen;
    std::thread opener;
    {
        afm::Worker<int> w({0, afm::Full::block, 0, 1}, [&](std::vector<int> &b, int64_t d) {
            if (b.front() == 0) gate.pass();
            seen.add(b, d);
        });
        w.start({}, "test");
        for (int k = 0; k < 5; ++k) w.post(k);
        gate.until_held();
        opener = std::thread([&] {
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
            gate.release();
        });
    }
    opener.join();
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(seen.items.size()));
    {
        afm::Worker<int> never_started({}, [](std::vector<int> &, int64_t) {});
        never_started.post(1);
    }
}

// The handler's error ends the thread and is rethrown by the next post() and flush().
void test_a_handler_error_reaches_the_producer()
{
    afm::Worker<int> w({4, afm::Full::block, 0, 1}, [](std::vector<int> &b, int64_t) {
        if (b.front() == 2) throw std::runtime_error("frame 2: disk full");
    });
    w.start({}, "test");
    for (int k = 0; k < 3; ++k) w.post(k);
    try {
        w.flush();
        TEST_FAIL_MESSAGE("flush() did not rethrow");
    } catch (const std::runtime_error &e) {
        TEST_ASSERT_EQUAL_STRING("frame 2: disk full", e.what());
    }
    TEST_ASSERT_EQUAL_INT64(2, w.counts().handled);
    try {
        w.post(3);
        TEST_FAIL_MESSAGE("post() did not rethrow");
    } catch (const std::runtime_error &e) {
        TEST_ASSERT_EQUAL_STRING("frame 2: disk full", e.what());
    }
}

// on_start runs on the thread before the first item; wait_started() rethrows its error.
void test_on_start_runs_first_and_its_error_is_rethrown()
{
    std::atomic<bool> started{false}, after_start{false};
    afm::Worker<int> ok({}, [&](std::vector<int> &, int64_t) { after_start = started.load(); });
    ok.start({}, "test", [&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        started = true;
    });
    ok.post(1);
    ok.wait_started();
    TEST_ASSERT_TRUE(started.load());
    ok.flush();
    ok.stop(afm::Stop::discard);
    TEST_ASSERT_TRUE(after_start.load());

    afm::Worker<int> bad({}, [](std::vector<int> &, int64_t) {});
    bad.start({}, "test", [] { throw std::runtime_error("video.mp4: no encoder"); });
    try {
        bad.wait_started();
        TEST_FAIL_MESSAGE("wait_started() did not rethrow");
    } catch (const std::runtime_error &e) {
        TEST_ASSERT_EQUAL_STRING("video.mp4: no encoder", e.what());
    }
}

// The handler's thread CPU time is counted.
void test_the_handlers_cpu_time_is_counted()
{
    afm::Worker<int> w({}, [](std::vector<int> &, int64_t) {
        const auto t0 = Clock::now();
        volatile double x = 0;
        while (ms_since(t0) < 20) x = x + 1;
    });
    w.start({}, "test");
    w.post(1);
    w.flush();
    w.stop(afm::Stop::discard);
    TEST_ASSERT_TRUE(w.counts().cpu_s > 0.005);
}

// A producing thread (the inbox's receiver) fills a queue in batches; its
// error comes to the consumer after the items it queued.
void test_a_producing_threads_error_comes_after_its_items()
{
    afm::Queue<int> q({});
    afm::WorkerThread t;
    t.start({}, "test", [&](const std::atomic<bool> &) {
        std::vector<int> batch = {0, 1, 2};
        q.push_all(batch);
        throw std::runtime_error("bus: socket closed");
    }, [&](std::exception_ptr e) { q.fail(std::move(e), afm::Stop::drain); });
    t.join();
    std::vector<int> got;
    for (int k = 0; k < 3; ++k) TEST_ASSERT_EQUAL_UINT(1, q.take(&got, 1, 0).n);
    expect_zero_to(got, 3);
    try {
        q.take(&got, 1, 1000);
        TEST_FAIL_MESSAGE("take() did not rethrow");
    } catch (const std::runtime_error &e) {
        TEST_ASSERT_EQUAL_STRING("bus: socket closed", e.what());
    }
}

// A consumer's take() with a timeout and nothing queued returns nothing in about that time.
void test_a_take_with_nothing_queued_times_out()
{
    afm::Queue<int> q({});
    std::vector<int> got;
    const auto t0 = Clock::now();
    TEST_ASSERT_EQUAL_UINT(0, q.take(&got, 1, 20000).n);
    TEST_ASSERT_TRUE(ms_since(t0) >= 19);
    TEST_ASSERT_EQUAL_UINT(0, q.take(&got, 1, 0).n);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_items_come_out_in_the_order_pushed);
    RUN_TEST(test_flush_waits_for_everything_queued);
    RUN_TEST(test_a_periodic_worker_batches_and_a_flush_hurries_it);
    RUN_TEST(test_a_faster_producer_waits_and_nothing_is_dropped);
    RUN_TEST(test_a_faster_producer_replaces_what_waits);
    RUN_TEST(test_stop_with_a_full_queue_drains_or_discards);
    RUN_TEST(test_destruction_without_stop_joins);
    RUN_TEST(test_a_handler_error_reaches_the_producer);
    RUN_TEST(test_on_start_runs_first_and_its_error_is_rethrown);
    RUN_TEST(test_the_handlers_cpu_time_is_counted);
    RUN_TEST(test_a_producing_threads_error_comes_after_its_items);
    RUN_TEST(test_a_take_with_nothing_queued_times_out);
    return UNITY_END();
}
