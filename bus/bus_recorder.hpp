// The run's record of its bus: every message on every channel, in the order
// this process receives them, written to an LCM event log (the format of
// lcm-logger, read by lcm-logplayer, analysis/afmlog.py and replay).
//
// Why not lcm-logger (measured by ./afm bench bus, docs/bus.md "The
// latency model"): lcm-logger passes each message through three threads and
// flushes its file only when a message arrives a flush interval after the
// last flush, so a simulator that paces itself on the file stops and goes;
// and its subscription holds 30 messages, beyond which it drops. Here the
// launcher, which receives every datagram of the bus anyway (bus_tap.hpp),
// records them itself: one write per message into the stdio buffer, and a
// flush to the kernel whenever kFlushBytes have gathered or the bus has
// gone quiet (settle()), so the file lags what arrived by at most
// kFlushBytes (about two blocks), or not at all when the simulator waits
// for it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "lcmlog.hpp"

namespace afm {

// run.json "channels": messages per channel of a record, each channel's
// name as afm::printable shows it (text.hpp). The record keeps a name as it
// came (LCM's format: any bytes but NUL); run.json holds only valid UTF-8,
// and nlohmann's dump throws on anything else (one datagram on a channel
// named "\xffX" aborted the launcher at the end of its run, exit 134, no
// run.json). Names that differ stay apart (the escaping is reversible).
nlohmann::json channels_json(const std::map<std::string, int64_t> &counts);

class BusRecorder {
public:
    // Creates `path` (replacing it). Throws LogError naming the file when it
    // cannot be created.
    explicit BusRecorder(const std::string &path);
    BusRecorder(const BusRecorder &) = delete;
    BusRecorder &operator=(const BusRecorder &) = delete;

    // Bytes written to the stdio buffer before it goes to the kernel.
    static constexpr int64_t kFlushBytes = 4096;

    // Records one message (BusTap::Sink's arguments). Throws LogError on a
    // write that failed (a full disk), naming the file and the reason.
    void take(const std::string &channel, const unsigned char *data, std::size_t size, int64_t recv_utime);
    // Flushes the file if the bus is quiet (the caller waited for a message
    // and none came) or kFlushBytes have gathered. Throws LogError as take().
    void settle(bool bus_quiet);
    int64_t events() const { return log_.events(); }
    bool unflushed() const { return log_.bytes() > flushed_; }

private:
    LogWriter log_;
    int64_t flushed_ = 0;   // the writer's bytes() at the last flush
};

}  // namespace afm
