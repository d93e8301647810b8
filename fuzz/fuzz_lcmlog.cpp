// Fuzz target "lcmlog": the bench's reader of LCM log files (afm::LogReader,
// bus/lcmlog.hpp; lcm-logger's format) and the simulator's follower of
// the log being written (afm::LogTail, bus/log_tail.hpp).
//
// Input: the bytes of a log file. A LogError (a corrupt or truncated log,
// named by file and offset) is the reader's clean refusal. Its promises:
//  - read() frames every event back to back from offset 0 (28 header bytes,
//    the channel, the data), within the limits it declares;
//  - a reader that follows the file while it is written (next(), the file
//    given first up to its middle, then whole) sees the same events, and
//    ends as the whole file's read does: at the end, at the same corrupt
//    event, or waiting (kIncomplete) where read() says it is truncated;
//  - a reader told only() some channels returns exactly those events and
//    frames all of them (events());
// and LogTail::poll reads the file without anything escaping but LogError,
// never past the block it is told the simulator has published.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "afm_channels.h"
#include "fuzz_files.hpp"
#include "lcmlog.hpp"
#include "log_tail.hpp"

namespace {

using afm::LogError;
using afm::LogEvent;
using afm::LogReader;
using afm_fuzz::broken;

const afm_fuzz::Folder &folder()
{
    static const afm_fuzz::Folder f("lcmlog");
    return f;
}

// How reading a file ended.
struct Outcome {
    enum Kind { kEnd, kCorrupt, kTruncated } kind = kEnd;
    uint64_t offset = 0;    // where the reader stood
    std::string what;       // the LogError's text, past the file's name
};

bool same(const LogEvent &a, const LogEvent &b)
{
    return a.offset == b.offset && a.number == b.number && a.utime == b.utime && a.channel == b.channel && a.data == b.data;
}

// The message without the file name that starts it (the two readers read two files).
std::string past_path(const std::string &msg, const std::string &path)
{
    return msg.compare(0, path.size(), path) == 0 ? msg.substr(path.size()) : msg;
}

std::vector<LogEvent> read_all(const std::string &path, Outcome *out)
{
    std::vector<LogEvent> evs;
    LogReader r(path);
    LogEvent ev;
    try {
        while (r.read(&ev)) evs.push_back(ev);
        out->kind = Outcome::kEnd;
    } catch (const LogError &e) {
        out->what = past_path(e.what(), path);
        out->kind = out->what.find("truncated log") != std::string::npos ? Outcome::kTruncated : Outcome::kCorrupt;
    }
    out->offset = r.offset();
    if (r.events() != static_cast<int64_t>(evs.size())) broken("read(): events() is not the number of events read");
    return evs;
}

void check_framing(const std::vector<LogEvent> &evs)
{
    uint64_t at = 0;
    for (const auto &e : evs) {
        if (e.offset != at) broken("read(): an event does not start where the last one ended");
        if (e.channel.empty() || e.channel.size() > LogReader::kMaxChannelBytes) broken("read(): a channel beyond the limits");
        if (e.data.size() > LogReader::kMaxDataBytes) broken("read(): data beyond the limit");
        at += LogReader::kHeaderBytes + e.channel.size() + e.data.size();
    }
}

// next() on a file written in two parts: first data[0, cut), then the rest.
void check_following(const uint8_t *data, std::size_t size, const std::vector<LogEvent> &whole, const Outcome &end)
{
    const afm_fuzz::Folder &dir = folder();
    const std::size_t cut = size / 2;
    const std::string path = dir.write("growing.lcmlog", data, cut);
    LogReader r(path);
    std::vector<LogEvent> evs;
    LogEvent ev;
    Outcome out;
    try {
        LogReader::Next n;
        while ((n = r.next(&ev)) == LogReader::Next::kEvent) evs.push_back(ev);
        dir.write("growing.lcmlog", data + cut, size - cut, "ab");
        while ((n = r.next(&ev)) == LogReader::Next::kEvent) evs.push_back(ev);
        out.kind = n == LogReader::Next::kEnd ? Outcome::kEnd : Outcome::kTruncated;
    } catch (const LogError &e) {
        out.kind = Outcome::kCorrupt;
        out.what = past_path(e.what(), path);
    }
    out.offset = r.offset();
    if (evs.size() != whole.size()) broken("next() on a growing file: another number of events than read()");
    for (std::size_t i = 0; i < evs.size(); ++i)
        if (!same(evs[i], whole[i])) broken("next() on a growing file: an event differs from read()'s");
    if (out.kind != end.kind) broken("next() on a growing file ends otherwise than read()");
    if (out.kind == Outcome::kCorrupt && out.what != end.what) broken("next() on a growing file names another corruption");
    if (out.offset != end.offset) broken("next() on a growing file stops at another offset");
}

// only(channel): the events of that channel, every event framed.
void check_only(const std::string &path, const std::string &channel, const std::vector<LogEvent> &whole, const Outcome &end)
{
    LogReader r(path);
    r.only({channel});
    std::vector<LogEvent> evs;
    LogEvent ev;
    try {
        while (r.next(&ev) == LogReader::Next::kEvent) evs.push_back(ev);
    } catch (const LogError &) {
        if (end.kind != Outcome::kCorrupt) broken("only(): a LogError where read() found none");
    }
    std::size_t k = 0;
    for (const auto &w : whole) {
        if (w.channel != channel) continue;
        if (k >= evs.size() || !same(evs[k], w)) broken("only(): not the events of its channel");
        ++k;
    }
    if (k != evs.size()) broken("only(): an event of another channel");
    if (r.events() != static_cast<int64_t>(whole.size())) broken("only(): events() is not every event framed");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, std::size_t size)
{
    const std::string path = folder().write("input.lcmlog", data, size);
    Outcome end;
    const std::vector<LogEvent> whole = read_all(path, &end);
    check_framing(whole);
    check_following(data, size, whole, end);
    check_only(path, AFM_CH_AFM_ANALOG, whole, end);
    if (!whole.empty()) check_only(path, whole.front().channel, whole, end);
    // The simulator's window: a follower that has published up to block 2
    // takes no later block, and counts the same scan lines.
    afm::LogTail all(path), early(path);
    try {
        all.poll(INT64_MAX - 1);   // every block (poll takes published + 1 for the pose)
        early.poll(2);
    } catch (const LogError &) {
        return 0;
    }
    if (early.last_analog_seq() > 2 || early.last_block_recorded() > 2) broken("LogTail: a block past the one published");
    if (early.scan_lines() != all.scan_lines()) broken("LogTail: scan lines depend on the block published");
    return 0;
}
