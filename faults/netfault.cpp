// afm_netfault: drops, duplicates and reorders the bus's datagrams in the
// kernel, for the fault matrix's net:kernel row (faults/faults.py). It stands
// where tc netem would (this project's machines run kernels without
// sch_netem): an iptables rule in the run's namespace hands every UDP
// datagram to the bus's port to netfilter queue N, and this process gives
// each its verdict:
//   drop       NF_DROP, only for a datagram on one of --drop-channels (the
//              lockstep's channels, whose loss the simulator's resend repairs;
//              a lost display message has no resend, docs/faults.md)
//   duplicate  NF_ACCEPT, then the same IP packet sent again through a raw
//              socket marked --mark (the rule lets marked packets pass)
//   reorder    held without a verdict until the next datagram has been
//              accepted, or --hold-us has passed, whichever comes first
// Everything else is accepted at once, in order. It runs until SIGTERM or
// SIGINT, then writes --report (JSON: counts, per channel) and exits 0.
//
// The link of two hosts (docs/hosts.md, run/two_hosts.sh) runs one in each
// of the run's two namespaces, on what arrives through the veth end from the
// other (--link-in IFACE --peer ADDR): one direction each. There it also
//   delays     holds every datagram for --delay-us, plus a uniform draw in
//              [-jitter, +jitter] (--jitter-us), then accepts it: a later
//              datagram with a shorter draw passes an earlier one (reordering,
//              as netem's jitter does); a --reorder draw adds --hold-us
//   drops      per IP packet: a fragment of a message larger than the link's
//              MTU is dropped alone (the receiver then loses the whole
//              message); a later fragment's channel is its first fragment's
//              (by IP id and source)
//   duplicates through a raw socket bound to lo (--dup-dev lo): the copy is
//              delivered in this namespace and never crosses back
//
//   afm_netfault --queue N [--drop P] [--dup P] [--reorder P] [--hold-us US]
//                [--drop-channels A,B,...] [--mark M] [--seed S] [--iptables]
//                [--link-in IFACE --peer ADDR] [--delay-us US] [--jitter-us US]
//                [--dup-dev DEV] [--while-pid PID] --report FILE
//
// Inside the run's namespace (run/in_netns.sh), before the run. With
// --iptables it adds, once its queue is open, the two rules that feed it
// (the bus's port from afm::kBusUrl):
//   iptables -t mangle -A OUTPUT -m mark --mark M -j ACCEPT
//   iptables -t mangle -A OUTPUT -p udp --dport PORT -j NFQUEUE --queue-num N
// (with --link-in, the one rule
//   iptables -t mangle -A PREROUTING -i IFACE -s ADDR -j NFQUEUE --queue-num N
// instead) and prints "ready" on stderr; a datagram queued with no reader would be
// dropped. Needs CAP_NET_ADMIN and CAP_NET_RAW in the namespace, which
// unshare -rn gives.
//
// The channel of a datagram is read from LCM's UDP multicast header by the
// bench's one reader of it (bus_filter.hpp, lcm_datagram_channel); a
// datagram it cannot read is counted as "unknown" and never dropped.
#include <netinet/in.h>   // before the netfilter headers (glibc's, then the kernel's, in that order)
#include <netinet/ip.h>
#include <libnetfilter_queue/libnetfilter_queue.h>
#include <linux/netfilter.h>
#include <poll.h>
#include <sys/prctl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <sys/socket.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <iterator>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bus.hpp"
#include "bus_filter.hpp"
#include "command_line.hpp"

extern char **environ;

namespace {

const char *kUsage =
    "usage: afm_netfault --queue N --report FILE [--drop P] [--dup P] [--reorder P]\n"
    "                    [--hold-us US] [--drop-channels A,B,...] [--mark M] [--seed S]\n"
    "                    [--iptables]\n"
    "  Gives a verdict to every datagram on netfilter queue N: drops one on a\n"
    "  --drop-channels channel with probability P, sends one again with probability\n"
    "  P (--dup, through a raw socket with SO_MARK M, default 1), holds one back\n"
    "  behind the next (at most --hold-us, default 1000) with probability P\n"
    "  (--reorder). Runs until SIGTERM or SIGINT, then writes the counts to FILE.\n"
    "  Inside the run's namespace, behind an iptables NFQUEUE rule on the bus's\n"
    "  port, which --iptables adds (faults/faults.py, row net:kernel).\n"
    "  The link of two hosts (run/two_hosts.sh, docs/hosts.md): --link-in IFACE\n"
    "  --peer ADDR queues what arrives through IFACE from ADDR instead (--iptables adds\n"
    "  that rule); --delay-us and --jitter-us hold each datagram that long (uniform\n"
    "  jitter); --dup-dev lo sends duplicates through lo, in this namespace;\n"
    "  --while-pid PID ends it (its report written) once PID has ended.\n";

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct Options {
    int queue = -1;
    double drop = 0, dup = 0, reorder = 0;
    int hold_us = 1000;
    std::set<std::string> drop_channels;
    uint32_t mark = 1;
    uint64_t seed = 1;
    std::string report;
    bool iptables = false;
    std::string link_in, peer;   // the link of two hosts: what arrives through link_in from peer
    int delay_us = 0, jitter_us = 0;
    std::string dup_dev;         // SO_BINDTODEVICE of the duplicates' raw socket ("" : none)
    int while_pid = -1;          // ends (writing its report) once this process has ended, as on SIGTERM
    bool delaying() const { return delay_us > 0 || jitter_us > 0; }
};

// Runs iptables -t mangle -A CHAIN with `args`; "" or what failed.
std::string iptables(const std::vector<std::string> &args, const std::string &chain = "OUTPUT")
{
    std::vector<char *> argv;
    std::vector<std::string> all = {"iptables", "-t", "mangle", "-A", chain};
    all.insert(all.end(), args.begin(), args.end());
    for (auto &a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid;
    if (posix_spawnp(&pid, "iptables", nullptr, nullptr, argv.data(), environ) != 0)
        return "cannot start iptables (Debian's iptables; ./afm setup installs it)";
    int st = 0;
    waitpid(pid, &st, 0);
    std::string cmd;
    for (auto &a : all) cmd += (cmd.empty() ? "" : " ") + a;
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) return "'" + cmd + "' failed (its error above)";
    return "";
}

// The rules that feed queue `o.queue` with the bus's datagrams, marked ones excepted.
std::string add_rules(const Options &o)
{
    if (!o.link_in.empty())   // one direction of the link: what arrives from the peer (fragments too: no port to match)
        return iptables({"-i", o.link_in, "-s", o.peer, "-j", "NFQUEUE", "--queue-num", std::to_string(o.queue)}, "PREROUTING");
    std::string e = iptables({"-m", "mark", "--mark", std::to_string(o.mark), "-j", "ACCEPT"});
    if (e.empty())
        e = iptables({"-p", "udp", "--dport", std::to_string(afm::kBusPort), "-j", "NFQUEUE", "--queue-num", std::to_string(o.queue)});
    return e;
}

struct Counts {
    int64_t seen = 0, dropped = 0, duplicated = 0, reordered = 0, released_by_time = 0, dup_failed = 0;
    int64_t fragments = 0, delayed = 0, passed = 0;   // IP fragments seen; held for the delay; released before one held earlier
    std::vector<double> held_us;                       // how long each delayed datagram was held, achieved
    std::map<std::string, int64_t> seen_by, dropped_by;
};

// The LCM channel of an IPv4 UDP packet (bus_filter.hpp reads LCM's
// header), or "unknown".
std::string channel_of(const unsigned char *pkt, int len)
{
    if (len < 20 || (pkt[0] >> 4) != 4) return "unknown";
    const int ihl = (pkt[0] & 0x0f) * 4;
    if (ihl < 20 || pkt[9] != IPPROTO_UDP || len < ihl + 8) return "unknown";
    const std::string ch = afm::lcm_datagram_channel(pkt + ihl + 8, static_cast<std::size_t>(len - ihl - 8));
    return ch.empty() ? "unknown" : ch;
}

class Fault {
public:
    Fault(const Options &o) : o_(o), rng_(o.seed) {}
    ~Fault()
    {
        if (qh_) nfq_destroy_queue(qh_);
        if (h_) nfq_close(h_);
        if (raw_ >= 0) close(raw_);
    }

    // Opens the queue and the raw socket; an error names what failed.
    std::string open()
    {
        h_ = nfq_open();
        if (!h_) return std::string("nfq_open: ") + std::strerror(errno) + " (needs CAP_NET_ADMIN in the namespace)";
        if (nfq_bind_pf(h_, AF_INET) < 0) return std::string("nfq_bind_pf: ") + std::strerror(errno);
        qh_ = nfq_create_queue(h_, static_cast<uint16_t>(o_.queue), &Fault::on_packet, this);
        if (!qh_) return "nfq_create_queue " + std::to_string(o_.queue) + ": " + std::strerror(errno) + " (another process holds it?)";
        if (nfq_set_mode(qh_, NFQNL_COPY_PACKET, 0xffff) < 0) return std::string("nfq_set_mode: ") + std::strerror(errno);
        nfq_set_queue_maxlen(qh_, 4096);
        const int one = 1;
        setsockopt(nfq_fd(h_), SOL_NETLINK, NETLINK_NO_ENOBUFS, &one, sizeof one);
        raw_ = socket(AF_INET, SOCK_RAW, IPPROTO_RAW);
        if (raw_ < 0) return std::string("raw socket: ") + std::strerror(errno) + " (needs CAP_NET_RAW)";
        if (setsockopt(raw_, SOL_SOCKET, SO_MARK, &o_.mark, sizeof o_.mark) < 0) return std::string("SO_MARK: ") + std::strerror(errno);
        if (!o_.dup_dev.empty() &&
            setsockopt(raw_, SOL_SOCKET, SO_BINDTODEVICE, o_.dup_dev.c_str(), static_cast<socklen_t>(o_.dup_dev.size())) < 0)
            return "SO_BINDTODEVICE " + o_.dup_dev + ": " + std::strerror(errno);
        return "";
    }

    // Until a signal: verdicts, and a held datagram released on time.
    void run()
    {
        alignas(8) static char buf[0x10000 + 4096];
        const int fd = nfq_fd(h_);
        while (!g_stop && !watched_gone()) {
            int64_t timeout_us = 100000;
            if (!delayed_.empty()) {
                const auto left = std::chrono::duration_cast<std::chrono::microseconds>(delayed_.begin()->first - clock::now()).count();
                if (left <= 0) {
                    release_due();
                    continue;
                }
                timeout_us = std::min<int64_t>(timeout_us, left);
            }
            if (held_) {
                const auto left = std::chrono::duration_cast<std::chrono::microseconds>(held_until_ - clock::now()).count();
                if (left <= 0) {
                    release(true);
                    continue;
                }
                timeout_us = std::min<int64_t>(timeout_us, left);
            }
            // to the microsecond: a link's delay of 0.2 ms must not wait a whole millisecond
            pollfd p{fd, POLLIN, 0};
            const timespec ts{static_cast<time_t>(timeout_us / 1000000), static_cast<long>(timeout_us % 1000000) * 1000};
            const int r = ppoll(&p, 1, &ts, nullptr);
            if (r < 0 && errno != EINTR) break;
            if (r <= 0) continue;
            const ssize_t n = recv(fd, buf, sizeof buf, 0);
            if (n > 0) nfq_handle_packet(h_, buf, static_cast<int>(n));
        }
        if (held_) release(false);
        while (!delayed_.empty()) release_due(true);
    }

    nlohmann::json report() const
    {
        return {{"seen", c_.seen},
                {"fragments", c_.fragments},
                {"delayed", c_.delayed},
                {"passed_earlier", c_.passed},
                {"held_us", held_summary()},
                {"dropped", c_.dropped},
                {"duplicated", c_.duplicated},
                {"reordered", c_.reordered},
                {"released_by_time", c_.released_by_time},
                {"duplicates_failed", c_.dup_failed},
                {"seen_by_channel", c_.seen_by},
                {"dropped_by_channel", c_.dropped_by},
                {"options",
                 {{"drop", o_.drop}, {"dup", o_.dup}, {"reorder", o_.reorder}, {"hold_us", o_.hold_us}, {"seed", o_.seed},
                  {"drop_channels", o_.drop_channels}, {"link_in", o_.link_in}, {"peer", o_.peer}, {"delay_us", o_.delay_us},
                  {"jitter_us", o_.jitter_us}}}};
    }

    // Median, p99 and worst of how long the delayed datagrams were held, us.
    nlohmann::json held_summary() const
    {
        if (c_.held_us.empty()) return nullptr;
        std::vector<double> v = c_.held_us;
        std::sort(v.begin(), v.end());
        auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
        return {{"count", v.size()}, {"median", at(0.5)}, {"p99", at(0.99)}, {"worst", v.back()}};
    }

private:
    using clock = std::chrono::steady_clock;

    static int on_packet(nfq_q_handle *, nfgenmsg *, nfq_data *nfa, void *self)
    {
        return static_cast<Fault *>(self)->verdict(nfa);
    }

    bool chance(double p) { return p > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < p; }

    // --while-pid: whether that process has ended (gone, or a zombie not yet reaped).
    bool watched_gone() const
    {
        if (o_.while_pid <= 0) return false;
        if (kill(o_.while_pid, 0) != 0 && errno == ESRCH) return true;
        // getline, not istreambuf_iterator: a read that fails as the process
        // goes (ESRCH) sets the stream's badbit instead of throwing
        std::ifstream f("/proc/" + std::to_string(o_.while_pid) + "/stat");
        std::string st;
        std::getline(f, st);
        const auto close = st.rfind(')');
        return close != std::string::npos && close + 2 < st.size() && st[close + 2] == 'Z';
    }

    // The channel of a packet; a fragment after the first takes its first
    // fragment's (by source and IP id), "unknown" if that was not seen.
    std::string channel(const unsigned char *pkt, int len)
    {
        if (len < 20) return "unknown";
        const unsigned frag = (static_cast<unsigned>(pkt[6]) << 8) | pkt[7];
        const bool more = frag & 0x2000, later = (frag & 0x1fff) != 0;
        if (!more && !later) return channel_of(pkt, len);
        ++c_.fragments;
        uint32_t src;
        std::memcpy(&src, pkt + 12, 4);
        const uint64_t key = (static_cast<uint64_t>(src) << 16) | ((static_cast<unsigned>(pkt[4]) << 8) | pkt[5]);
        if (!later) {
            if (frag_channel_.size() > 4096) frag_channel_.clear();   // bounded: ids long done
            return frag_channel_[key] = channel_of(pkt, len);
        }
        const auto it = frag_channel_.find(key);
        return it == frag_channel_.end() ? "unknown" : it->second;
    }

    int verdict(nfq_data *nfa)
    {
        const nfqnl_msg_packet_hdr *ph = nfq_get_msg_packet_hdr(nfa);
        if (!ph) return 0;
        const uint32_t id = ntohl(ph->packet_id);
        unsigned char *pkt = nullptr;
        const int len = nfq_get_payload(nfa, &pkt);
        const std::string ch = len > 0 ? channel(pkt, len) : "unknown";
        ++c_.seen;
        ++c_.seen_by[ch];
        // one decision per kind, drawn in a fixed order, so a seed replays them
        const bool drop = chance(o_.drop) && o_.drop_channels.count(ch);
        const bool dup = chance(o_.dup);
        const bool hold = chance(o_.reorder);
        if (drop) {
            ++c_.dropped;
            ++c_.dropped_by[ch];
            nfq_set_verdict(qh_, id, NF_DROP, 0, nullptr);
            return 0;
        }
        if (o_.delaying()) {   // the link's delay: held until its time, whatever came before
            const int draw = o_.jitter_us > 0 ? std::uniform_int_distribution<int>(-o_.jitter_us, o_.jitter_us)(rng_) : 0;
            const int us = std::max(0, o_.delay_us + draw) + (hold ? o_.hold_us : 0);
            const auto now = clock::now(), at = now + std::chrono::microseconds(us);
            if (!delayed_.empty() && at < std::prev(delayed_.end())->first) ++c_.passed;
            Delayed d{id, dup, now, dup ? std::string(reinterpret_cast<char *>(pkt), static_cast<std::size_t>(len)) : std::string()};
            delayed_.emplace(at, std::move(d));
            if (hold) ++c_.reordered;
            return 0;
        }
        if (hold && !held_) {
            held_ = true;
            held_id_ = id;
            held_dup_ = dup;
            if (dup) held_pkt_.assign(reinterpret_cast<char *>(pkt), static_cast<std::size_t>(len));
            held_until_ = clock::now() + std::chrono::microseconds(o_.hold_us);
            return 0;
        }
        accept(id, dup, pkt, len);
        if (held_) release(false);   // the held one after this one: reordered
        return 0;
    }

    // Accepts the delayed datagrams whose time has come (all: at the end).
    void release_due(bool all = false)
    {
        const auto now = clock::now();
        while (!delayed_.empty() && (all || delayed_.begin()->first <= now)) {
            const Delayed &d = delayed_.begin()->second;
            ++c_.delayed;
            if (c_.held_us.size() < 1000000) c_.held_us.push_back(std::chrono::duration<double, std::micro>(now - d.since).count());
            accept(d.id, d.dup, reinterpret_cast<const unsigned char *>(d.pkt.data()), static_cast<int>(d.pkt.size()));
            delayed_.erase(delayed_.begin());
        }
    }

    void accept(uint32_t id, bool dup, const unsigned char *pkt, int len)
    {
        nfq_set_verdict(qh_, id, NF_ACCEPT, 0, nullptr);
        if (!dup || len < 20) return;
        sockaddr_in to{};
        to.sin_family = AF_INET;
        std::memcpy(&to.sin_addr, pkt + 16, 4);   // the IPv4 destination
        if (sendto(raw_, pkt, static_cast<std::size_t>(len), 0, reinterpret_cast<sockaddr *>(&to), sizeof to) == len) ++c_.duplicated;
        else ++c_.dup_failed;
    }

    void release(bool by_time)
    {
        held_ = false;
        if (by_time) ++c_.released_by_time;
        else ++c_.reordered;
        accept(held_id_, held_dup_, reinterpret_cast<const unsigned char *>(held_pkt_.data()), static_cast<int>(held_pkt_.size()));
        held_pkt_.clear();
    }

    Options o_;
    std::mt19937_64 rng_;
    Counts c_;
    nfq_handle *h_ = nullptr;
    nfq_q_handle *qh_ = nullptr;
    int raw_ = -1;
    bool held_ = false, held_dup_ = false;
    uint32_t held_id_ = 0;
    std::string held_pkt_;
    clock::time_point held_until_;
    struct Delayed {
        uint32_t id;
        bool dup;
        clock::time_point since;
        std::string pkt;   // kept only to duplicate it
    };
    std::multimap<clock::time_point, Delayed> delayed_;   // by release time
    std::map<uint64_t, std::string> frag_channel_;       // (source, IP id) -> the first fragment's channel
};

// --drop-channels A,B,...: the channels, empty names skipped.
std::string set_drop_channels(const std::string &v, Options *o)
{
    std::stringstream ss(v);
    std::string c;
    while (std::getline(ss, c, ','))
        if (!c.empty()) o->drop_channels.insert(c);
    return "";
}

template <class I>
afm::cli::Setter<Options> integer(I Options::*m, long long lo, long long hi)
{
    return afm::cli::whole(m, lo, hi, "an integer");
}

afm::cli::Setter<Options> probability(double Options::*m)
{
    return afm::cli::number(m, afm::cli::in_range(0, 1), "a probability");
}

// The usage's head names every option (kUsage); the table checks them.
const afm::cli::CommandLine<Options> kCommandLine = {
    "afm_netfault",
    kUsage,
    {
        {{"--queue", "N", nullptr, nullptr, true}, integer(&Options::queue, 0, 65535)},
        {{"--report", "FILE", nullptr, nullptr, true}, afm::cli::text(&Options::report)},
        {{"--drop", "P", nullptr, nullptr}, probability(&Options::drop)},
        {{"--dup", "P", nullptr, nullptr}, probability(&Options::dup)},
        {{"--reorder", "P", nullptr, nullptr}, probability(&Options::reorder)},
        {{"--hold-us", "US", nullptr, nullptr}, integer(&Options::hold_us, 1, 1000000)},
        {{"--drop-channels", "A,B,...", nullptr, nullptr}, set_drop_channels},
        {{"--mark", "M", nullptr, nullptr}, integer(&Options::mark, 1, 0xffffffffLL)},
        {{"--seed", "S", nullptr, nullptr}, integer(&Options::seed, 0, INT64_MAX)},
        {{"--iptables", nullptr, nullptr, nullptr}, afm::cli::flag(&Options::iptables)},
        {{"--link-in", "IFACE", nullptr, nullptr}, afm::cli::text(&Options::link_in)},
        {{"--peer", "ADDR", nullptr, nullptr}, afm::cli::text(&Options::peer)},
        {{"--delay-us", "US", nullptr, nullptr}, integer(&Options::delay_us, 0, 10000000)},
        {{"--jitter-us", "US", nullptr, nullptr}, integer(&Options::jitter_us, 0, 10000000)},
        {{"--dup-dev", "IFACE", nullptr, nullptr}, afm::cli::text(&Options::dup_dev)},
        {{"--while-pid", "PID", nullptr, nullptr}, integer(&Options::while_pid, 1, 4194304)},
    },
    [](const Options &o) { return o.link_in.empty() != o.peer.empty() ? std::string("--link-in: goes with --peer") : std::string(); }};

}  // namespace

int main(int argc, char **argv)
{
    Options o;
    if (const int code = afm::cli::read_command_line(kCommandLine, argc, argv, &o); code >= 0) return code;
    struct sigaction sa{};
    sa.sa_handler = on_signal;
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
    // a held datagram's release to the microsecond: the kernel's default timer slack is 50 us
    prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);
    Fault f(o);
    const std::string err = f.open();
    if (!err.empty()) {
        std::fprintf(stderr, "afm_netfault: %s\n", err.c_str());
        return 1;
    }
    if (o.iptables) {
        const std::string e = add_rules(o);
        if (!e.empty()) {
            std::fprintf(stderr, "afm_netfault: %s\n", e.c_str());
            return 3;
        }
    }
    std::fprintf(stderr, "afm_netfault: pid %d, queue %d ready%s\n", static_cast<int>(getpid()), o.queue,
                 o.iptables ? (", fed by the bus's port " + std::to_string(afm::kBusPort)).c_str() : "");
    f.run();
    std::ofstream out(o.report);
    out << f.report().dump(2) << "\n";
    if (!out) {
        std::fprintf(stderr, "afm_netfault: cannot write %s\n", o.report.c_str());
        return 1;
    }
    return 0;
}
