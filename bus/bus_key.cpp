#include "bus_key.hpp"

#include <sodium.h>
#include <sys/mman.h>
#include <sys/random.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include "text.hpp"

namespace afm {

namespace {

constexpr unsigned char kMagic[4] = {'A', 'F', 'M', 'K'};
static_assert(crypto_shorthash_siphashx24_KEYBYTES == BusKey::kKeyBytes, "SipHash's key");
static_assert(crypto_shorthash_siphashx24_BYTES == BusKey::kTagBytes, "SipHash-x24's output is the tag");

void put_be64(uint64_t v, unsigned char *out)
{
    for (int i = 7; i >= 0; --i, v >>= 8) out[i] = static_cast<unsigned char>(v & 0xFF);
}

uint64_t get_be64(const unsigned char *in)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v = (v << 8) | in[i];
    return v;
}

}  // namespace

const char *check_name(BusKey::Check c)
{
    switch (c) {
    case BusKey::Check::ok: return "ok";
    case BusKey::Check::no_trailer: return "no_trailer";
    case BusKey::Check::bad_mac: return "bad_mac";
    }
    return "?";
}

BusKey BusKey::make()
{
    std::array<unsigned char, kKeyBytes> k{};
    std::size_t got = 0;
    while (got < k.size()) {
        const ssize_t n = getrandom(k.data() + got, k.size() - got, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw std::runtime_error(std::string("the bus key: getrandom: ") + std::strerror(errno));
        got += static_cast<std::size_t>(n);
    }
    return BusKey(k);
}

std::optional<BusKey> BusKey::inherited()
{
    const char *env = std::getenv(kBusKeyFdEnv);
    if (!env || !*env) return std::nullopt;
    char *end = nullptr;
    const long fd = std::strtol(env, &end, 10);
    const std::string name = std::string(kBusKeyFdEnv) + "=" + env;
    if (*end || fd < 0 || fd > 65535) throw std::runtime_error(name + ": not a descriptor");
    std::array<unsigned char, kKeyBytes> k{};
    std::size_t got = 0;
    while (got < k.size()) {
        const ssize_t n = pread(static_cast<int>(fd), k.data() + got, k.size() - got, static_cast<off_t>(got));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int err = n < 0 ? errno : 0;
            close(static_cast<int>(fd));
            throw std::runtime_error(name + ": holds no bus key" + (err ? std::string(": ") + std::strerror(err) : std::string(" (short)")));
        }
        got += static_cast<std::size_t>(n);
    }
    close(static_cast<int>(fd));
    unsetenv(kBusKeyFdEnv);
    return BusKey(k);
}

int BusKey::memfd() const
{
    const int fd = memfd_create("afm-bus-key", MFD_CLOEXEC);
    if (fd < 0) throw std::runtime_error(std::string("the bus key: memfd_create: ") + std::strerror(errno));
    if (write(fd, key_.data(), key_.size()) != static_cast<ssize_t>(key_.size())) {
        const int err = errno;
        close(fd);
        throw std::runtime_error(std::string("the bus key: cannot write its memfd: ") + std::strerror(err));
    }
    return fd;
}

void BusKey::tag(const std::string &channel, const unsigned char *seq_be, const unsigned char *d, std::size_t n, unsigned char *out) const
{
    // SipHash takes one buffer: the channel with its NUL, the sequence, the message
    thread_local std::vector<unsigned char> in;
    in.resize(channel.size() + 1 + 8 + n);
    std::memcpy(in.data(), channel.c_str(), channel.size() + 1);
    std::memcpy(in.data() + channel.size() + 1, seq_be, 8);
    if (n) std::memcpy(in.data() + channel.size() + 9, d, n);
    crypto_shorthash_siphashx24(out, in.data(), in.size(), key_.data());
}

void BusKey::sign(const std::string &channel, uint64_t seq, std::vector<unsigned char> *msg) const
{
    const int64_t t0 = proof_clock_ns();
    const std::size_t n = msg->size();
    msg->resize(n + kTrailerBytes);
    unsigned char *t = msg->data() + n;
    std::memcpy(t, kMagic, 4);
    put_be64(seq, t + 4);
    tag(channel, t + 4, msg->data(), n, t + 12);
    ProofCost &c = proof_cost();
    c.sign_ns += proof_clock_ns() - t0;
    ++c.signed_n;
}

BusKey::Check BusKey::verify(const std::string &channel, const unsigned char *d, std::size_t n, uint64_t *seq) const
{
    if (n < kTrailerBytes) return Check::no_trailer;
    const unsigned char *t = d + n - kTrailerBytes;
    if (std::memcmp(t, kMagic, 4) != 0) return Check::no_trailer;
    const int64_t t0 = proof_clock_ns();
    unsigned char want[kTagBytes];
    tag(channel, t + 4, d, n - kTrailerBytes, want);
    const bool same = sodium_memcmp(want, t + 12, kTagBytes) == 0;
    ProofCost &c = proof_cost();
    c.check_ns += proof_clock_ns() - t0;
    ++c.checked_n;
    if (!same) return Check::bad_mac;
    *seq = get_be64(t + 4);
    return Check::ok;
}

namespace {

struct Held {
    std::once_flag once;
    std::optional<BusKey> key;
    bool set = false;
};

Held &held()
{
    static Held h;
    return h;
}

}  // namespace

const BusKey *run_key()
{
    Held &h = held();
    std::call_once(h.once, [&] {
        if (!h.set) h.key = BusKey::inherited();
    });
    return h.key ? &*h.key : nullptr;
}

void set_run_key(const BusKey &key)
{
    Held &h = held();
    h.key = key;
    h.set = true;
    run_key();   // taken: nothing is inherited after it
}

bool bus_mac_off()
{
    const char *v = std::getenv("AFM_BUS_MAC");
    return v && std::string(v) == "off";
}

ProofCost &proof_cost()
{
    static ProofCost c;
    return c;
}

int64_t proof_clock_ns()
{
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

nlohmann::json ProofCost::to_json() const
{
    return {{"signed", signed_n.load()}, {"sign_us", sign_ns.load() * 1e-3}, {"checked", checked_n.load()}, {"check_us", check_ns.load() * 1e-3}};
}

void ProofCounts::count(const char *reason, const std::string &channel)
{
    std::lock_guard<std::mutex> lock(m_);
    ++total_;
    ++by_reason_[reason];
    std::string name = printable(channel);
    if (!by_channel_.count(name) && by_channel_.size() >= kMaxChannels) name = kOtherChannels;
    ++by_channel_[name];
}

int64_t ProofCounts::total() const
{
    std::lock_guard<std::mutex> lock(m_);
    return total_;
}

nlohmann::json ProofCounts::to_json() const
{
    std::lock_guard<std::mutex> lock(m_);
    nlohmann::json j = {{"total", total_}, {"by_reason", nlohmann::json::object()}, {"by_channel", nlohmann::json::object()}};
    for (const auto &[r, n] : by_reason_) j["by_reason"][r] = n;
    for (const auto &[c, n] : by_channel_) j["by_channel"][c] = n;
    return j;
}

bool ReplayWindow::take(uint16_t sender, const std::string &channel, uint64_t seq)
{
    Seen &s = seen_[{sender, channel}];
    if (!s.any || seq > s.top) {
        const uint64_t shift = s.any ? seq - s.top : kWindow;
        s.bits = shift >= kWindow ? 0 : s.bits << shift;
        s.bits |= 1;
        s.top = seq;
        s.any = true;
        return true;
    }
    const uint64_t back = s.top - seq;
    if (back >= kWindow) return false;   // too old to tell: refused
    const uint64_t bit = uint64_t{1} << back;
    if (s.bits & bit) return false;
    s.bits |= bit;
    return true;
}

}  // namespace afm
