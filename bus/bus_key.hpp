// The run's bus key and the proof each datagram carries (issue 46, item 5).
//
// The threat: anything outside the run (another user, another run, a raw
// socket in the run's namespace without the key, a forger on the link
// between two hosts) sending on the run's bus, with any source port it
// likes (a raw socket spoofs the port that bus/senders.hpp trusts). The
// run's own processes are one trust domain: they share one key.
//
// The key: 16 random bytes (getrandom), made by the launcher for each run,
// handed to its processes without touching the disk or the command line:
// a memfd (memory only, never a path) that the launcher's child finds as
// descriptor kBusKeyFd, named in its environment by kBusKeyFdEnv; the
// process reads it once at its start (BusKey::inherited) and closes the
// descriptor, so that nothing it starts (QEMU, ffmpeg) holds it.
//
// The proof: a trailer after the message's own bytes,
//     "AFMK" (4 bytes) | sequence (8 bytes, big-endian) | tag (16 bytes)
// the tag libsodium's SipHash-2-4 with a 128-bit output
// (crypto_shorthash_siphashx24: a PRF made to authenticate short messages)
// over the channel's name, a NUL, the sequence and the message. Why not
// HMAC or keyed BLAKE2b: the cost a block (./afm bench bus measures it;
// the figures: docs/bus.md, "The trailer"): a block signs six messages and
// checks each about three times (the launcher's record, its readers), and
// BLAKE2b's share of a block was over the 10 % allowed. The sequence is
// the sender's own counter (one per sending socket), so that a datagram
// recorded and sent again is refused (ReplayWindow). LCM's decoders read a
// message's fields and ignore bytes after them, so a message with its
// trailer still decodes everywhere (lcm-spy, the Python bindings).
//
// Reasons a receiver refuses (run.json, counted per channel and reason):
//   no_trailer  no trailer, or too short to hold one
//   bad_mac     a trailer whose tag is not the key's for this channel,
//               sequence and message
//   replayed    a sequence this receiver has already taken from that
//               sender on that channel, or one too old to tell
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace afm {

constexpr const char *kBusKeyFdEnv = "AFM_BUS_KEY_FD";
constexpr int kBusKeyFd = 3;   // where the launcher's child finds the key's memfd

class BusKey {
public:
    static constexpr std::size_t kKeyBytes = 16;
    static constexpr std::size_t kTagBytes = 16;
    static constexpr std::size_t kTrailerBytes = 4 + 8 + kTagBytes;

    // A fresh key from the kernel's random source (getrandom). Throws
    // std::runtime_error when the kernel gives none.
    static BusKey make();
    // The key the launcher handed down: read once from the descriptor
    // $AFM_BUS_KEY_FD names, which is then closed and the variable unset.
    // nullopt when the variable is not set (a process started by hand).
    // Throws std::runtime_error naming the descriptor when it is set but
    // holds no key.
    static std::optional<BusKey> inherited();
    explicit BusKey(const std::array<unsigned char, kKeyBytes> &k) : key_(k) {}

    // A memfd holding the key, close-on-exec (the launcher's spawn puts it
    // at kBusKeyFd in its child). Throws std::runtime_error when it cannot.
    int memfd() const;

    // `msg` with its trailer for `channel` and `seq` appended.
    void sign(const std::string &channel, uint64_t seq, std::vector<unsigned char> *msg) const;
    enum class Check { ok, no_trailer, bad_mac };
    // Checks the trailer of the n bytes at d (the message and its
    // trailer); ok: *seq is its sequence, the message is the first
    // n - kTrailerBytes bytes.
    Check verify(const std::string &channel, const unsigned char *d, std::size_t n, uint64_t *seq) const;

private:
    void tag(const std::string &channel, const unsigned char *seq_be, const unsigned char *d, std::size_t n, unsigned char *out) const;
    std::array<unsigned char, kKeyBytes> key_{};
};

const char *check_name(BusKey::Check c);

// The process's run key; nullptr: none (a process started by hand, a test,
// or a run with AFM_BUS_MAC=off: nothing is signed and nothing checked).
// The launcher sets it before it starts anything (set_run_key); any other
// process inherits it: the first call reads it (BusKey::inherited), and
// run_process (process.hpp) makes that call before anything else, so that
// the descriptor is closed before the process starts a process of its own.
// Throws as BusKey::inherited.
const BusKey *run_key();
void set_run_key(const BusKey &key);
// AFM_BUS_MAC=off in the launcher's environment: the run makes no key (the
// fault matrix's rows "without the key" show what the MAC holds off).
bool bus_mac_off();

// What the proof costs this process (./afm bench bus: the MAC's cost per
// block, apart from the floor): messages signed and checked, and the time
// spent on each, from clock reads around the work alone.
struct ProofCost {
    std::atomic<int64_t> signed_n{0}, sign_ns{0}, checked_n{0}, check_ns{0};
    // {"signed", "sign_us", "checked", "check_us"}
    nlohmann::json to_json() const;
};
ProofCost &proof_cost();
int64_t proof_clock_ns();

// What a receiver refused for want of proof: {"total", "by_reason":
// {"no_trailer", "bad_mac", "replayed"}, "by_channel": {CHANNEL: n}}, each
// CHANNEL as afm::printable shows it, at most kMaxChannels of them (a flood
// of names costs no memory: the rest are counted under kOtherChannels).
// Thread-safe (a receive thread counts, the main thread reports).
class ProofCounts {
public:
    static constexpr std::size_t kMaxChannels = 64;
    static constexpr const char *kOtherChannels = "(other channels)";
    void count(const char *reason, const std::string &channel);
    int64_t total() const;
    nlohmann::json to_json() const;

private:
    mutable std::mutex m_;
    int64_t total_ = 0;
    std::map<std::string, int64_t> by_reason_ = {{"no_trailer", 0}, {"bad_mac", 0}, {"replayed", 0}};
    std::map<std::string, int64_t> by_channel_;
};

// Sequences taken per sender and channel: a sequence is new when it is
// above every one taken, or within the last kWindow below the highest and
// not yet taken (datagrams a link reordered). Anything else is replayed.
class ReplayWindow {
public:
    static constexpr uint64_t kWindow = 64;
    // True (and remembered) when `seq` is new for (sender, channel).
    bool take(uint16_t sender, const std::string &channel, uint64_t seq);

private:
    struct Seen {
        uint64_t top = 0;    // highest taken
        uint64_t bits = 0;   // bit i: top - i taken
        bool any = false;
    };
    std::map<std::pair<uint16_t, std::string>, Seen> seen_;
};

}  // namespace afm
