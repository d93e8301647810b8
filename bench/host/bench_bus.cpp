// bench_bus: the raw latency of the run's bus (LCM udpm on the namespace's
// loopback), for ./afm bench bus (tools/bench_bus.py).
//
//   bench_bus --sizes 49,836 --count N [--receive tap|liblcm] [--json FILE]
//
// Forks an echo process and, for each payload size, sends N pings one at a
// time. Both ends publish through lcm::LCM (afm::open_bus), and receive
// either as the bench's processes do (--receive tap, the default: a socket
// of their own filtered to their channel and read on their own thread,
// bus/bus_tap.hpp, as afm::Inbox does) or through liblcm's own receive
// thread (--receive liblcm: subscribe and handleTimeout). Each ping carries
// its send time; the echo writes its receive time into the copy it sends
// back. Both clocks are the machine's CLOCK_MONOTONIC, so
//   one-way    = echo's receive time - send time   (one hop: publish, kernel, receive, handler)
//   round trip = back at the sender - send time    (two hops)
// Prints median and p99 of each, in microseconds. Must run inside the run's
// namespace (run/in_netns.sh), like any process on the bus.
//
// The two channels are the bench's own: raw bytes (no LCM type), never on a
// run's bus, so they are not in lcmtypes/channels.yaml.
#include <lcm/lcm-cpp.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bus.hpp"
#include "bus_tap.hpp"
#include "process.hpp"
#include "run_process.hpp"

namespace {

constexpr const char *kPing = "BENCH_BUS_PING";
constexpr const char *kPong = "BENCH_BUS_PONG";
constexpr std::size_t kStampBytes = 24;   // send time, echo's receive time, sequence: int64 each

bool g_tap = true;   // --receive tap

int64_t now_ns()
{
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void put64(uint8_t *p, int64_t v) { std::memcpy(p, &v, 8); }
int64_t get64(const uint8_t *p)
{
    int64_t v;
    std::memcpy(&v, p, 8);
    return v;
}

// The echo: every ping back at once, its receive time written in. Ends when
// its parent does (SIGTERM).
[[noreturn]] void echo()
{
    auto lc = afm::open_bus();
    struct Echo {
        lcm::LCM *lc;
        std::vector<uint8_t> out;
        void got(const void *d, std::size_t n)
        {
            const int64_t t = now_ns();
            if (n < kStampBytes) return;
            out.assign(static_cast<const uint8_t *>(d), static_cast<const uint8_t *>(d) + n);
            put64(out.data() + 8, t);
            lc->publish(kPong, out.data(), static_cast<unsigned>(out.size()));
        }
        void on(const lcm::ReceiveBuffer *rb, const std::string &) { got(rb->data, rb->data_size); }
    } e{lc.get(), {}};
    if (g_tap) {
        afm::BusTap tap(afm::bus_url());
        tap.accept_only({kPing});
        const afm::BusTap::Sink sink = [&](const std::string &, const unsigned char *d, std::size_t n, int64_t) { e.got(d, n); };
        for (;;) tap.next(sink, 1000);
    }
    lc->subscribe(kPing, &Echo::on, &e)->setQueueCapacity(afm::kQueueCapacity);
    for (;;) lc->handleTimeout(1000);
}

struct Stats {
    double median_us = 0, p99_us = 0;
};

Stats stats_of(std::vector<double> v)
{
    Stats s;
    if (v.empty()) return s;
    std::sort(v.begin(), v.end());
    s.median_us = v[v.size() / 2];
    s.p99_us = v[std::min(v.size() - 1, static_cast<std::size_t>(v.size() * 0.99))];
    return s;
}

struct Row {
    int bytes = 0;
    int sent = 0, answered = 0;
    Stats one_way, round_trip;
};

// Pings of one size, one at a time; a ping not answered in 100 ms is lost.
// tap: the receiver when --receive tap (nullptr: liblcm's).
Row measure(lcm::LCM &lc, afm::BusTap *tap, int bytes, int count)
{
    Row r;
    r.bytes = bytes;
    std::vector<uint8_t> buf(static_cast<std::size_t>(bytes), 0x5a);
    std::vector<double> one, round;
    struct Back {
        int64_t want = -1, sent_ns = 0, echo_ns = 0, back_ns = 0;
        void got(const void *data, std::size_t n)
        {
            const int64_t t = now_ns();
            if (n < kStampBytes) return;
            const auto *d = static_cast<const uint8_t *>(data);
            if (get64(d + 16) != want) return;   // a late answer to an earlier ping
            sent_ns = get64(d);
            echo_ns = get64(d + 8);
            back_ns = t;
        }
        void on(const lcm::ReceiveBuffer *rb, const std::string &) { got(rb->data, rb->data_size); }
    } back;
    lcm::Subscription *sub = nullptr;
    afm::BusTap::Sink on_tap;
    if (tap) {
        on_tap = [&](const std::string &, const unsigned char *d, std::size_t n, int64_t) { back.got(d, n); };
    } else {
        sub = lc.subscribe(kPong, &Back::on, &back);
        sub->setQueueCapacity(afm::kQueueCapacity);
    }
    for (int i = -50; i < count; ++i) {   // 50 unmeasured pings first: caches and the scheduler warm
        back.want = i;
        back.back_ns = 0;
        put64(buf.data() + 16, i);
        put64(buf.data(), now_ns());
        lc.publish(kPing, buf.data(), static_cast<unsigned>(buf.size()));
        const int64_t deadline = now_ns() + 100000000;
        while (!back.back_ns && now_ns() < deadline) {
            if (tap) tap->next(on_tap, 10);
            else lc.handleTimeout(10);
        }
        if (i < 0) continue;
        ++r.sent;
        if (!back.back_ns) continue;
        ++r.answered;
        one.push_back((back.echo_ns - back.sent_ns) * 1e-3);
        round.push_back((back.back_ns - back.sent_ns) * 1e-3);
    }
    if (sub) lc.unsubscribe(sub);
    r.one_way = stats_of(one);
    r.round_trip = stats_of(round);
    return r;
}

// The command line (kCommandLine: each option's one check).
struct Options {
    std::vector<int> sizes = {49, 57, 76, 836, 2056};
    int count = 2000;
    std::string receive = "tap";
    std::string json_path;
};

// "--sizes 49,836": every one a size in bytes the probe can send.
std::string set_sizes(const std::string &v, Options *o)
{
    std::vector<int> sizes;
    for (std::size_t p = 0; p <= v.size();) {
        const std::size_t q = std::min(v.find(',', p), v.size());
        long long b = 0;
        if (!afm::cli::read_whole(v.substr(p, q - p), static_cast<long long>(kStampBytes), 60000, &b).empty())
            return "wants sizes in bytes from " + std::to_string(kStampBytes) + " to 60000, comma-separated";
        sizes.push_back(static_cast<int>(b));
        p = q + 1;
    }
    o->sizes = sizes;
    return "";
}

const afm::cli::CommandLine<Options> kCommandLine = {
    "bench_bus",
    "usage: bench_bus [--sizes B,B,...] [--count N] [--receive tap|liblcm] [--json FILE]\n"
    "  The raw one-way and round-trip latency of LCM on the run's bus for each\n"
    "  payload size. Run inside a network namespace (run/in_netns.sh).\n",
    {
        {{"--sizes", "B,B,...", "options:",
          "payload sizes in bytes, 24 to 60000 (default 49,57,76,836,2056;\n"
          "./afm bench bus passes the sizes of the messages in a run's log)"},
         set_sizes},
        {{"--count", "N", "options:", "pings a size (default 2000, at least 10)"},
         afm::cli::whole(&Options::count, 10, std::numeric_limits<long long>::max(), "a number of pings")},
        {{"--receive", "tap|liblcm", "options:",
          "how both ends receive: tap (the default) as the bench's processes do,\n"
          "a filtered socket read on their own thread; liblcm through its\n"
          "receive thread"},
         afm::cli::choice(&Options::receive, {"tap", "liblcm"})},
        {{"--json", "FILE", "options:", "the rows as JSON to FILE too"}, afm::cli::text(&Options::json_path)},
    }};

void print_rows(const std::vector<Row> &rows)
{
    std::printf("%8s %8s %12s %12s %12s %12s\n", "bytes", "answered", "one-way med", "one-way p99", "round med", "round p99");
    for (const Row &r : rows)
        std::printf("%8d %4d/%-4d %9.1f us %9.1f us %9.1f us %9.1f us\n", r.bytes, r.answered, r.sent, r.one_way.median_us,
                    r.one_way.p99_us, r.round_trip.median_us, r.round_trip.p99_us);
}

nlohmann::json rows_json(const std::vector<Row> &rows)
{
    nlohmann::json out = nlohmann::json::array();
    for (const Row &r : rows)
        out.push_back({{"bytes", r.bytes}, {"sent", r.sent}, {"answered", r.answered}, {"one_way_median_us", r.one_way.median_us},
                       {"one_way_p99_us", r.one_way.p99_us}, {"round_trip_median_us", r.round_trip.median_us},
                       {"round_trip_p99_us", r.round_trip.p99_us}});
    return out;
}

}  // namespace

int main(int argc, char **argv)
{
    Options o;
    if (const int code = afm::cli::read_command_line(kCommandLine, argc, argv, &o); code >= 0) return code;
    g_tap = o.receive == "tap";
    return afm::run_process("bench_bus", [&] {
        auto lc = afm::open_bus();   // refuses a bus not confined to loopback
        const pid_t kid = fork();
        if (kid < 0) throw std::runtime_error("fork failed");
        if (kid == 0) echo();
        std::unique_ptr<afm::BusTap> tap;
        if (g_tap) {
            tap = std::make_unique<afm::BusTap>(afm::bus_url());
            tap->accept_only({kPong});
        }
        std::vector<Row> rows;
        for (int b : o.sizes) rows.push_back(measure(*lc, tap.get(), b, o.count));
        kill(kid, SIGTERM);
        waitpid(kid, nullptr, 0);
        print_rows(rows);
        if (!o.json_path.empty()) afm::write_report(o.json_path, rows_json(rows));
        return static_cast<int>(afm::kExitOk);
    });
}
