// The kernel's share of a subscription: a classic BPF filter on a process's
// LCM receive socket that lets through only the datagrams on the channels
// the process subscribed to, so a datagram for another process never wakes
// this one. udpm delivers every datagram of the group to every socket on
// it; without the filter each of a block's eight datagrams wakes LCM's
// receive thread in each of the five processes, and most of them are
// dropped there, after a wake-up, a recvmsg and a channel look-up (README,
// "The bus's latency model"; ./afm bench bus measures both).
//
// What passes the filter:
//   - an LCM short message (magic "LC02") whose channel is one of the
//     process's subscriptions or LCM_SELF_TEST;
//   - every datagram that is not an LCM short message (fragments "LC03",
//     garbage): liblcm reads and judges those as before.
// The launcher, which records every channel, receives through a tap of its
// own (bus_tap.hpp), not through liblcm. Filtering changes what reaches liblcm's receive thread,
// never what a subscription receives: a channel dropped by the kernel is one
// liblcm would have dropped itself (no handler).
//
// The channel is read from LCM's UDP multicast header (LCM's "UDP Multicast
// Protocol": a short message is magic "LC02", a 32-bit sequence number, the
// channel's name with its NUL, then the payload; a fragment, "LC03", adds
// its message size, offset, number and count, and names its channel only in
// fragment 0). LCM exports no reader of its datagrams: the constants and
// lcm_datagram_channel() below are the bench's one reader, used by this
// filter and by afm_netfault, and tested against what liblcm sends by every
// run of the bench (each process filters its socket).
//
// Where the filter cannot be attached (not exactly one socket bound to the
// bus's port: another provider than udpm, or a socket inherited from a
// parent), nothing is filtered and the process works as without it.
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
// sees a datagram). Empty `channels`: only LCM_SELF_TEST and what is not a
// short message pass.
std::vector<sock_filter> bus_filter_program(const std::set<std::string> &channels);

// The process's LCM receive socket: the one datagram socket bound to the
// bus's port (bus.hpp, kBusPort); -1 if there is none, or more than one (a
// socket inherited from a parent is the parent's too: never filtered here).
int bus_receive_socket();

// Adds `channel`, just subscribed on the process's bus, to what its socket
// lets through, and (re)attaches the filter; false when it could not be
// attached (then nothing is filtered).
bool bus_filter_add(const std::string &channel);

}  // namespace afm
