// Fuzz target "record": the launcher's path from the bus to run.json, with
// channel names of any bytes (issue 46: one datagram on a channel named
// "\xffX" aborted the launcher at the end of its run, nlohmann's
// type_error.316, exit 134, no run.json).
//
// Input: datagrams, each as [sender: 1 byte][length: 2 bytes, big-endian]
// [bytes], from 127.0.0.1, port 40000 + sender % 8, gathered as the
// launcher's tap gathers them (BusGather: short messages and fragments);
// every message is recorded (BusRecorder, a log in TMPDIR), counted as a
// refusal of the launcher's inbox (Rejections) and as a foreign datagram of
// its sender (Senders::count_foreign); then the log is read back (LogReader)
// and the channels counted as run.json counts them (channels_json). The
// promises:
//  - every JSON that run.json takes from these dumps in strict mode (no
//    exception) as valid UTF-8 without a control byte;
//  - the record reads back as written: as many events, the same channels;
//  - channels whose names differ stay apart in every table (the escaping,
//    afm::printable, is reversible);
//  - nothing escapes (no exception, no sanitizer report).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <string>

#include "bus_recorder.hpp"
#include "bus_tap.hpp"
#include "inbox.hpp"
#include "lcmlog.hpp"
#include "senders.hpp"

namespace {

[[noreturn]] void broken(const char *promise)
{
    __builtin_printf("fuzz: broken promise: %s\n", promise);
    std::abort();
}

// Valid UTF-8 without a C0 control or DEL (what a strict dump of escaped
// text gives; JSON's own escapes are ASCII).
bool clean_utf8(const std::string &s)
{
    for (std::size_t i = 0; i < s.size();) {
        const unsigned char c = static_cast<unsigned char>(s[i]);
        if (c < 0x80) {
            if ((c < 0x20 && c != '\n') || c == 0x7F) return false;
            ++i;
            continue;
        }
        const int n = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 ? 2 : 0;
        if (n == 0 || i + n > s.size()) return false;
        for (int k = 1; k < n; ++k)
            if ((static_cast<unsigned char>(s[i + k]) & 0xC0) != 0x80) return false;
        i += n;
    }
    return true;
}

std::string dumped(const nlohmann::json &j)
{
    try {
        return j.dump(2);
    } catch (const nlohmann::json::exception &) {
        broken("run.json's dump threw");
    }
}

std::string log_path()
{
    const char *tmp = std::getenv("TMPDIR");
    return std::string(tmp && *tmp ? tmp : "/tmp") + "/fuzz_record." + std::to_string(getpid()) + ".lcmlog";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const std::string path = log_path();
    afm::BusGather g;
    afm::Rejections rejected;
    afm::Senders senders(afm::Senders::Scope::children);
    std::map<std::string, int64_t> sent;   // raw channel -> messages
    int64_t events = 0;
    {
        afm::BusRecorder rec(path);
        const auto sink = [&](const std::string &channel, const unsigned char *d, std::size_t n, int64_t t) {
            rec.take(channel, d, n, t);
            rejected.count(afm::Reject::fingerprint, channel);
            senders.count_foreign(channel, 40000);
            ++sent[channel];
            ++events;
        };
        for (std::size_t at = 0; size - at >= 3;) {
            const uint8_t sender = data[at];
            std::size_t n = (static_cast<std::size_t>(data[at + 1]) << 8) | data[at + 2];
            at += 3;
            if (n > size - at) n = size - at;
            g.take(data + at, n, 0x7F000001u, static_cast<uint16_t>(40000 + sender % 8), 1000, sink);
            at += n;
        }
        rec.settle(true);
    }
    std::map<std::string, int64_t> counts;
    {
        afm::LogReader log(path);
        afm::LogEvent ev;
        while (log.read(&ev)) ++counts[ev.channel];
    }
    unlink(path.c_str());
    if (counts != sent) broken("the record reads back otherwise than it was written");
    const nlohmann::json channels = afm::channels_json(counts), rej = rejected.to_json(), foreign = senders.foreign();
    for (const auto *j : {&channels, &rej, &foreign})
        if (!clean_utf8(dumped(*j))) broken("a dump that is not clean UTF-8");
    if (channels.size() != counts.size()) broken("two channels merged in run.json's channels");
    if (rej["by_channel"].size() != sent.size() || foreign.size() != sent.size()) broken("two channels merged in a count");
    if (rejected.total() != events || senders.foreign_count() != events) broken("a message not counted");
    return 0;
}
