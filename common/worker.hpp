// A thread of a process's own and the queue between it and the process's
// main thread: the one way the bench moves work off the main thread (a
// Worker: bus/aside.hpp publishing aside, host/renderer/frame_writer.hpp
// writing frames, host/renderer/view_frames.hpp encoding the page's frames)
// or brings work to it (a WorkerThread filling a Queue: bus/inbox.hpp's
// batched receiver).
//
// Queue<T>, between producers and one consumer:
//   - Order: items come out in the order pushed (the dropped ones aside).
//   - Bounded (capacity > 0) or not (0). When full, by Full:
//       block    push() waits for room (counted: waits, and wait_s, the wall
//                time they waited); nothing is dropped;
//       replace  the oldest item waiting is dropped (counted: dropped) and
//                the new one queued: the consumer sees the newest.
//   - Wake-ups: with period_us 0 a push wakes the consumer. With period_us
//     > 0 a push wakes nobody (a wake-up of a thread on another CPU costs
//     more than a datagram): the consumer takes what is queued every
//     period_us, sooner when hurried (a flush(), or a push that found the
//     queue full).
//   - flush() returns once every item pushed before the call is handled
//     (done()) or dropped.
//   - fail(e): the consumer's error (or a producing thread's). From then
//     push() and flush() rethrow it; take() returns what is still queued,
//     then rethrows it.
//   - close(): no more items; Stop::drain lets the consumer take what is
//     queued, Stop::discard drops it at once (counted). A push to a closed
//     queue is dropped (counted).
//   - counts(): queued, handled, dropped, high_water (most items waiting at
//     once), waits, wait_s, and cpu_s, the consumer's thread CPU time in
//     handling (thread_cpu_seconds(): common/placement.hpp) as done() gives it.
//
// WorkerThread: a thread started pinned (start_pinned: common/placement.hpp),
// given a stop flag, joined by join() or its destruction; an exception out
// of its body goes to the on_error it was started with.
//
// Worker<T>: a Queue<T> emptied by a WorkerThread through a handler, in
// batches of at most max_batch items (0: all that are queued). start() runs
// an on_start step on the thread before the first item (wait_started()
// waits for it); an exception from on_start or the handler fails the queue
// (Stop::discard) and ends the thread. stop(Stop::drain) handles what is
// queued, then joins; Stop::discard drops it; the destructor stops with
// Stop::discard when stop() was not called.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "placement.hpp"

namespace afm {

enum class Full { block, replace };
enum class Stop { drain, discard };

struct QueueCounts {
    int64_t queued = 0;          // items push() accepted
    int64_t handled = 0;         // items the consumer handled (done())
    int64_t dropped = 0;         // replaced, discarded, pushed after close()
    std::size_t high_water = 0;  // most items waiting at once
    int64_t waits = 0;           // pushes that waited for room (Full::block)
    double wait_s = 0;           // the wall time they waited
    double cpu_s = 0;            // the consumer's thread CPU time in handling
};

template <class T>
class Queue {
public:
    struct Options {
        std::size_t capacity = 0;   // 0: unbounded
        Full full = Full::block;
        int period_us = 0;          // 0: a push wakes the consumer
    };
    // What take() took: how many items, how many the queue dropped since
    // the previous take, and whether the queue is closed with nothing left.
    struct Took {
        std::size_t n = 0;
        int64_t dropped = 0;
        bool end = false;
    };

    explicit Queue(Options o) : o_(o) {}
    Queue(const Queue &) = delete;
    Queue &operator=(const Queue &) = delete;

    void push(T item)
    {
        std::unique_lock<std::mutex> l(m_);
        if (!admit(l)) return;
        q_.push_back(std::move(item));
        accepted(l, 1);
    }
    // Every item of `items` (emptied), with one wake-up.
    void push_all(std::vector<T> &items)
    {
        std::unique_lock<std::mutex> l(m_);
        for (auto &x : items) {
            if (!admit(l)) break;
            q_.push_back(std::move(x));
            ++c_.queued;
            c_.high_water = std::max(c_.high_water, q_.size());
        }
        items.clear();
        if (o_.period_us == 0) consumer_.notify_one();
    }

    // The consumer: waits up to timeout_us (< 0: for ever) for work (an
    // item; with period_us > 0 a hurry), then moves at most `max` items
    // (0: all) to the end of *out.
    Took take(std::vector<T> *out, std::size_t max, int64_t timeout_us)
    {
        std::unique_lock<std::mutex> l(m_);
        const auto ready = [&] { return failed_ || closed_ || hurry_ || (o_.period_us == 0 && !q_.empty()); };
        if (timeout_us < 0) consumer_.wait(l, ready);
        else consumer_.wait_for(l, std::chrono::microseconds(timeout_us), ready);
        hurry_ = false;
        if (failed_ && q_.empty()) std::rethrow_exception(failed_);
        Took t;
        t.n = max == 0 ? q_.size() : std::min(max, q_.size());
        for (std::size_t i = 0; i < t.n; ++i) {
            out->push_back(std::move(q_.front()));
            q_.pop_front();
        }
        t.dropped = std::exchange(dropped_since_take_, 0);
        t.end = closed_ && q_.empty();
        if (t.n > 0) producers_.notify_all();   // room
        return t;
    }
    // The consumer handled n items, in cpu_s of its thread's CPU.
    void done(std::size_t n, double cpu_s)
    {
        std::lock_guard<std::mutex> l(m_);
        c_.handled += static_cast<int64_t>(n);
        c_.cpu_s += cpu_s;
        producers_.notify_all();   // flush() waits for this
    }

    void flush()
    {
        std::unique_lock<std::mutex> l(m_);
        const int64_t want = c_.queued;
        hurry(l);
        producers_.wait(l, [&] { return failed_ || c_.handled + c_.dropped >= want; });
        if (failed_) std::rethrow_exception(failed_);
    }
    void fail(std::exception_ptr e, Stop queued)
    {
        std::lock_guard<std::mutex> l(m_);
        failed_ = std::move(e);
        if (queued == Stop::discard) discard();
        producers_.notify_all();
        consumer_.notify_all();
    }
    void close(Stop queued)
    {
        std::lock_guard<std::mutex> l(m_);
        closed_ = true;
        if (queued == Stop::discard) discard();
        producers_.notify_all();
        consumer_.notify_all();
    }
    // Rethrows the queue's failure, if it has one.
    void check() const
    {
        std::lock_guard<std::mutex> l(m_);
        if (failed_) std::rethrow_exception(failed_);
    }
    QueueCounts counts() const
    {
        std::lock_guard<std::mutex> l(m_);
        return c_;
    }

private:
    // Room for one more item, by the policy; false: dropped (closed).
    bool admit(std::unique_lock<std::mutex> &l)
    {
        if (failed_) std::rethrow_exception(failed_);
        const auto room = [&] { return o_.capacity == 0 || q_.size() < o_.capacity; };
        if (!closed_ && !room() && o_.full == Full::replace) {
            q_.pop_front();
            ++c_.dropped;
            ++dropped_since_take_;
        } else if (!closed_ && !room()) {
            const auto t0 = std::chrono::steady_clock::now();
            ++c_.waits;
            hurry(l);
            producers_.wait(l, [&] { return failed_ || closed_ || room(); });
            c_.wait_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (failed_) std::rethrow_exception(failed_);
        }
        if (!closed_) return true;
        ++c_.dropped;
        return false;
    }
    void accepted(std::unique_lock<std::mutex> &, std::size_t n)
    {
        c_.queued += static_cast<int64_t>(n);
        c_.high_water = std::max(c_.high_water, q_.size());
        if (o_.period_us == 0) consumer_.notify_one();
    }
    void hurry(std::unique_lock<std::mutex> &)
    {
        if (o_.period_us == 0) return;
        hurry_ = true;
        consumer_.notify_one();
    }
    void discard()
    {
        c_.dropped += static_cast<int64_t>(q_.size());
        q_.clear();
    }

    const Options o_;
    mutable std::mutex m_;
    std::condition_variable consumer_;    // work, a hurry, the end
    std::condition_variable producers_;   // room, items handled, the end
    std::deque<T> q_;
    QueueCounts c_;
    int64_t dropped_since_take_ = 0;
    bool hurry_ = false, closed_ = false;
    std::exception_ptr failed_;
};

class WorkerThread {
public:
    using Body = std::function<void(const std::atomic<bool> &stop)>;
    using OnError = std::function<void(std::exception_ptr)>;

    WorkerThread() = default;
    ~WorkerThread() { join(); }
    WorkerThread(const WorkerThread &) = delete;
    WorkerThread &operator=(const WorkerThread &) = delete;

    // Starts body(stop) on a thread pinned to `cpus` (empty: where the
    // kernel puts it; a pin refused is said on stderr, naming `what`).
    void start(std::vector<int> cpus, std::string what, Body body, OnError on_error)
    {
        thread_ = start_pinned(std::move(cpus), std::move(what), [this, body = std::move(body), on_error = std::move(on_error)] {
            try {
                body(stop_);
            } catch (...) {
                on_error(std::current_exception());
            }
        });
    }
    // Raises the stop flag and waits for the body to return.
    void join()
    {
        stop_ = true;
        if (thread_.joinable()) thread_.join();
    }

private:
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

template <class T>
class Worker {
public:
    // handle(batch, dropped): the items taken, in order, and how many the
    // queue dropped since the previous batch (Full::replace).
    using Handler = std::function<void(std::vector<T> &batch, int64_t dropped)>;
    struct Options {
        std::size_t capacity = 0;
        Full full = Full::block;
        int period_us = 0;
        std::size_t max_batch = 0;   // 0: all that are queued
    };

    Worker(Options o, Handler handle) : q_({o.capacity, o.full, o.period_us}), o_(o), handle_(std::move(handle)) {}
    ~Worker() { stop(Stop::discard); }
    Worker(const Worker &) = delete;
    Worker &operator=(const Worker &) = delete;

    void start(std::vector<int> cpus, std::string what, std::function<void()> on_start = {})
    {
        thread_.start(
            std::move(cpus), std::move(what), [this, on_start = std::move(on_start)](const std::atomic<bool> &) { run(on_start); },
            [this](std::exception_ptr e) { q_.fail(std::move(e), Stop::discard); });
    }
    // Returns once on_start has run; rethrows its error (or the handler's).
    void wait_started()
    {
        std::unique_lock<std::mutex> l(m_);
        started_cv_.wait(l, [&] { return started_; });
        l.unlock();
        q_.check();
    }
    void post(T item) { q_.push(std::move(item)); }
    void flush() { q_.flush(); }
    void stop(Stop queued)
    {
        q_.close(queued);
        thread_.join();
    }
    QueueCounts counts() const { return q_.counts(); }

private:
    void run(const std::function<void()> &on_start)
    {
        try {
            if (on_start) on_start();
        } catch (...) {
            q_.fail(std::current_exception(), Stop::discard);
        }
        {
            std::lock_guard<std::mutex> l(m_);
            started_ = true;
        }
        started_cv_.notify_all();
        std::vector<T> batch;
        while (true) {
            const auto took = q_.take(&batch, o_.max_batch, o_.period_us > 0 ? o_.period_us : -1);
            if (took.n > 0) {
                const double t0 = thread_cpu_seconds();
                handle_(batch, took.dropped);   // an exception: the thread's on_error
                q_.done(took.n, thread_cpu_seconds() - t0);
                batch.clear();
            }
            if (took.end) return;
        }
    }

    Queue<T> q_;
    const Options o_;
    const Handler handle_;
    std::mutex m_;
    std::condition_variable started_cv_;
    bool started_ = false;
    WorkerThread thread_;
};

}  // namespace afm
