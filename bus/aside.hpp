// Publishing aside: the messages no process of the lockstep waits for (the
// card's FW_STATE unless the planner reads it;
// the simulator's SIM_TRUTH), published from a thread of the process's own,
// in batches, instead of by the lockstep's thread on the lockstep's CPU.
// The thread may run on every CPU of the run (the launcher's placement:
// common/placement.hpp): the kernel puts its sends where there is room.
// Pinned to the observers' CPU, the run's busiest (the renderer, the
// record), a block cost more (docs/bus.md, "Publishing aside").
//
// Why (docs/bus.md "The latency model"; ./afm bench bus measures it): a
// datagram costs its sender's CPU its delivery to every socket on the bus;
// two of a block's six datagrams are
// for the observers (the launcher's record, the renderer), and on the one
// CPU of the lockstep they cost as much as its hops. The observers do not
// need them at once: the renderer draws a frame from them a window of
// frames behind, the launcher records them.
//
// What a receiver sees: each channel published aside in the order it was
// posted, a batch at most kBatchUs (0.5 ms) after it was posted; relative to
// the channels published at once, later (a log holds FW_STATE n after
// AFM_ANALOG n + k). Nothing is dropped: post() waits while kMaxQueued
// messages wait (the lockstep slows down to the observers' pace, as it
// does for the record's window), and flush() returns once everything
// posted is published (before a process says "done", so that the record
// holds every block).
//
// A channel published aside is published aside for the whole run (the
// order within a channel is the bus's contract); which ones are is
// lockstep_reads(): the one rule, which every process of the lockstep checks
// its subscriptions against when it starts (check_lockstep_reads).
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "scene.hpp"
#include "worker.hpp"

namespace afm {

// True when a process of the lockstep (sim_afm, fw_node, operator) may wait
// for a message on `channel` in scene `s`: the lockstep's own hops
// (AFM_ANALOG, AFM_CMD, HAPTIC_FORCE, HAPTIC_POSE), a scan's (AFM_SCAN_REQ,
// AFM_SCAN_LINE), a fix (HOST_OBJECT_FIX), a frame (RENDER_FRAME), a
// heartbeat; and FW_STATE when the scene's operator plans
// (op.plan.enabled: the planner reads the card's objects every block) or
// takes the page's hand (op.mode browser: a planner stroke the page asks
// for reads them the same way). A
// channel it does not name is published aside (Aside) by a process of the
// lockstep.
bool lockstep_reads(const Scene &s, const std::string &channel);
// Throws std::logic_error naming the process and the channel when a
// process of the lockstep subscribes to a channel lockstep_reads() does not
// name (its messages would come a batch late): a programming error, caught
// when the process starts.
void check_lockstep_reads(const Scene &s, const std::vector<std::string> &subscribed, const std::string &process);

class Aside {
public:
    // Batches kBatchUs apart; a poster waits beyond kMaxQueued messages
    // (about 250 blocks of the card's three: 2 MB on a 100-particle scene).
    static constexpr int kBatchUs = 500;
    static constexpr std::size_t kMaxQueued = 1024;

    // Opens a bus of its own (open_bus(): its own socket, so that its
    // batches never hold liblcm's send lock against the lockstep's thread)
    // and starts the thread, pinned to `cpus` (empty: where the kernel puts
    // it; a pin refused is reported on stderr and the thread runs
    // unpinned). Throws std::runtime_error when the bus cannot be opened.
    explicit Aside(std::vector<int> cpus, int batch_us = kBatchUs, std::size_t max_queued = kMaxQueued);
    // Publishes what is queued, then stops the thread.
    ~Aside();
    Aside(const Aside &) = delete;
    Aside &operator=(const Aside &) = delete;

    // Queues one encoded message for the thread to publish.
    void post(const std::string &channel, const void *data, std::size_t size);
    template <class M>
    void post(const std::string &channel, const M &m)
    {
        std::vector<uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
        m.encode(buf.data(), 0, static_cast<int>(buf.size()));
        post(channel, buf.data(), buf.size());
    }
    // Returns once every message posted before the call is published.
    void flush();

    // Published so far; publish calls liblcm refused (counted, not retried:
    // the bus's loss, as a refused send on the lockstep's own thread);
    // posts that waited for the queue to drain.
    int64_t published() const;
    int64_t failed() const;
    int64_t waits() const;
    // The three, as the processes' reports hold them:
    // {"published", "failed", "waits"}.
    nlohmann::json report() const;

private:
    struct Msg {
        std::string channel;
        std::vector<uint8_t> data;
    };
    void publish(std::vector<Msg> &batch);

    std::unique_ptr<lcm::LCM> lc_;
    std::atomic<int64_t> published_{0}, failed_{0};
    Worker<Msg> worker_;   // the thread (common/worker.hpp): batch_us apart, max_queued, blocking
};

}  // namespace afm
