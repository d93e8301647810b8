// afm_view_bridge: the one hop of a viewed run's data out of its network
// namespace (docs/view.md). Inside the namespace it takes VIEW_FRAME and
// AFM_HEARTBEAT off the bus, through a bus tap filtered by the kernel to
// those two channels (common/bus_tap.hpp: the lockstep's datagrams never
// wake it), and writes each message as it came to a pipe whose reader, the
// page's server (analysis/view), runs in the caller's namespace.
//
// Contract:
//   - The pipe carries records, one a message: the channel's length (u32,
//     little-endian), the channel, the payload's length (u32, little-endian),
//     the payload (the LCM message as published; the server decodes it with
//     the generated types, nothing else).
//   - It takes a message only from the run's own process that publishes its
//     channel (common/senders.hpp), as every process of the run does.
//   - It publishes nothing: an observer the run never waits for. When the
//     pipe is full it blocks, and its socket's buffer overflows instead of
//     anything of the run slowing down.
//   - It ends when its parent (the launcher) ends, on SIGTERM or SIGINT, or
//     when the pipe's reader is gone; exit 0, or 2 for a bad command line or
//     a bus it cannot open.
#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "afm_channels.h"
#include "bus.hpp"
#include "bus_tap.hpp"
#include "senders.hpp"

namespace {

const char *kUsage =
    "usage: afm_view_bridge --fd N\n"
    "  Writes the run's VIEW_FRAME and AFM_HEARTBEAT messages to file descriptor N\n"
    "  (a pipe to the page's server; docs/view.md). ./afm run --view starts it.\n";

volatile sig_atomic_t g_stop = 0;
extern "C" void on_stop(int) { g_stop = 1; }

// Writes all of `n` bytes; false when the reader is gone.
bool write_all(int fd, const void *p, std::size_t n)
{
    const auto *b = static_cast<const unsigned char *>(p);
    while (n > 0) {
        const ssize_t w = write(fd, b, n);
        if (w < 0 && errno == EINTR) {
            if (g_stop) return false;
            continue;
        }
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

// The file descriptor of "--fd N", or -1.
int parse_fd(int argc, char **argv)
{
    if (argc != 3 || std::strcmp(argv[1], "--fd") != 0) return -1;
    char *end = nullptr;
    const long fd = std::strtol(argv[2], &end, 10);
    return (*argv[2] && !*end && fd >= 0 && fd < 1024) ? static_cast<int>(fd) : -1;
}

void on_signals()
{
    struct sigaction sa {};
    sa.sa_handler = on_stop;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
    signal(SIGPIPE, SIG_IGN);
}

}  // namespace

int main(int argc, char **argv)
{
    if (argc == 2 && (!std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "--help"))) {
        std::fputs(kUsage, stdout);
        return 0;
    }
    const int fd = parse_fd(argc, argv);
    if (fd < 0) {
        std::fputs(kUsage, stderr);
        return 2;
    }
    const pid_t parent = getppid();
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) return 0;   // the launcher ended before the line above
    on_signals();
    try {
        afm::BusTap tap(afm::bus_url());
        tap.accept_only({AFM_CH_VIEW_FRAME, AFM_CH_AFM_HEARTBEAT});
        // only the run's own processes on their channels (senders.hpp): the
        // bridge's parent is the launcher, as the run's processes' is
        afm::Senders senders(afm::Senders::Scope::siblings);
        tap.admit_only([&senders](const std::string &channel, uint16_t port) { return senders.admit(channel, port); });
        bool open = true;
        const afm::BusTap::Sink sink = [&](const std::string &channel, const unsigned char *data, std::size_t size, int64_t) {
            open = open && write_u32(fd, channel.size()) && write_all(fd, channel.data(), channel.size()) && write_u32(fd, size) &&
                   write_all(fd, data, size);
        };
        while (open && !g_stop) tap.next(sink, 200);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "afm_view_bridge: %s\n", e.what());
        return 2;
    }
    return 0;
}
