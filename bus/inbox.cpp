#include "inbox.hpp"

#include "bus_tap.hpp"
#include "senders.hpp"
#include "text.hpp"
#include "worker.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <set>
#include <stdexcept>
#include <thread>

#include "afm_channels.h"
#include "bus.hpp"
#include "afm/analog_block_t.hpp"
#include "afm/fw_state_t.hpp"
#include "afm/haptic_force_t.hpp"
#include "afm/haptic_pose_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/object_fix_t.hpp"
#include "afm/objects_t.hpp"
#include "afm/render_frame_t.hpp"
#include "afm/scan_line_t.hpp"
#include "afm/scan_req_t.hpp"
#include "afm/sim_truth_t.hpp"
#include "afm/tip_cmd_t.hpp"
#include "afm/view_frame_t.hpp"

namespace afm {

namespace {

struct ChannelType {
    const char *channel;
    const char *type;
    int64_t hash;
};

#define AFM_ROW(CH, T) {#CH, #T, static_cast<int64_t>(T::getHash())},
const ChannelType kChannels[] = {AFM_CHANNEL_TYPES(AFM_ROW)};
#undef AFM_ROW

}  // namespace

const char *reject_name(Reject r)
{
    switch (r) {
    case Reject::none: return "none";
    case Reject::truncated: return "truncated";
    case Reject::fingerprint: return "fingerprint";
    case Reject::wrong_type: return "wrong_type";
    case Reject::array_length: return "array_length";
    case Reject::non_finite: return "non_finite";
    case Reject::seq_past: return "seq_past";
    case Reject::seq_future: return "seq_future";
    case Reject::out_of_range: return "out_of_range";
    case Reject::count_: break;
    }
    return "unknown";
}

std::string bus_type_of_hash(int64_t hash)
{
    for (const auto &c : kChannels)
        if (c.hash == hash) return c.type;
    return "";
}

std::string channel_type(const std::string &channel)
{
    for (const auto &c : kChannels)
        if (channel == c.channel) return c.type;
    return "";
}

Reject classify_decode_failure(int code, const void *data, std::size_t size, int64_t expected_hash)
{
    if (code == AFM_LCM_E_LENGTH) return Reject::array_length;
    if (code == AFM_LCM_E_NONFINITE) return Reject::non_finite;
    int64_t hash = 0;
    // The fingerprint: LCM's own decoder for its first 8 bytes.
    if (size < sizeof hash || __int64_t_decode_array(data, 0, static_cast<int>(size), &hash, 1) < 0) return Reject::truncated;
    if (hash == expected_hash) return Reject::truncated;
    return bus_type_of_hash(hash).empty() ? Reject::fingerprint : Reject::wrong_type;
}

void Rejections::count(Reject r, const std::string &channel)
{
    if (r == Reject::none || r == Reject::count_) return;
    ++total_;
    ++by_reason_[static_cast<std::size_t>(r)];
    // Channels are the bus's own (a subscription's name), so the map stays
    // small; escaped all the same (text.hpp): deliver() takes any name.
    ++by_channel_[printable(channel)];
}

nlohmann::json Rejections::to_json() const
{
    nlohmann::json j = {{"total", total_}, {"by_reason", nlohmann::json::object()}, {"by_channel", nlohmann::json::object()}};
    for (int i = 1; i < static_cast<int>(Reject::count_); ++i)
        j["by_reason"][reject_name(static_cast<Reject>(i))] = by_reason_[static_cast<std::size_t>(i)];
    for (const auto &kv : by_channel_) j["by_channel"][kv.first] = kv.second;
    return j;
}

void Inbox::check_channel(const std::string &channel, const char *type_name) const
{
    const std::string t = channel_type(channel);
    if (t.empty()) throw std::logic_error("Inbox: channel " + channel + " is not in lcmtypes/channels.yaml");
    if (t != type_name) throw std::logic_error("Inbox: channel " + channel + " carries " + t + ", not " + type_name);
}

// The batched receiver: a thread of the inbox's own (common/worker.hpp)
// fills an unbounded queue, a batch at a time, that handle() empties.
struct Inbox::Batcher {
    struct Msg {
        std::string channel;
        std::vector<unsigned char> data;
    };
    Queue<Msg> queue{{}};
    std::atomic<int64_t> dropped{0};
    std::atomic<int64_t> abandoned{0};
    WorkerThread thread;   // the only reader of the tap once started; its error ends handle()

    void start(BusTap &tap, int batch_us)
    {
        thread.start({}, "inbox: the receive thread", [this, &tap, batch_us](const std::atomic<bool> &stop) { run(tap, batch_us, stop); },
                     [this](std::exception_ptr e) { queue.fail(std::move(e), Stop::drain); });
    }

    void run(BusTap &tap, int batch_us, const std::atomic<bool> &stop)
    {
        std::vector<Msg> batch;
        const BusTap::Sink take = [&](const std::string &channel, const unsigned char *d, std::size_t n, int64_t) {
            batch.push_back({channel, std::vector<unsigned char>(d, d + n)});
        };
        // While the bus is busy the thread wakes by its own clock and takes
        // what came meanwhile: no datagram wakes it (a wake-up sent from the
        // lockstep's CPU to this one costs the sender). A batch that finds
        // nothing sends it back to waiting on the socket.
        bool busy = false;
        while (!stop) {
            if (!busy && !tap.wait(50)) continue;
            std::this_thread::sleep_for(std::chrono::microseconds(batch_us));
            busy = tap.drain(take) > 0;
            dropped = tap.dropped();
            abandoned = tap.abandoned();
            if (!batch.empty()) queue.push_all(batch);
        }
    }
};

Inbox::Inbox(lcm::LCM *lc, int batch_us) : lc_(lc), batch_us_(batch_us)
{
    const std::string url = bus_url();
    if (lc_ && url.rfind("udpm://", 0) == 0) {
        tap_ = std::make_unique<BusTap>(url);
        tap_->accept_only({});   // nothing until a subscription
        senders_ = std::make_unique<Senders>(Senders::Scope::siblings);
        Senders *s = senders_.get();
        tap_->admit_only([s](const std::string &channel, uint16_t port) { return s->admit(channel, port); });
        tap_->vet_with([s](const std::string &ch, const unsigned char *d, std::size_t n, uint16_t port) { return s->vet(ch, d, n, port); });
    }
}

Inbox::~Inbox()
{
    if (batcher_) batcher_->thread.join();   // within the thread's 50 ms wait
}

void Inbox::subscribe(Sub &sub)
{
    if (tap_) {
        if (batcher_) throw std::logic_error("Inbox: " + sub.channel + " subscribed after the receive thread started");
        std::set<std::string> channels = tap_->accepted();
        channels.insert(sub.channel);
        tap_->accept_only(channels);   // the kernel drops the other processes' channels (bus_filter.hpp)
    } else if (lc_) {
        lc_->subscribe(sub.channel, &Sub::on_raw, &sub)->setQueueCapacity(kQueueCapacity);
    }
}

int Inbox::handle(int timeout_ms)
{
    if (tap_ && batch_us_ > 0) {
        if (!batcher_) {
            auto b = std::make_unique<Batcher>();
            b->start(*tap_, batch_us_);   // throws before batcher_ is set
            batcher_ = std::move(b);
        }
        std::vector<Batcher::Msg> one;
        // rethrows the receive thread's end once what it queued is taken
        if (batcher_->queue.take(&one, 1, 1000LL * std::max(0, timeout_ms)).n == 0) return 0;
        deliver(one.front().channel, one.front().data.data(), one.front().data.size());
        return 1;
    }
    if (tap_)
        return tap_->next([this](const std::string &channel, const unsigned char *data, std::size_t size,
                                 int64_t) { deliver(channel, data, size); },
                          timeout_ms);
    return lc_ ? lc_->handleTimeout(timeout_ms) : 0;
}

int64_t Inbox::bus_dropped() const
{
    if (batcher_) return batcher_->dropped;
    return tap_ ? tap_->dropped() : 0;
}

int64_t Inbox::bus_abandoned() const
{
    if (batcher_) return batcher_->abandoned;
    return tap_ ? tap_->abandoned() : 0;
}

nlohmann::json Inbox::report() const
{
    nlohmann::json j = rejected_.to_json();
    j["bus_dropped"] = bus_dropped();
    j["bus_abandoned"] = bus_abandoned();
    j["unproven"] = tap_ ? tap_->unproven().to_json() : ProofCounts().to_json();   // bus_key.hpp
    j["proof_cost"] = proof_cost().to_json();
    j["foreign_datagrams"] = senders_ ? senders_->foreign_count() : 0;
    j["foreign"] = senders_ ? senders_->foreign() : nlohmann::json::object();
    return j;
}

void Inbox::Sub::on_raw(const lcm::ReceiveBuffer *rbuf, const std::string &)
{
    const Reject r = take(rbuf->data, rbuf->data_size);
    inbox->rejected_.count(r, channel);
}

Reject Inbox::deliver(const std::string &channel, const void *data, std::size_t size)
{
    for (auto &s : subs_)
        if (s->channel == channel) {
            const Reject r = s->take(data, size);
            rejected_.count(r, channel);
            return r;
        }
    return Reject::none;
}

}  // namespace afm
