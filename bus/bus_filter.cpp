#include "bus_filter.hpp"

#include "big_endian.hpp"

#include <sys/socket.h>

#include <cstring>

namespace afm {

namespace {

constexpr uint32_t kUdpHeader = 8;            // the filter sees the UDP header first
constexpr uint32_t kNameAt = kUdpHeader + kLcmShortNameAt;
constexpr uint32_t kAccept = 0xffffffffu;     // keep the whole datagram

sock_filter stmt(uint16_t code, uint32_t k) { return sock_filter{code, 0, 0, k}; }
sock_filter jump(uint16_t code, uint32_t k, uint8_t jt, uint8_t jf) { return sock_filter{code, jt, jf, k}; }

// Instructions that accept a short message on `channel` and fall through
// (to the next channel's) otherwise.
std::vector<sock_filter> channel_block(const std::string &channel)
{
    const std::string b = channel + '\0';
    std::vector<sock_filter> p;
    std::vector<std::size_t> fail;   // jumps whose jf goes past this block
    p.push_back(stmt(BPF_LD | BPF_W | BPF_LEN, 0));
    fail.push_back(p.size());
    p.push_back(jump(BPF_JMP | BPF_JGE | BPF_K, kNameAt + static_cast<uint32_t>(b.size()), 0, 0));
    for (std::size_t at = 0; at < b.size();) {
        const std::size_t n = b.size() - at >= 4 ? 4 : b.size() - at >= 2 ? 2 : 1;
        uint32_t v = 0;
        for (std::size_t i = 0; i < n; ++i) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
        const uint16_t size = n == 4 ? BPF_W : n == 2 ? BPF_H : BPF_B;
        p.push_back(stmt(BPF_LD | size | BPF_ABS, kNameAt + static_cast<uint32_t>(at)));
        fail.push_back(p.size());
        p.push_back(jump(BPF_JMP | BPF_JEQ | BPF_K, v, 0, 0));
        at += n;
    }
    p.push_back(stmt(BPF_RET | BPF_K, kAccept));
    for (std::size_t j : fail) p[j].jf = static_cast<uint8_t>(p.size() - (j + 1));   // < 255: names are short (checked below)
    return p;
}

}  // namespace

std::string lcm_datagram_channel(const unsigned char *d, std::size_t n)
{
    if (n < kLcmShortNameAt) return "";
    std::size_t at;
    const uint32_t magic = be32(d);
    if (magic == kLcmShortMagic) at = kLcmShortNameAt;
    else if (magic == kLcmFragmentMagic && n > kLcmFragmentNameAt && ((d[16] << 8) | d[17]) == 0) at = kLcmFragmentNameAt;   // fragment 0
    else return "";
    const void *nul = std::memchr(d + at, 0, n - at);
    if (!nul) return "";
    return std::string(reinterpret_cast<const char *>(d + at), static_cast<const char *>(nul));
}

bool lcm_datagram(const unsigned char *d, std::size_t n, LcmDatagram *out)
{
    if (n < kLcmShortNameAt) return false;
    LcmDatagram g;
    const uint32_t magic = be32(d);
    g.seqno = be32(d + 4);
    if (magic == kLcmFragmentMagic) {
        if (n < kLcmFragmentNameAt) return false;
        g.fragment = true;
        g.msg_size = be32(d + 8);
        g.offset = be32(d + 12);
        g.fragment_no = static_cast<uint16_t>((d[16] << 8) | d[17]);
        g.fragments = static_cast<uint16_t>((d[18] << 8) | d[19]);
        if (g.fragment_no >= g.fragments) return false;
        g.payload_at = kLcmFragmentNameAt;
    } else if (magic == kLcmShortMagic) {
        g.payload_at = kLcmShortNameAt;
    } else {
        return false;
    }
    if (!g.fragment || g.fragment_no == 0) {
        g.channel = lcm_datagram_channel(d, n);
        if (g.channel.empty() || g.channel.size() > kLcmMaxChannelBytes) return false;
        g.payload_at += g.channel.size() + 1;
    }
    *out = std::move(g);
    return true;
}

std::vector<sock_filter> bus_filter_program(const std::set<std::string> &channels)
{
    std::vector<sock_filter> p = {
        stmt(BPF_LD | BPF_W | BPF_LEN, 0),
        jump(BPF_JMP | BPF_JGE | BPF_K, kUdpHeader + 4, 1, 0),   // too short for a magic: the receiver's to judge
        stmt(BPF_RET | BPF_K, kAccept),
        stmt(BPF_LD | BPF_W | BPF_ABS, kUdpHeader),
        jump(BPF_JMP | BPF_JEQ | BPF_K, kLcmShortMagic, 1, 0),       // a fragment or garbage: the receiver's to judge
        stmt(BPF_RET | BPF_K, kAccept),
    };
    for (const auto &c : channels) {
        if (c.size() > 200) {   // a jump past a longer name would not fit in 8 bits: keep it unfiltered
            return {stmt(BPF_RET | BPF_K, kAccept)};
        }
        const auto b = channel_block(c);
        p.insert(p.end(), b.begin(), b.end());
    }
    p.push_back(stmt(BPF_RET | BPF_K, 0));   // another process's channel
    return p;
}

bool bus_filter_attach(int fd, const std::set<std::string> &channels)
{
    std::vector<sock_filter> prog = bus_filter_program(channels);
    sock_fprog fp{static_cast<unsigned short>(prog.size()), prog.data()};
    return setsockopt(fd, SOL_SOCKET, SO_ATTACH_FILTER, &fp, sizeof fp) == 0;
}

}  // namespace afm
