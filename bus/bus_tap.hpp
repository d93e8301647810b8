// The bus, received without liblcm's receive thread: how every process of
// a run takes messages off the bus. The launcher's tap records every
// message (bus_recorder.hpp); each other process's inbox (inbox.hpp) holds
// a tap filtered to its own channels (accept_only).
//
// Why (docs/bus.md "The latency model"; ./afm bench bus measures it):
// liblcm's udpm provider receives each datagram on a thread of its own,
// which wakes for every datagram and hands it to the caller's thread
// through a pipe: two wake-ups and a pipe per message, where a socket read
// by the caller's own thread needs one. On a lockstep hop that is about
// half its latency; the launcher, which hears all of a block's eight
// datagrams, spent about as much CPU on the wake-ups as the rest of the
// run's observers together. The tap is one socket read by the caller's own
// thread, either a message at a time (next(), as liblcm's handleTimeout
// hands them) or in batches (drain(): the launcher and the renderer sleep
// between batches and then take every datagram already queued, with one
// recvmmsg call per 64 of them).
//
// What it receives is what liblcm would deliver to a subscription to ".*":
//   - a short message (magic "LC02"): its channel and payload at once;
//   - a fragmented message (magic "LC03"): its fragments gathered per
//     sender and message number, fragment 0 first (it names the channel),
//     as liblcm gathers them; delivered once every fragment has come. A
//     fragment repeated is taken once; a new message from the same sender
//     abandons the one it had not finished (counted in abandoned()). The
//     fragments are kept as they come, and the message is put together only
//     when the last one has: what a message holds is what arrived, never the
//     size its fragment 0 merely claims (a 40-byte datagram may claim 16 MiB).
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
#include <set>
#include <string>
#include <vector>

#include "bus_key.hpp"

namespace afm {

// What the tap does with each datagram it reads, without the socket: the
// rules above, per sender (its IPv4 address and port). BusTap owns one; the
// bus fuzzer (fuzz/fuzz_bus.cpp) feeds one datagrams directly.
class BusGather {
public:
    // A whole message: channel, payload, the kernel's receive time (us).
    using Sink = std::function<void(const std::string &channel, const unsigned char *data, std::size_t size, int64_t recv_utime)>;
    using Admit = std::function<bool(const std::string &channel, uint16_t source_port)>;

    // Only messages on `channels` are handed on (BusTap adds the kernel's filter).
    void accept_only(const std::set<std::string> &channels);
    const std::set<std::string> &accepted() const { return accept_; }
    void admit_only(Admit admit) { admit_ = std::move(admit); }
    // A whole message, proven, is handed on only when vet(channel, bytes,
    // size, source port) says so (Senders::vet: a heartbeat's name must be
    // that of the program behind its source port).
    using Vet = std::function<bool(const std::string &channel, const unsigned char *data, std::size_t size, uint16_t source_port)>;
    void vet_with(Vet vet) { vet_ = std::move(vet); }
    // One datagram of n bytes from (addr, port), host byte order; returns
    // the messages it completed and handed to `sink` (0 or 1).
    int take(const unsigned char *d, std::size_t n, uint32_t addr, uint16_t port, int64_t utime, const Sink &sink);
    int64_t dropped() const { return dropped_; }
    void drop() { ++dropped_; }   // a datagram the socket cut short, counted with the rest
    int64_t abandoned() const { return abandoned_; }
    // The run's proof (bus_key.hpp): with a key, a whole message from an
    // admitted sender must carry its trailer, signed with that key, with a
    // sequence not taken before from that sender on that channel; the
    // trailer is stripped before the message is handed on, and a message
    // without one is refused and counted (unproven()). enforce false
    // (AFM_ADMIT_ANY_SENDER=1, for the tests that reach the inboxes' own
    // checks): a trailer that verifies is stripped, and anything else is
    // handed on as it came. No key: every message as it came.
    void prove_with(const BusKey *key, bool enforce)
    {
        key_ = key;
        enforce_ = enforce;
    }
    const ProofCounts &unproven() const { return unproven_; }
    std::size_t held_bytes() const;
    // Unfinished messages held now (at most kMaxPartial).
    std::size_t partial() const { return partial_.size(); }

    static constexpr std::size_t kMaxMessageBytes = 16u << 20;
    static constexpr std::size_t kMaxPartial = 16;

private:
    struct Partial {
        uint32_t seqno = 0;
        std::string channel;
        std::size_t size = 0;             // the whole message's, bytes (as fragment 0 claims it)
        bool skip = false;                // not on an accepted channel: its fragments are not kept
        std::vector<std::pair<std::size_t, std::vector<unsigned char>>> frags;   // (offset, bytes) as they came
        std::size_t held = 0;             // bytes in frags
        std::vector<bool> got;   // per fragment
        uint32_t missing = 0;
    };
    // Whether the n bytes at d on `channel` from `port` carry their proof;
    // true: hand them on, *n less the trailer.
    bool proven(const std::string &channel, const unsigned char *d, std::size_t *n, uint16_t port);
    // A whole message from an admitted sender: proven, vetted, then to the
    // sink (1), or refused (0).
    int hand_on(const std::string &channel, const unsigned char *d, std::size_t n, uint16_t port, int64_t utime, const Sink &sink);
    std::map<uint64_t, Partial> partial_;   // by sender (address, port)
    const BusKey *key_ = nullptr;
    bool enforce_ = true;
    ReplayWindow window_;
    ProofCounts unproven_;
    int64_t dropped_ = 0, abandoned_ = 0;
    bool filtered_ = false;
    std::set<std::string> accept_;
    Admit admit_;
    Vet vet_;
};

class BusTap {
public:
    // A whole message: channel, payload, the kernel's receive time (us).
    using Sink = BusGather::Sink;

    // Joins the group of `url` (udpm://GROUP:PORT?...; recv_buf_size is
    // honoured) on a socket of its own. Throws std::runtime_error naming the
    // URL and the reason when it cannot.
    explicit BusTap(const std::string &url);
    ~BusTap();
    BusTap(const BusTap &) = delete;
    BusTap &operator=(const BusTap &) = delete;

    // Hands on only messages on `channels`: the kernel drops the other
    // short messages before they reach the socket (bus_filter.hpp's program,
    // attached to it); a message gathered from fragments on another channel
    // is dropped here, uncounted (it is not garbage, only not this
    // receiver's). Throws std::runtime_error when the kernel refuses the
    // filter.
    void accept_only(const std::set<std::string> &channels);
    // The channels accept_only() last named (empty before it).
    const std::set<std::string> &accepted() const { return gather_.accepted(); }

    // Who may send (issue 35): every whole message on an accepted channel is
    // handed on only when admit(channel, source port) says so; the rest are
    // the admitter's to count (Senders::admit). A fragmented message is
    // judged at its fragment 0: a foreign one is not gathered at all (its
    // later fragments, without their fragment 0, are dropped). None set:
    // every sender.
    using Admit = BusGather::Admit;
    void admit_only(Admit admit) { gather_.admit_only(std::move(admit)); }
    using Vet = BusGather::Vet;
    void vet_with(Vet vet) { gather_.vet_with(std::move(vet)); }

    // Waits up to timeout_ms for a datagram; true when one is queued.
    bool wait(int timeout_ms);
    // Hands the next whole message to `sink`, waiting up to timeout_ms
    // (0: only what is already queued) for it to come: one message at
    // most, as liblcm's handleTimeout. Returns 1 when it handed one, 0 when
    // none came in time.
    int next(const Sink &sink, int timeout_ms);
    // Hands every message already received (up to `max` datagrams read) to
    // `sink`, in the order they arrived; returns the messages handed.
    int drain(const Sink &sink, int max = 100000);

    // The socket's receive buffer as the kernel granted it (SO_RCVBUF, in
    // its accounting of a datagram's memory); 0 if it cannot say.
    int64_t receive_buffer_bytes() const;

    // Messages refused for want of the run's proof (BusGather::prove_with:
    // the tap proves with the run's key, run_key(), unless every sender is
    // admitted, Senders::admit_any()).
    const ProofCounts &unproven() const { return gather_.unproven(); }
    // Datagrams that are not part of any message LCM would deliver.
    int64_t dropped() const { return gather_.dropped(); }
    // Fragmented messages left unfinished (a fragment lost).
    int64_t abandoned() const { return gather_.abandoned(); }
    // Bytes held now in unfinished fragmented messages: what their
    // fragments carried, at most kMaxPartial messages of kMaxMessageBytes.
    std::size_t held_bytes() const { return gather_.held_bytes(); }

    // The largest message gathered from fragments: the largest the run's log
    // holds (LogReader::kMaxDataBytes, 16 MiB; the bench's largest, a scan
    // line of 8192 points, is 200 kB). liblcm's own limit is larger.
    static constexpr std::size_t kMaxMessageBytes = BusGather::kMaxMessageBytes;
    // Fragmented messages held unfinished at once, over every sender (as
    // liblcm's store, beyond it one is abandoned).
    static constexpr std::size_t kMaxPartial = BusGather::kMaxPartial;

private:
    // Reads up to `max` datagrams already queued (*read: how many), handing
    // each message they complete to `sink`; returns the messages handed.
    // wait: the first read waits for a datagram, up to the socket's
    // SO_RCVTIMEO (set_timeout(); never set: without end).
    int receive(const Sink &sink, int max, int *read, bool wait = false);
    // Sets the socket's SO_RCVTIMEO to `ms` (> 0) unless it is set to it
    // already; false when the kernel refuses it.
    bool set_timeout(int ms);

    int fd_ = -1;
    BusGather gather_;
    std::vector<unsigned char> bufs_, ctl_;   // receive()'s datagrams and their control data
    int timeout_ms_ = 0;               // the socket's SO_RCVTIMEO, ms (0: none set; next() sets it before a read waits)
};

}  // namespace afm
