// Fuzz target "bus": how every process of a run gathers the bus's datagrams
// into messages (afm::BusGather, bus/bus_tap.hpp: LCM's short messages
// and fragments, per sender), without the socket.
//
// Input: a first byte of options (bit 0: accept only three channels, as an
// inbox does; bit 1: admit only even source ports, as Senders does), then
// datagrams, each as [sender: 1 byte][length: 2 bytes, big-endian][bytes],
// from 127.0.0.1, port 40000 + sender % 8. The seed corpus
// (fuzz/make_seeds.py) holds whole fragmented messages, fragment-0 headers
// that claim 16 MiB, fragments repeated, overlapping, out of order and from
// two senders at once. The gatherer's promises:
//  - what it holds is what came: held_bytes() never exceeds the payload
//    bytes fed so far (a header's claimed size is never allocated);
//  - at most kMaxPartial unfinished messages at once;
//  - a message it hands on is on an accepted channel, from an admitted
//    sender, and no larger than kMaxMessageBytes;
//  - nothing escapes it (no exception, no sanitizer report).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>

#include "bus_tap.hpp"

namespace {

[[noreturn]] void broken(const char *promise)
{
    __builtin_printf("fuzz_bus: broken promise: %s\n", promise);
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    const uint8_t opts = data[0];
    const std::set<std::string> accepted = {"AFM_CMD", "FW_STATE", "SIM_TRUTH"};
    afm::BusGather g;
    if (opts & 1u) g.accept_only(accepted);
    if (opts & 2u) g.admit_only([](const std::string &, uint16_t port) { return port % 2 == 0; });
    std::size_t fed = 0, at = 1;
    const auto sink = [&](const std::string &channel, const unsigned char *, std::size_t n, int64_t) {
        if ((opts & 1u) && !accepted.count(channel)) broken("a message on a channel not accepted");
        if (n > afm::BusGather::kMaxMessageBytes) broken("a message over kMaxMessageBytes");
    };
    while (size - at >= 3) {
        const uint8_t sender = data[at];
        std::size_t n = (static_cast<std::size_t>(data[at + 1]) << 8) | data[at + 2];
        at += 3;
        if (n > size - at) n = size - at;
        const uint16_t port = static_cast<uint16_t>(40000 + sender % 8);
        int handed = 0;
        const auto admitted_sink = [&](const std::string &channel, const unsigned char *d, std::size_t len, int64_t t) {
            if ((opts & 2u) && port % 2 != 0) broken("a message from a sender not admitted");
            ++handed;
            sink(channel, d, len, t);
        };
        g.take(data + at, n, 0x7f000001u, port, 0, admitted_sink);
        fed += n;
        at += n;
        if (g.held_bytes() > fed) broken("held more bytes than came (a claimed size allocated)");
        if (g.partial() > afm::BusGather::kMaxPartial) broken("more unfinished messages than kMaxPartial");
        if (handed > 1) broken("one datagram completed two messages");
    }
    return 0;
}
