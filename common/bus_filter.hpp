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
// A process with a subscription to a pattern (the launcher's recorder, ".*")
// is never filtered. Filtering changes what reaches liblcm's receive thread,
// never what a subscription receives: a channel dropped by the kernel is one
// liblcm would have dropped itself (no handler).
//
// The channel is read from LCM's UDP multicast header (LCM's "UDP Multicast
// Protocol": magic, a 32-bit sequence number, the channel's name and its
// NUL); LCM exports no reader of its datagrams, so this and afm_netfault are
// the two places that read it, each checked by tests against liblcm itself
// (test_bus_filter).
//
// Where the filter cannot be attached (no receive socket found: another
// provider than udpm, or a liblcm that keeps it elsewhere), nothing is
// filtered and the process works as without it; filtered() says which.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include <linux/filter.h>

namespace afm {

// The classic BPF program that accepts exactly what the header says for
// `channels` (offsets relative to the UDP header, as a UDP socket's filter
// sees a datagram). Empty `channels`: accept everything LCM could use
// nothing of except LCM_SELF_TEST and non-short messages.
std::vector<sock_filter> bus_filter_program(const std::set<std::string> &channels);

// The process's LCM receive socket: the one datagram socket bound to the
// bus's port (bus.hpp, kBusPort); -1 if there is none, or more than one (a
// socket inherited from a parent is the parent's too: never filtered here).
int bus_receive_socket();

// Adds `channel` to what `lc`'s socket lets through, and (re)attaches the
// filter. "" (a pattern) turns filtering off for good. Returns false, with
// `why`, when the filter could not be attached (then nothing is filtered).
bool bus_filter_add(lcm::LCM *lc, const std::string &channel, std::string *why = nullptr);
void bus_filter_off(lcm::LCM *lc);

// Whether the kernel filters this process's bus socket now, and on which channels.
bool bus_filtered();
std::set<std::string> bus_filter_channels();

}  // namespace afm
