// The whole bus, received without liblcm's receive thread: the launcher's
// tap, from which it records every message (bus_recorder.hpp) and reads the
// processes' heartbeats.
//
// Why (README "The bus's latency model"; ./afm bench bus measures it):
// liblcm's udpm provider receives each datagram on a thread of its own,
// which wakes for every datagram and hands it to the caller through a pipe.
// The launcher hears all of a block's eight datagrams; a wake-up each cost
// it about as much CPU as the rest of the run's observers together, on the
// CPU it shares with the renderer. The tap is one socket read by the
// caller's own thread: it sleeps between batches (the launcher's 0.5 ms),
// and then takes every datagram already queued with one recvmmsg call per
// 64 of them.
//
// What it receives is what liblcm would deliver to a subscription to ".*":
//   - a short message (magic "LC02"): its channel and payload at once;
//   - a fragmented message (magic "LC03"): its fragments gathered per
//     sender and message number, fragment 0 first (it names the channel),
//     as liblcm gathers them; delivered once every fragment has come. A
//     fragment repeated is taken once; a new message from the same sender
//     abandons the one it had not finished (counted in abandoned()).
//   - anything else (garbage, a name over 63 bytes, a fragment without
//     its fragment 0, a fragment past its message's size, a message over
//     kMaxMessageBytes or larger than its fragments can carry) is dropped
//     and counted (dropped()), as liblcm drops it; a fragment that does
//     not fit abandons its message.
// The header layout is bus_filter.hpp's (the bench's one reader of LCM's
// datagrams). Publishing stays with liblcm, so what lcm-spy, lcm-logger and
// every other process see is unchanged.
//
// Each message carries the kernel's receive time (SO_TIMESTAMP), in
// microseconds since the epoch, as liblcm's receive_utime would.
#pragma once

#include <netinet/in.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace afm {

class BusTap {
public:
    // A whole message: channel, payload, the kernel's receive time (us).
    using Sink = std::function<void(const std::string &channel, const unsigned char *data, std::size_t size, int64_t recv_utime)>;

    // Joins the group of `url` (udpm://GROUP:PORT?...; recv_buf_size is
    // honoured) on a socket of its own. Throws std::runtime_error naming the
    // URL and the reason when it cannot.
    explicit BusTap(const std::string &url);
    ~BusTap();
    BusTap(const BusTap &) = delete;
    BusTap &operator=(const BusTap &) = delete;

    // Waits up to timeout_ms for a datagram; true when one is queued.
    bool wait(int timeout_ms);
    // Hands every message already received (up to `max` datagrams read) to
    // `sink`, in the order they arrived; returns the messages handed.
    int drain(const Sink &sink, int max = 100000);

    // Datagrams that are not part of any message LCM would deliver.
    int64_t dropped() const { return dropped_; }
    // Fragmented messages left unfinished (a fragment lost).
    int64_t abandoned() const { return abandoned_; }

    // The largest message gathered from fragments: the largest the run's log
    // holds (LogReader::kMaxDataBytes, 16 MiB; the bench's largest, a scan
    // line of 8192 points, is 200 kB). liblcm's own limit is larger.
    static constexpr std::size_t kMaxMessageBytes = 16u << 20;
    // Fragmented messages held unfinished at once, over every sender (as
    // liblcm's store, beyond it one is abandoned).
    static constexpr std::size_t kMaxPartial = 16;

private:
    struct Partial {
        uint32_t seqno = 0;
        std::string channel;
        std::vector<unsigned char> data;
        std::vector<bool> got;   // per fragment
        uint32_t missing = 0;
    };
    int take(const unsigned char *d, std::size_t n, const sockaddr_in &from, int64_t utime, const Sink &sink);

    int fd_ = -1;
    std::map<uint64_t, Partial> partial_;   // by sender (address, port)
    int64_t dropped_ = 0, abandoned_ = 0;
};

}  // namespace afm
