#include "bus_tap.hpp"

#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "bus.hpp"
#include "bus_filter.hpp"
#include "lcmlog.hpp"
#include "senders.hpp"

namespace afm {

namespace {

constexpr int kBatch = 64;                 // datagrams per recvmmsg
constexpr std::size_t kDatagramMax = 65536;
static_assert(BusTap::kMaxMessageBytes <= LogReader::kMaxDataBytes, "the tap gathers no message its log cannot hold");

struct Url {
    in_addr group{};
    int port = 0;
    int recv_buf = 0;
};

Url parse(const std::string &url)
{
    const std::string head = "udpm://";
    auto fail = [&](const std::string &why) { return std::runtime_error("bus tap: " + url + ": " + why); };
    if (url.rfind(head, 0) != 0) throw fail("not a udpm:// URL");
    Url u;
    u.port = udpm_port(url.c_str());   // bus.hpp's reader of the port, as afm_netfault's rule uses it
    if (u.port < 0) throw fail("no GROUP:PORT");
    if (u.port == 0 || u.port > 65535) throw fail("the port is not in 1..65535");
    const std::size_t colon = url.rfind(':', url.find('?'));
    if (inet_pton(AF_INET, url.substr(head.size(), colon - head.size()).c_str(), &u.group) != 1) throw fail("the group is not an IPv4 address");
    const std::size_t rb = url.find("recv_buf_size=");
    if (rb != std::string::npos) u.recv_buf = std::atoi(url.c_str() + rb + std::strlen("recv_buf_size="));
    return u;
}

// The kernel's receive time of a datagram read with its control data
// (SO_TIMESTAMP), in us since the epoch; now when none came with it.
int64_t stamp_of(msghdr &h)
{
    for (cmsghdr *c = CMSG_FIRSTHDR(&h); c; c = CMSG_NXTHDR(&h, c))
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMP) {
            timeval tv;
            std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
            return static_cast<int64_t>(tv.tv_sec) * 1000000 + tv.tv_usec;
        }
    return wall_utime();
}

}  // namespace

BusTap::BusTap(const std::string &url)
{
    const Url u = parse(url);
    auto fail = [&](const char *what) {
        const std::string why = std::string("bus tap: ") + url + ": " + what + ": " + std::strerror(errno);
        if (fd_ >= 0) close(fd_);
        return std::runtime_error(why);
    };
    fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw fail("socket");
    const int one = 1;
    if (setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) throw fail("SO_REUSEADDR");
    if (setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof one) != 0) throw fail("SO_TIMESTAMP");
    // as liblcm does: a request the kernel may cap at net.core.rmem_max
    if (u.recv_buf > 0) setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &u.recv_buf, sizeof u.recv_buf);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(u.port));
    a.sin_addr.s_addr = htonl(INADDR_ANY);
    if (bind(fd_, reinterpret_cast<sockaddr *>(&a), sizeof a) != 0) throw fail("bind");
    ip_mreq m{};
    m.imr_multiaddr = u.group;
    m.imr_interface.s_addr = htonl(INADDR_ANY);
    if (setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof m) != 0) throw fail("IP_ADD_MEMBERSHIP");
    gather_.prove_with(run_key(), !Senders::admit_any());
}

BusTap::~BusTap()
{
    if (fd_ >= 0) close(fd_);
}

void BusTap::accept_only(const std::set<std::string> &channels)
{
    if (!bus_filter_attach(fd_, channels)) throw std::runtime_error(std::string("bus tap: SO_ATTACH_FILTER: ") + std::strerror(errno));
    gather_.accept_only(channels);
}

void BusGather::accept_only(const std::set<std::string> &channels)
{
    filtered_ = true;
    accept_ = channels;
}

int64_t BusTap::receive_buffer_bytes() const
{
    int v = 0;
    socklen_t n = sizeof v;
    return getsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &v, &n) == 0 ? v : 0;
}

bool BusTap::wait(int timeout_ms)
{
    // An error on the socket counts as readable: drain()'s recvmmsg takes
    // it (clearing it), so a socket error never turns waits into a spin.
    pollfd p{fd_, POLLIN, 0};
    return poll(&p, 1, timeout_ms) > 0 && p.revents != 0;
}

int BusTap::drain(const Sink &sink, int max)
{
    int read = 0;
    return receive(sink, max, &read);
}

int BusTap::receive(const Sink &sink, int max, int *read, bool wait)
{
    // the buffers are the tap's (one thread reads a tap), as large as the
    // largest batch asked for: a datagram for next(), 64 for drain()
    const std::size_t batch = static_cast<std::size_t>(std::clamp(max, 1, kBatch));
    if (bufs_.size() < batch * kDatagramMax) {
        bufs_.resize(batch * kDatagramMax);
        ctl_.resize(batch * CMSG_SPACE(sizeof(timeval)));
    }
    mmsghdr msgs[kBatch];
    iovec iov[kBatch];
    sockaddr_in from[kBatch];
    int messages = 0;
    *read = 0;
    while (*read < max) {
        const int want = std::min(kBatch, max - *read);
        for (int i = 0; i < want; ++i) {
            iov[i] = {bufs_.data() + static_cast<std::size_t>(i) * kDatagramMax, kDatagramMax};
            msgs[i].msg_hdr = {};
            msgs[i].msg_hdr.msg_name = &from[i];
            msgs[i].msg_hdr.msg_namelen = sizeof from[i];
            msgs[i].msg_hdr.msg_iov = &iov[i];
            msgs[i].msg_hdr.msg_iovlen = 1;
            msgs[i].msg_hdr.msg_control = ctl_.data() + static_cast<std::size_t>(i) * CMSG_SPACE(sizeof(timeval));
            msgs[i].msg_hdr.msg_controllen = CMSG_SPACE(sizeof(timeval));
        }
        // The first read may wait (for the socket's SO_RCVTIMEO, set by
        // next()), so that a waiting process takes a datagram in the one
        // call that wakes it.
        const bool block = wait && *read == 0;
        const int got = recvmmsg(fd_, msgs, static_cast<unsigned>(want), block ? 0 : MSG_DONTWAIT, nullptr);
        if (got <= 0) break;   // nothing queued (EAGAIN), the timeout, a signal, or a socket error, now taken
        for (int i = 0; i < got; ++i) {
            if (msgs[i].msg_hdr.msg_flags & MSG_TRUNC) {
                gather_.drop();   // larger than any datagram LCM sends
                continue;
            }
            messages += gather_.take(static_cast<const unsigned char *>(iov[i].iov_base), msgs[i].msg_len, ntohl(from[i].sin_addr.s_addr),
                                     ntohs(from[i].sin_port), stamp_of(msgs[i].msg_hdr), sink);
        }
        *read += got;
        if (got < want) break;
    }
    return messages;
}

bool BusTap::set_timeout(int ms)
{
    if (ms == timeout_ms_) return true;
    const timeval tv{ms / 1000, (ms % 1000) * 1000};
    if (setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv) != 0) return false;   // then poll, as before
    timeout_ms_ = ms;
    return true;
}

int BusTap::next(const Sink &sink, int timeout_ms)
{
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
    for (int idle = 0;;) {
        int wait_ms = static_cast<int>(
            std::max<int64_t>(0, std::chrono::ceil<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count()));
        // One call: the read waits (up to wait_ms, SO_RCVTIMEO) for the
        // datagram itself, where a poll and then a read would take two
        // calls and the empty read before them a third (docs/bus.md, "The
        // latency model"). Without SO_RCVTIMEO, a poll and a read.
        if (wait_ms > 0 && !set_timeout(wait_ms)) {
            if (!wait(wait_ms)) return 0;
            wait_ms = 0;
        }
        int read = 0;
        if (receive(sink, 1, &read, wait_ms > 0) > 0) return 1;
        // a datagram that completed no message (a fragment, one dropped):
        // read on, but not past the timeout under a stream of them
        if (read > 0 && (++idle % 256 != 0 || std::chrono::steady_clock::now() < deadline)) continue;
        // nothing came in time (or a signal, or a socket error, taken by the
        // read so that it never turns into a spin: the next read waits)
        if (read > 0 || std::chrono::steady_clock::now() >= deadline) return 0;
    }
}

int BusGather::take(const unsigned char *d, std::size_t n, uint32_t addr, uint16_t port, int64_t utime, const Sink &sink)
{
    LcmDatagram g;
    if (!lcm_datagram(d, n, &g)) {
        ++dropped_;
        return 0;
    }
    if (!g.fragment) {
        if (filtered_ && !accept_.count(g.channel)) return 0;   // the kernel let it by: a name past its filter's reach
        if (admit_ && !admit_(g.channel, port)) return 0;
        return hand_on(g.channel, d + g.payload_at, n - g.payload_at, port, utime, sink);
    }
    const uint64_t key = (static_cast<uint64_t>(addr) << 16) | port;
    auto it = partial_.find(key);
    if (it != partial_.end() &&
        (it->second.seqno != g.seqno || it->second.size != g.msg_size || it->second.got.size() != g.fragments)) {
        ++abandoned_;   // the sender has moved on: a fragment of the old message was lost
        partial_.erase(it);
        it = partial_.end();
    }
    if (it == partial_.end()) {
        // no fragment 0 to name the channel (liblcm drops these too), or a
        // size no message of the log may have or its fragments cannot carry
        if (g.fragment_no != 0 || g.msg_size > kMaxMessageBytes ||
            g.msg_size > static_cast<std::size_t>(g.fragments) * kDatagramMax) {
            ++dropped_;
            return 0;
        }
        // a sender that may not send on this channel: not even its fragments are kept
        if (!(filtered_ && !accept_.count(g.channel)) && admit_ && !admit_(g.channel, port)) return 0;
        if (partial_.size() >= kMaxPartial) {
            ++abandoned_;
            partial_.erase(partial_.begin());
        }
        Partial p;
        p.seqno = g.seqno;
        p.channel = g.channel;
        p.size = g.msg_size;
        p.skip = filtered_ && !accept_.count(g.channel);   // another process's message: followed, not copied
        p.got.assign(g.fragments, false);
        p.missing = g.fragments;
        it = partial_.emplace(key, std::move(p)).first;
    }
    Partial &p = it->second;
    const std::size_t size = n - g.payload_at;
    if (g.offset > p.size || size > p.size - g.offset) {
        ++dropped_;   // and its message cannot be whole: abandoned, as liblcm does
        ++abandoned_;
        partial_.erase(it);
        return 0;
    }
    if (p.got[g.fragment_no]) return 0;   // a fragment twice (a duplicated datagram): taken once
    if (p.held + size > p.size) {   // more than the message claims (fragments overlapping): it cannot be whole
        ++dropped_;
        ++abandoned_;
        partial_.erase(it);
        return 0;
    }
    if (!p.skip) {
        p.frags.emplace_back(g.offset, std::vector<unsigned char>(d + g.payload_at, d + g.payload_at + size));
        p.held += size;
    }
    p.got[g.fragment_no] = true;
    if (--p.missing > 0) return 0;
    const Partial whole = std::move(p);
    partial_.erase(it);
    if (whole.skip) return 0;
    if (admit_ && !admit_(whole.channel, port)) return 0;
    // Every fragment came: now the message's bytes are real, put together.
    std::vector<unsigned char> data(whole.size);
    for (const auto &[offset, bytes] : whole.frags)
        if (!bytes.empty()) std::memcpy(data.data() + offset, bytes.data(), bytes.size());   // an empty fragment has no bytes to point at (memcpy from null is undefined)
    return hand_on(whole.channel, data.data(), data.size(), port, utime, sink);
}

int BusGather::hand_on(const std::string &channel, const unsigned char *d, std::size_t n, uint16_t port, int64_t utime, const Sink &sink)
{
    if (!proven(channel, d, &n, port)) return 0;
    if (vet_ && !vet_(channel, d, n, port)) return 0;
    sink(channel, d, n, utime);
    return 1;
}

bool BusGather::proven(const std::string &channel, const unsigned char *d, std::size_t *n, uint16_t port)
{
    if (!key_) return true;
    uint64_t seq = 0;
    const BusKey::Check c = key_->verify(channel, d, *n, &seq);
    if (c == BusKey::Check::ok) {
        if (window_.take(port, channel, seq) || !enforce_) {
            *n -= BusKey::kTrailerBytes;
            return true;
        }
        unproven_.count("replayed", channel);
        return false;
    }
    if (!enforce_) return true;
    unproven_.count(check_name(c), channel);
    return false;
}

std::size_t BusGather::held_bytes() const
{
    std::size_t n = 0;
    for (const auto &kv : partial_) n += kv.second.held;
    return n;
}

}  // namespace afm
