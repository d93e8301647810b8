// The run's record of its bus: every message on every channel, in the order
// this process receives them, written to an LCM event log (the format of
// lcm-logger, read by lcm-logplayer, afmlog.py and replay).
//
// Why not lcm-logger (measured by ./afm bench bus, README "The bus's
// latency model"): lcm-logger passes each message through three threads and
// flushes its file only when a message arrives a flush interval after the
// last flush, so a simulator that paces itself on the file stops and goes;
// and its subscription holds 30 messages, beyond which it drops. Here the
// launcher, which receives every datagram of the bus anyway, records them
// itself: a subscription of kQueueCapacity messages, one write per message
// into the stdio buffer, and a flush to the kernel whenever kFlushBytes have
// gathered or the bus has gone quiet (drain()), so the file lags what
// arrived by at most kFlushBytes (about two blocks), or not at all when the
// simulator waits for it.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <string>

#include "lcmlog.hpp"

namespace afm {

class BusRecorder {
public:
    // Subscribes to every channel of `lc` and creates `path` (replacing it).
    // Throws LogError naming the file when it cannot be created.
    BusRecorder(lcm::LCM &lc, const std::string &path);
    ~BusRecorder();
    BusRecorder(const BusRecorder &) = delete;
    BusRecorder &operator=(const BusRecorder &) = delete;

    // Bytes written to the stdio buffer before it goes to the kernel.
    static constexpr int64_t kFlushBytes = 4096;

    // Handles every message already received (up to `max` of them), then
    // flushes the file if the bus is quiet (the caller waited for a message
    // and none came) or kFlushBytes have gathered. Returns the number
    // handled. Throws LogError on a write that failed (a full disk), naming
    // the file and the reason.
    int drain(bool bus_quiet, int max = 10000);
    int64_t events() const { return log_.events(); }
    bool unflushed() const { return log_.bytes() > flushed_; }

private:
    void on(const lcm::ReceiveBuffer *rb, const std::string &channel);
    lcm::LCM &lc_;
    LogWriter log_;
    lcm::Subscription *sub_ = nullptr;
    int64_t flushed_ = 0;   // the writer's bytes() at the last flush
    std::string error_;   // a write that failed inside LCM's dispatch, thrown by drain()
};

}  // namespace afm
