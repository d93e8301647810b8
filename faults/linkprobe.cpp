// afm_linkprobe: measures the link between a run's two hosts (docs/hosts.md)
// by LCM round trips across it, before the run starts (run/two_hosts.sh).
//
//   afm_linkprobe --echo --json FILE          in the "afm" namespace: answers
//                                             every LINK_PING with a LINK_PONG
//                                             of the same size until SIGTERM,
//                                             then writes how many it received
//   afm_linkprobe --ping N [--interval-us US] [--sizes B,B...] [--wait-ms MS]
//                 --echoed FILE --json FILE   in the "host" namespace
//
// Both ends use LCM's udpm on the bus's group with ttl=1 but their own port
// (kProbePort, not the bus's): the run's processes never see a probe. Each
// ping carries its send time; the echo puts its receive and send times in
// its answer. The two namespaces share the machine's CLOCK_MONOTONIC, so
// both one-way delays are measured, not halved round trips. Loss is counted
// in messages per direction: a message larger than the link's MTU travels as
// IP fragments, and a fragment lost loses it whole (afm_netfault counts the
// datagrams). Every --sizes entry is sent in turn; by default a small one
// and one of three fragments.
//
// The JSON of --ping: {"to_afm": {...}, "to_host": {...}, "round_trip":
// {...}, "by_size": {...}}, each direction with best_us, median_us, p99_us, worst_us,
// messages_sent, messages_received, message_loss. Exit 0; 2 on a usage
// error; 1 when the link carries nothing (no ping answered).
#include <lcm/lcm-cpp.hpp>

#include <poll.h>
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bus.hpp"
#include "command_line.hpp"

namespace {

constexpr int kProbePort = 7668;   // the bus's port + 1: the run never subscribes to it
const std::string kProbeUrl = "udpm://" + std::string(afm::kBusGroup) + ":" + std::to_string(kProbePort) + "?ttl=1&recv_buf_size=4194304";

const char *kUsage =
    "usage: afm_linkprobe --echo --json FILE\n"
    "       afm_linkprobe --ping N [--interval-us US] [--sizes B,B,...] [--wait-ms MS] --echoed FILE --json FILE\n"
    "  LCM round trips across the link of two hosts (docs/hosts.md): --echo in the\n"
    "  afm namespace answers until SIGTERM and writes what it received to FILE;\n"
    "  --ping sends N pings of the given sizes (default 64,4000 bytes) every US\n"
    "  (default 1000; 0: each once the last is answered, ping-pong), waits MS (default 300) for the last answers, reads the echo's\n"
    "  count from --echoed and writes the one-way delays and message losses.\n";

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

int64_t now_ns()
{
    timespec t{};
    clock_gettime(CLOCK_MONOTONIC, &t);
    return static_cast<int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
}

// A probe message: seq, the ping's send time, the echo's receive and send times (ns), padding.
struct Stamp {
    int64_t seq = 0, sent = 0, echo_received = 0, echo_sent = 0;
};
constexpr std::size_t kStampBytes = sizeof(Stamp);

// Best, median, p99 and worst of `us` (null when empty).
nlohmann::json summary(std::vector<double> us)
{
    if (us.empty()) return {{"best_us", nullptr}, {"median_us", nullptr}, {"p99_us", nullptr}, {"worst_us", nullptr}};
    std::sort(us.begin(), us.end());
    auto at = [&](double q) { return us[std::min(us.size() - 1, static_cast<std::size_t>(q * static_cast<double>(us.size())))]; };
    return {{"best_us", us.front()}, {"median_us", at(0.5)}, {"p99_us", at(0.99)}, {"worst_us", us.back()}};
}

bool stays_in_run()
{
    std::string why;
    if (afm::multicast_stays_in_run(&why)) return true;
    std::fprintf(stderr, "afm_linkprobe: refusing to probe: %s\n", why.c_str());
    return false;
}

int echo(const std::string &json_path)
{
    lcm::LCM lc(kProbeUrl);
    if (!lc.good()) return std::fprintf(stderr, "afm_linkprobe: cannot open %s\n", kProbeUrl.c_str()), 1;
    int64_t received = 0;
    std::map<int64_t, int64_t> by_size;
    struct Handler {
        lcm::LCM *lc;
        int64_t *received;
        std::map<int64_t, int64_t> *by_size;
        void on(const lcm::ReceiveBuffer *rb, const std::string &)
        {
            if (rb->data_size < kStampBytes) return;
            std::vector<unsigned char> msg(static_cast<const unsigned char *>(rb->data),
                                           static_cast<const unsigned char *>(rb->data) + rb->data_size);
            Stamp s;
            std::memcpy(&s, msg.data(), kStampBytes);
            s.echo_received = now_ns();
            ++*received;
            ++(*by_size)[static_cast<int64_t>(rb->data_size)];
            s.echo_sent = now_ns();
            std::memcpy(msg.data(), &s, kStampBytes);
            lc->publish("LINK_PONG", msg.data(), static_cast<unsigned>(msg.size()));
        }
    } h{&lc, &received, &by_size};
    lc.subscribe("LINK_PING", &Handler::on, &h);
    // LINK_DONE: the pinger has sent all and waited for the last answers (or SIGTERM)
    struct Done {
        bool seen = false;
        void on(const lcm::ReceiveBuffer *, const std::string &) { seen = true; }
    } done;
    lc.subscribe("LINK_DONE", &Done::on, &done);
    std::fprintf(stderr, "afm_linkprobe: echo ready\n");
    while (!g_stop && !done.seen) lc.handleTimeout(50);
    nlohmann::json j = {{"received", received}, {"received_by_size", nlohmann::json::object()}};
    for (const auto &[b, n] : by_size) j["received_by_size"][std::to_string(b)] = n;
    {
        std::ofstream(json_path + ".part") << j.dump(1) << "\n";
    }
    return std::rename((json_path + ".part").c_str(), json_path.c_str()) == 0 ? 0 : 1;   // whole, or not at all
}

struct PingOptions {
    bool echo = false;   // --echo: the echo's side, not the pinger's
    int count = 0, interval_us = 1000, wait_ms = 300;
    std::vector<int> sizes = {64, 4000};
    std::string echoed, json;
};

// One direction's figures: the delays of the messages that came, and the messages lost.
nlohmann::json direction(const std::vector<double> &us, int64_t sent, int64_t received)
{
    nlohmann::json j = summary(us);
    j["messages_sent"] = sent;
    j["messages_received"] = received;
    j["message_loss"] = sent > 0 ? static_cast<double>(sent - received) / static_cast<double>(sent) : 0.0;
    return j;
}

// The figures of --ping into o.json, from the answers and the echo's count.
int write_ping(const PingOptions &o, const std::map<int64_t, Stamp> &back, const std::map<int64_t, int64_t> &back_at)
{
    int64_t echoed = -1;
    std::ifstream ef(o.echoed);
    const nlohmann::json e = nlohmann::json::parse(ef, nullptr, false);
    if (!e.is_discarded() && e.contains("received")) echoed = e["received"].get<int64_t>();
    std::vector<double> there, home, rtt;
    std::map<int, std::vector<double>> rtt_by, there_by, home_by;
    std::map<int, int64_t> sent_by, back_by;
    for (int k = 0; k < o.count; ++k) ++sent_by[o.sizes[k % o.sizes.size()]];
    for (const auto &[seq, s] : back) {
        const int64_t at = back_at.at(seq);
        there.push_back((s.echo_received - s.sent) * 1e-3);
        home.push_back((at - s.echo_sent) * 1e-3);
        rtt.push_back((at - s.sent) * 1e-3);
        const int size = o.sizes[static_cast<std::size_t>(seq) % o.sizes.size()];
        rtt_by[size].push_back((at - s.sent) * 1e-3);
        there_by[size].push_back((s.echo_received - s.sent) * 1e-3);
        home_by[size].push_back((at - s.echo_sent) * 1e-3);
        ++back_by[size];
    }
    const int64_t answered = static_cast<int64_t>(back.size());
    nlohmann::json j;
    j["probe_url"] = kProbeUrl;
    j["pings"] = o.count;
    j["interval_us"] = o.interval_us;
    j["sizes"] = o.sizes;
    // to the afm host: the pings the echo received (its count; -1 unread: then only the answered ones are known)
    j["to_afm"] = direction(there, o.count, echoed >= 0 ? echoed : answered);
    j["to_host"] = direction(home, echoed >= 0 ? echoed : answered, answered);
    j["round_trip"] = direction(rtt, o.count, answered);
    j["echo_count_read"] = echoed >= 0;
    for (const auto &[size, n] : sent_by)   // each size's one-way delays (of the answered pings) and round trips
        j["by_size"][std::to_string(size)] = {{"round_trip", direction(rtt_by[size], n, back_by[size])},
                                              {"to_afm", summary(there_by[size])}, {"to_host", summary(home_by[size])}};
    std::ofstream out(o.json);
    out << j.dump(1) << "\n";
    if (!out) return std::fprintf(stderr, "afm_linkprobe: cannot write %s\n", o.json.c_str()), 1;
    if (answered == 0) return std::fprintf(stderr, "afm_linkprobe: no ping of %d answered across the link\n", o.count), 1;
    return 0;
}

int ping(const PingOptions &o)
{
    if (!stays_in_run()) return 1;
    lcm::LCM lc(kProbeUrl);
    if (!lc.good()) return std::fprintf(stderr, "afm_linkprobe: cannot open %s\n", kProbeUrl.c_str()), 1;
    std::map<int64_t, Stamp> back;   // seq -> the answer's stamps
    std::map<int64_t, int64_t> back_at;   // seq -> when the answer came
    struct Handler {
        std::map<int64_t, Stamp> *back;
        std::map<int64_t, int64_t> *back_at;
        void on(const lcm::ReceiveBuffer *rb, const std::string &)
        {
            if (rb->data_size < kStampBytes) return;
            Stamp s;
            std::memcpy(&s, rb->data, kStampBytes);
            if (back->count(s.seq)) return;   // a duplicate
            (*back)[s.seq] = s;
            (*back_at)[s.seq] = now_ns();
        }
    } h{&back, &back_at};
    lc.subscribe("LINK_PONG", &Handler::on, &h);
    const int64_t t0 = now_ns();
    for (int k = 0; k < o.count && !g_stop; ++k) {
        std::vector<unsigned char> msg(std::max<std::size_t>(static_cast<std::size_t>(o.sizes[k % o.sizes.size()]), kStampBytes));
        Stamp s;
        s.seq = k;
        s.sent = now_ns();
        std::memcpy(msg.data(), &s, kStampBytes);
        lc.publish("LINK_PING", msg.data(), static_cast<unsigned>(msg.size()));
        // --interval-us 0: ping-pong, the next once this one is answered (20 ms at most), as the lockstep goes
        const int64_t next = o.interval_us > 0 ? t0 + static_cast<int64_t>(k + 1) * o.interval_us * 1000 : now_ns() + 20000000;
        for (int64_t left = next - now_ns(); left > 0 && !(o.interval_us == 0 && back.count(k)); left = next - now_ns()) {
            pollfd p{lc.getFileno(), POLLIN, 0};
            const timespec ts{static_cast<time_t>(left / 1000000000), static_cast<long>(left % 1000000000)};
            if (ppoll(&p, 1, &ts, nullptr) > 0) lc.handle();
        }
    }
    const int64_t end = now_ns() + static_cast<int64_t>(o.wait_ms) * 1000000;
    while (now_ns() < end && static_cast<int>(back.size()) < o.count) lc.handleTimeout(10);
    // the echo writes its count on LINK_DONE (sent five times: not on the lossy channels); 1 s at most for it
    std::remove(o.echoed.c_str());
    for (int k = 0; k < 5; ++k) lc.publish("LINK_DONE", "done", 4);
    for (int k = 0; k < 100 && !std::ifstream(o.echoed); ++k) lc.handleTimeout(10);
    lc.handleTimeout(20);   // the file closed
    return write_ping(o, back, back_at);
}

constexpr long long kMost = 100000000;

// --sizes B,B,...: payload sizes, each a positive integer.
std::string set_sizes(const std::string &v, PingOptions *o)
{
    std::vector<int> sizes;
    std::stringstream ss(v);
    std::string b;
    long long x = 0;
    while (std::getline(ss, b, ',')) {
        if (!afm::cli::read_whole(b, 1, kMost, &x).empty()) return "wants sizes in bytes, positive integers, comma-separated";
        sizes.push_back(static_cast<int>(x));
    }
    if (sizes.empty()) return "wants sizes in bytes, positive integers, comma-separated";
    o->sizes = sizes;
    return "";
}

// The usage's head names every option (kUsage); the table checks them.
const afm::cli::CommandLine<PingOptions> kCommandLine = {
    "afm_linkprobe",
    kUsage,
    {
        {{"--echo", nullptr, nullptr, nullptr}, afm::cli::flag(&PingOptions::echo)},
        {{"--json", "FILE", nullptr, nullptr, true}, afm::cli::text(&PingOptions::json)},
        {{"--ping", "N", nullptr, nullptr}, afm::cli::whole(&PingOptions::count, 1, kMost, "a positive integer")},
        {{"--interval-us", "US", nullptr, nullptr}, afm::cli::whole(&PingOptions::interval_us, 0, kMost, "an integer")},
        {{"--sizes", "B,B,...", nullptr, nullptr}, set_sizes},
        {{"--wait-ms", "MS", nullptr, nullptr}, afm::cli::whole(&PingOptions::wait_ms, 1, kMost, "a positive integer")},
        {{"--echoed", "FILE", nullptr, nullptr}, afm::cli::text(&PingOptions::echoed)},
    },
    [](const PingOptions &o) {
        return o.echo == (o.count > 0) || (!o.echo && o.echoed.empty())
                   ? std::string("--echo: or --ping N with --echoed FILE, one of them (afm_linkprobe --help: the usage)")
                   : std::string();
    }};

}  // namespace

int main(int argc, char **argv)
{
    PingOptions o;
    if (const int code = afm::cli::read_command_line(kCommandLine, argc, argv, &o); code >= 0) return code;
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
    if (o.echo) return stays_in_run() ? echo(o.json) : 1;
    return ping(o);
}
