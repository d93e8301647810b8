// afm_view_bridge: the one hop of a viewed run's data out of its network
// namespace (docs/view.md). The launcher starts it as its child (afm_launch
// --view --view-fd N), with the run's bus key, and hands it the write end of
// a pipe whose reader, the page's server (analysis/view), runs in the
// caller's namespace. It takes VIEW_FRAME and AFM_HEARTBEAT off the bus,
// through a bus tap filtered by the kernel to those two channels
// (bus/bus_tap.hpp: the lockstep's datagrams never wake it), and writes
// each message as it came to the pipe.
//
// Contract:
//   - The pipe carries records, one a message: the channel's length (u32,
//     little-endian), the channel, the payload's length (u32, little-endian),
//     the payload (the LCM message as its sender encoded it, the trailer of
//     the run's proof stripped; the server decodes it with the generated
//     types, nothing else).
//   - It takes a message only from the run's own process that publishes its
//     channel (bus/senders.hpp), and, holding the run's key (inherited as
//     every child of the launcher inherits it: bus/bus_key.hpp), only
//     with the run's proof: as every process of the run does. What it
//     refuses is counted by reason and channel, said in its log when it
//     ends, and written to --report FILE (JSON: "passed" by channel,
//     "rejected": "unproven", "foreign", "foreign_datagrams", "tap_dropped",
//     "tap_abandoned"; "bus_mac": whether it held a key; "ended": how the
//     bridge ended, bus/lifecycle.hpp), which the launcher
//     puts in run.json (launcher.view_bridge).
//   - It publishes nothing: an observer the run never waits for. When the
//     pipe is full it blocks, and its socket's buffer overflows instead of
//     anything of the run slowing down.
//   - It ends when the launcher ends (its parent-death signal), on SIGTERM or
//     SIGINT (having first passed on the messages its socket holds), or when
//     the pipe's reader is gone; exit 0, 2 for a bad command line or a bus it
//     cannot open, 1 when its launcher is gone at its start or the key it was
//     handed does not read (common/process.hpp, run_process).
#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "afm_channels.h"
#include "bus.hpp"
#include "bus_key.hpp"
#include "bus_tap.hpp"
#include "process.hpp"
#include "run_process.hpp"
#include "senders.hpp"

namespace {

volatile sig_atomic_t g_stop = 0;
extern "C" void on_stop(int) { g_stop = 1; }

// Writes all of `n` bytes (a signal does not cut a record short); false
// when the reader is gone.
bool write_all(int fd, const void *p, std::size_t n)
{
    const auto *b = static_cast<const unsigned char *>(p);
    while (n > 0) {
        const ssize_t w = write(fd, b, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        b += w;
        n -= static_cast<std::size_t>(w);
    }
    return true;
}

bool write_u32(int fd, std::size_t v)
{
    const unsigned char le[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8), static_cast<unsigned char>(v >> 16),
                                 static_cast<unsigned char>(v >> 24)};
    return write_all(fd, le, 4);
}

// The bridge's command line and its one check of each option (command_line.hpp).
struct Args {
    int fd = -1;
    std::string report;   // "" when none
};

const afm::Process<Args> kProcess = {
    {"afm_view_bridge",
    "usage: afm_view_bridge --fd N [--report FILE]\n"
    "  Writes the run's VIEW_FRAME and AFM_HEARTBEAT messages to file descriptor N\n"
    "  (a pipe to the page's server; docs/view.md); what it refused to FILE at its end.\n"
    "  afm_launch --view --view-fd N starts it.\n",
    {
        {{"--fd", "N", nullptr, nullptr, true}, afm::cli::whole(&Args::fd, 0, 1023, "a file descriptor")},
        {{"--report", "FILE", nullptr, nullptr}, afm::cli::text(&Args::report)},
    }},
    {AFM_CH_VIEW_FRAME, AFM_CH_AFM_HEARTBEAT},
    {},
    [](const Args &a) { return a.report; }};

void on_signals()
{
    struct sigaction sa {};
    sa.sa_handler = on_stop;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
    signal(SIGPIPE, SIG_IGN);
}

// What the bridge passed on and refused: its log's last line.
void say_passed(const afm::BusTap &tap, const afm::Senders &senders, const std::map<std::string, int64_t> &passed)
{
    const nlohmann::json unproven = tap.unproven().to_json();
    int64_t n = 0;
    for (const auto &[ch, k] : passed) n += k;
    std::fprintf(stderr,
                 "afm_view_bridge: passed on %lld messages (VIEW_FRAME %lld, AFM_HEARTBEAT %lld); refused %lld without the run's proof "
                 "(no_trailer %lld, bad_mac %lld, replayed %lld)%s, %lld from no process of the run that publishes its channel\n",
                 static_cast<long long>(n), static_cast<long long>(passed.count(AFM_CH_VIEW_FRAME) ? passed.at(AFM_CH_VIEW_FRAME) : 0),
                 static_cast<long long>(passed.count(AFM_CH_AFM_HEARTBEAT) ? passed.at(AFM_CH_AFM_HEARTBEAT) : 0),
                 static_cast<long long>(unproven["total"].get<int64_t>()), static_cast<long long>(unproven["by_reason"]["no_trailer"].get<int64_t>()),
                 static_cast<long long>(unproven["by_reason"]["bad_mac"].get<int64_t>()),
                 static_cast<long long>(unproven["by_reason"]["replayed"].get<int64_t>()), afm::run_key() ? "" : " (no key: nothing proven)",
                 static_cast<long long>(senders.foreign_count()));
}

// --report: the same, by channel and reason.
nlohmann::json report_json(const afm::BusTap &tap, const afm::Senders &senders, const std::map<std::string, int64_t> &passed)
{
    return {{"passed", passed},
            {"rejected", {{"unproven", tap.unproven().to_json()}, {"foreign", senders.foreign()}, {"foreign_datagrams", senders.foreign_count()}}},
            {"tap_dropped", tap.dropped()},
            {"tap_abandoned", tap.abandoned()},
            {"bus_mac", afm::run_key() != nullptr}};
}

// parent: the launcher, as the bridge found it at its start.
int bridge(const Args &a, pid_t parent, afm::Lifecycle &life)
{
    // still bound to the launcher (run_process), now by a signal it stops
    // on as on SIGTERM, saying what it refused
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) return afm::kExitOk;   // the launcher ended before the line above
    on_signals();
    try {
        afm::BusTap tap(afm::bus_url());
        tap.accept_only({AFM_CH_VIEW_FRAME, AFM_CH_AFM_HEARTBEAT});
        // only the run's own processes on their channels (senders.hpp): the
        // bridge's parent is the launcher, as the run's processes' is
        afm::Senders senders(afm::Senders::Scope::siblings);
        tap.admit_only([&senders](const std::string &channel, uint16_t port) { return senders.admit(channel, port); });
        std::map<std::string, int64_t> passed;
        const auto report = life.report_from([&] { return report_json(tap, senders, passed); });   // written as the bridge ends
        bool open = true;
        const afm::BusTap::Sink sink = [&](const std::string &channel, const unsigned char *data, std::size_t size, int64_t) {
            open = open && write_u32(a.fd, channel.size()) && write_all(a.fd, channel.data(), channel.size()) && write_u32(a.fd, size) &&
                   write_all(a.fd, data, size);
            if (open) ++passed[channel];
        };
        while (open && !g_stop) tap.next(sink, 200);
        while (open && tap.next(sink, 0) > 0) {}   // stopped: what the socket holds yet
        say_passed(tap, senders, passed);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "afm_view_bridge: %s\n", e.what());
        return afm::kExitInput;
    }
    return afm::kExitOk;
}

}  // namespace

int main(int argc, char **argv)
{
    const pid_t parent = getppid();
    return afm::run_process(kProcess, argc, argv, [parent](const Args &a, afm::Lifecycle &life) { return bridge(a, parent, life); });
}
