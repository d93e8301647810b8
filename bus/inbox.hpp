// The one way a process of the bench takes a message off the bus: decode
// (LCM's generated decoder, guarded: lcmtypes/afm_lcm_guard.h), check, count
// what is refused, and only then hand it to the process. A process never
// sees a truncated message, another type's bytes, an array length past the
// datagram, or a NaN; its handler refuses what its own state cannot use (a
// block from the past or too far ahead) by returning the reason.
//
// Reasons (run.json: each process's "rejected", by reason and by channel):
//   truncated     shorter than its fields (or than a fingerprint)
//   fingerprint   a fingerprint no type of the bus has (garbage)
//   wrong_type    the fingerprint of another type of the bus
//   array_length  an array or string length field past the bytes left, or below 0
//   non_finite    a NaN or an infinity in a double field
//   seq_past      a sequence number the process has already passed
//   seq_future    a sequence number beyond what the protocol can have sent yet
//   out_of_range  a field outside what the protocol allows (a size, an index)
// Datagrams that are not LCM packets at all never reach a process: the
// inbox's receiver drops them before any subscription, as liblcm would
// (counted apart: bus_dropped()).
//
// How messages come (docs/bus.md, "The latency model"): on a udpm bus the
// inbox receives on a socket of its own (bus_tap.hpp) read by the caller's
// thread in handle(), with the kernel's filter letting through only its
// channels (bus_filter.hpp), not through liblcm's receive thread; the
// process publishes through liblcm as before. On another provider (memq://,
// file://) it subscribes through liblcm.
//
// Two ways to read the socket:
//   - on call (batch_us 0; the lockstep's processes): handle() reads it, so
//     a message wakes the process at once, and nothing else does. Messages
//     wait in the socket while the process is busy elsewhere: fine for a
//     process the lockstep waits for, as long as it takes all that came
//     whenever it looks (handle(0) until it says 0).
//   - batched (batch_us > 0; the renderer, an observer the simulator may
//     run 2 frames ahead of): a thread of the inbox's own waits for the
//     bus, sleeps batch_us, takes everything queued in one go (recvmmsg)
//     into a queue in memory, and handle() takes from that queue; while
//     batches keep finding messages it goes on by its own clock (sleep,
//     take) without waiting on the socket, so that no datagram wakes it.
//     One wake-up per batch, not per datagram; and a main thread busy for
//     longer than the socket's buffer lasts (a frame's PNG, a fidelity
//     check) loses nothing, as with liblcm's own receive thread.
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace afm {

class BusTap;
class Senders;

enum class Reject : int {
    none = 0,
    truncated,
    fingerprint,
    wrong_type,
    array_length,
    non_finite,
    seq_past,
    seq_future,
    out_of_range,
    count_
};

const char *reject_name(Reject r);

// The bus type whose fingerprint `hash` is ("" if none).
std::string bus_type_of_hash(int64_t hash);
// The type the channel carries (lcmtypes/channels.yaml; "" for an unknown channel).
std::string channel_type(const std::string &channel);

// Why `decode` failed: from its return code and the datagram's fingerprint.
Reject classify_decode_failure(int code, const void *data, std::size_t size, int64_t expected_hash);

// Decodes one datagram as M. Returns Reject::none and fills *msg, or the reason.
template <class M>
Reject decode_checked(const void *data, std::size_t size, M *msg)
{
    if (size > static_cast<std::size_t>(INT32_MAX)) return Reject::out_of_range;
    const int code = msg->decode(data, 0, static_cast<int>(size));
    if (code >= 0) return Reject::none;
    return classify_decode_failure(code, data, size, M::getHash());
}

// Counts of what a process refused.
class Rejections {
public:
    void count(Reject r, const std::string &channel);
    int64_t total() const { return total_; }
    int64_t of(Reject r) const { return by_reason_[static_cast<std::size_t>(r)]; }
    // {"total": N, "by_reason": {reason: n, ...}, "by_channel": {channel: n, ...}}
    nlohmann::json to_json() const;

private:
    int64_t total_ = 0;
    std::array<int64_t, static_cast<std::size_t>(Reject::count_)> by_reason_{};
    std::map<std::string, int64_t> by_channel_;
};

// A process's subscriptions. on<M>(channel, handler): handler(const M &)
// returns Reject::none when it took the message, or why it did not.
class Inbox {
public:
    // lc: the bus the process opened with open_bus() (the URL bus_url()
    // names), or nullptr for an inbox fed by deliver() alone (replay, the
    // fuzz harnesses). batch_us: 0 to read the socket in handle(), or the
    // receive thread's sleep between batches (above). Throws
    // std::runtime_error when a udpm bus's socket cannot be opened.
    explicit Inbox(lcm::LCM *lc, int batch_us = 0);
    ~Inbox();
    Inbox(const Inbox &) = delete;
    Inbox &operator=(const Inbox &) = delete;

    // Throws std::logic_error when the channel is not declared in
    // channels.yaml with type M, or (batched) when handle() has already
    // started the receive thread (programming errors, caught at start).
    template <class M>
    void on(const std::string &channel, std::function<Reject(const M &)> handler)
    {
        check_channel(channel, M::getTypeName());
        auto sub = std::make_unique<Sub>();
        sub->inbox = this;
        sub->channel = channel;
        sub->take = [handler = std::move(handler)](const void *data, std::size_t size) {
            M msg;
            const Reject r = decode_checked(data, size, &msg);
            return r != Reject::none ? r : handler(msg);
        };
        subscribe(*sub);
        subs_.push_back(std::move(sub));
    }

    // The channels subscribed to, in the order on() named them.
    std::vector<std::string> channels() const
    {
        std::vector<std::string> c;
        for (const auto &s : subs_) c.push_back(s->channel);
        return c;
    }

    const Rejections &rejected() const { return rejected_; }
    // A refusal found outside a handler (counted with the others).
    void count(Reject r, const std::string &channel) { rejected_.count(r, channel); }

    // Hands one raw datagram to the subscription of `channel` as if it had
    // arrived (replay and the fuzz harnesses); returns what the inbox decided.
    Reject deliver(const std::string &channel, const void *data, std::size_t size);

    // Takes the next message off the bus into its handler, waiting up to
    // timeout_ms (0: only what has come) for one: one message at most, as
    // liblcm's handleTimeout. Returns 1 when it took one, 0 when none came,
    // -1 on a bus error (liblcm's). An inbox without a bus returns 0.
    int handle(int timeout_ms);
    // Datagrams the receiver dropped before any subscription: not LCM,
    // names liblcm refuses, fragments of a message never whole.
    int64_t bus_dropped() const;
    // Fragmented messages the receiver left unfinished (a fragment lost, or
    // a fragment 0 whose message never came: bus_tap.hpp).
    int64_t bus_abandoned() const;
    // What the inbox refused, for a process's report: rejected().to_json()
    // with the receiver's bus_dropped and bus_abandoned beside it, and the
    // datagrams of senders that do not publish their channel (senders.hpp):
    // foreign_datagrams, and foreign {channel: {sender: count}}.
    nlohmann::json report() const;

    // The batched receive thread's state (inbox.cpp).
    struct Batcher;
private:
    struct Sub {
        Inbox *inbox = nullptr;
        std::string channel;
        std::function<Reject(const void *, std::size_t)> take;
        void on_raw(const lcm::ReceiveBuffer *rbuf, const std::string &channel);
    };
    void check_channel(const std::string &channel, const char *type_name) const;
    void subscribe(Sub &sub);

    lcm::LCM *lc_;
    std::unique_ptr<BusTap> tap_;     // a udpm bus's receiver (nullptr: liblcm's, or none)
    std::unique_ptr<Senders> senders_;   // who may send what (the tap's admitter)
    int batch_us_ = 0;
    std::unique_ptr<Batcher> batcher_;   // started by the first handle() when batch_us_ > 0
    std::vector<std::unique_ptr<Sub>> subs_;
    Rejections rejected_;
};

}  // namespace afm
