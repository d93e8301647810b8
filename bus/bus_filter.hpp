// The kernel's share of a subscription: a classic BPF filter on a process's
// bus socket that lets through only the datagrams on the channels the
// process subscribed to, so a datagram for another process never wakes
// this one. udpm delivers every datagram of the group to every socket on
// it; without the filter each of a block's eight datagrams would wake each
// of the five processes, most of them to be dropped after a wake-up, a
// recvmsg and a channel look-up (docs/bus.md, "The latency model";
// ./afm bench bus measures it).
//
// What passes the filter:
//   - an LCM short message (magic "LC02") whose channel is one of the
//     process's subscriptions;
//   - every datagram that is not an LCM short message (fragments "LC03",
//     garbage): the receiver (bus_tap.hpp) reads and judges those itself.
// A process receives through a BusTap of its own (inbox.hpp), which
// attaches this filter to its socket (BusTap::accept_only); the launcher,
// which records every channel, filters nothing. Filtering changes what
// reaches the process's socket, never what a subscription receives: a
// channel the kernel drops is one the inbox would have dropped itself (no
// handler).
//
// The channel is read from LCM's UDP multicast header (LCM's "UDP Multicast
// Protocol": a short message is magic "LC02", a 32-bit sequence number, the
// channel's name with its NUL, then the payload; a fragment, "LC03", adds
// its message size, offset, number and count, and names its channel only in
// fragment 0). LCM exports no reader of its datagrams: the constants,
// lcm_datagram() and lcm_datagram_channel() below are the bench's one
// reader, used by this filter, the bus tap and afm_netfault, and tested
// against what liblcm sends by every run of the bench.
#pragma once

#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include <linux/filter.h>

namespace afm {

constexpr uint32_t kLcmShortMagic = 0x4c433032;      // "LC02"
constexpr uint32_t kLcmFragmentMagic = 0x4c433033;   // "LC03"
constexpr std::size_t kLcmShortNameAt = 8;            // after magic and sequence number
constexpr std::size_t kLcmFragmentNameAt = 20;        // after magic, sequence, size, offset, number, count

// The channel an LCM datagram (a UDP payload of `n` bytes) names: a short
// message's, or fragment 0's; "" for anything else (another fragment,
// garbage, a name without its NUL).
std::string lcm_datagram_channel(const unsigned char *d, std::size_t n);

// An LCM datagram read whole: a short message, or one fragment of a longer
// one (bus_tap.hpp gathers those).
struct LcmDatagram {
    bool fragment = false;
    uint32_t seqno = 0;       // the sender's message number
    uint32_t msg_size = 0;    // a fragment's whole message, bytes (payload only)
    uint32_t offset = 0;      // where this fragment's payload goes in it
    uint16_t fragment_no = 0, fragments = 0;
    std::string channel;      // a short message's, fragment 0's; "" in a later fragment
    std::size_t payload_at = 0;   // where the payload starts in the datagram
};
// liblcm's longest channel name (LCM_MAX_CHANNEL_NAME_LENGTH); it drops longer ones.
constexpr std::size_t kLcmMaxChannelBytes = 63;
// Reads datagram `d` of `n` bytes; false for anything LCM would not take
// (garbage, a short message or fragment 0 without a NUL-ended name or with
// one over kLcmMaxChannelBytes, a fragment number not below its count).
bool lcm_datagram(const unsigned char *d, std::size_t n, LcmDatagram *out);

// The classic BPF program that accepts exactly what the header says for
// `channels` (offsets relative to the UDP header, as a UDP socket's filter
// sees a datagram). Empty `channels`: only what is not a short message
// passes. A name over 200 bytes (a jump past it would not fit BPF's 8 bits)
// turns the filter into one that passes everything.
std::vector<sock_filter> bus_filter_program(const std::set<std::string> &channels);

// Attaches bus_filter_program(channels) to socket `fd` (replacing any
// filter it had); false when the kernel refuses it (errno says why).
bool bus_filter_attach(int fd, const std::set<std::string> &channels);

}  // namespace afm
