#include "bus.hpp"

#include <arpa/inet.h>
#include <linux/ethtool.h>
#include <linux/sockios.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "bus_key.hpp"

namespace afm {

int publish_raw(lcm::LCM &lc, const std::string &channel, const void *data, std::size_t size)
{
    const BusKey *key = run_key();
    if (!key) return lc.publish(channel, data, static_cast<unsigned>(size));
    // one counter for the process: increasing on each of its sockets (a
    // receiver keeps a window per sender and channel: bus_key.hpp)
    static std::atomic<uint64_t> seq{0};
    // the thread's own buffer, kept between messages: no allocation a message
    thread_local std::vector<unsigned char> msg;
    msg.assign(static_cast<const unsigned char *>(data), static_cast<const unsigned char *>(data) + size);
    key->sign(channel, ++seq, &msg);
    return lc.publish(channel, msg.data(), static_cast<unsigned>(msg.size()));
}

namespace {

// The interface that carries an unbound send to the bus's group: the most
// specific route of /proc/net/route that covers it, the lowest metric among
// equals (as the kernel picks); "" when none does.
std::string multicast_route_interface(std::string *why)
{
    // /proc/net/route: Iface Destination Gateway Flags RefCnt Use Metric Mask ...
    // (addresses little-endian hex)
    std::ifstream f("/proc/net/route");
    if (!f) {
        if (why) *why = "cannot read /proc/net/route";
        return "";
    }
    in_addr group{};
    inet_pton(AF_INET, kBusGroup, &group);
    const uint32_t g = group.s_addr;
    std::string line, best_if;
    int best_len = -1;
    long best_metric = 0;
    std::getline(f, line);  // header
    while (std::getline(f, line)) {
        std::istringstream in(line);
        std::string iface, dst_hex, gw_hex, flags, ref, use, mask_hex;
        long metric = 0;
        if (!(in >> iface >> dst_hex >> gw_hex >> flags >> ref >> use >> metric >> mask_hex)) continue;
        const uint32_t dst = static_cast<uint32_t>(std::stoul(dst_hex, nullptr, 16));
        const uint32_t mask = static_cast<uint32_t>(std::stoul(mask_hex, nullptr, 16));
        if ((g & mask) != dst) continue;
        const int len = __builtin_popcount(mask);
        if (len > best_len || (len == best_len && metric < best_metric)) {
            best_len = len;
            best_metric = metric;
            best_if = iface;
        }
    }
    if (best_len < 0 && why) *why = "no route to the multicast group " + std::string(kBusGroup);
    return best_if;
}

}  // namespace

std::vector<std::string> namespace_interfaces()
{
    // /proc/net/dev: two header lines, then "  NAME: counters..."
    std::vector<std::string> out;
    std::ifstream f("/proc/net/dev");
    std::string line;
    for (int skip = 0; skip < 2 && std::getline(f, line); ++skip) {}
    while (std::getline(f, line)) {
        const auto colon = line.find(':');
        if (colon == std::string::npos) continue;
        std::istringstream name(line.substr(0, colon));
        std::string n;
        if (name >> n) out.push_back(n);
    }
    return out;
}

bool is_veth(const std::string &iface)
{
    const int fd = socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) return false;
    ethtool_drvinfo info{};
    info.cmd = ETHTOOL_GDRVINFO;
    ifreq req{};
    std::snprintf(req.ifr_name, sizeof req.ifr_name, "%s", iface.c_str());
    req.ifr_data = reinterpret_cast<char *>(&info);
    const bool ok = ioctl(fd, SIOCETHTOOL, &req) == 0 && std::string(info.driver) == "veth";
    close(fd);
    return ok;
}

bool multicast_stays_in_run(std::string *why, std::string *via)
{
    const std::string iface = multicast_route_interface(why);
    if (via) *via = iface;
    if (iface.empty()) return false;
    if (iface == "lo") return true;
    const char *link = std::getenv(kBusLinkEnv);
    if (!link || iface != link) {
        if (why) *why = "multicast to " + std::string(kBusGroup) + " would leave through '" + iface +
                        "' (run inside the run's network namespace: ./afm run)";
        return false;
    }
    // two hosts: the group goes through the link, which must join the run's two namespaces and nothing else
    if (!is_veth(iface)) {
        if (why) *why = std::string(kBusLinkEnv) + "=" + iface + " names no veth end: multicast to " + kBusGroup + " would leave through it";
        return false;
    }
    for (const auto &other : namespace_interfaces())
        if (other != "lo" && other != iface) {
            if (why) *why = "the namespace of the link " + iface + " also holds '" + other + "': the bus could leave through it";
            return false;
        }
    return true;
}

std::string bus_url()
{
    const char *env = std::getenv("LCM_DEFAULT_URL");
    return env && *env ? env : kBusUrl;
}

std::unique_ptr<lcm::LCM> open_bus()
{
    const std::string url = bus_url();
    if (url.rfind("udpm://", 0) == 0 || url.find("://") == std::string::npos) {
        std::string why;
        std::string via;
        if (!multicast_stays_in_run(&why, &via)) throw std::runtime_error("refusing to open the bus " + url + ": " + why);
        const bool linked = via != "lo";   // two hosts: one hop across the link
        if (url.find("ttl=0") == std::string::npos && !(linked && url.find("ttl=1") != std::string::npos))
            throw std::runtime_error("refusing to open the bus " + url + ": udpm URLs must carry ttl=0" +
                                     (linked ? std::string(" (or ttl=1 across the link ") + via + ")" : std::string()));
    }
    auto lc = std::make_unique<lcm::LCM>(url);
    if (!lc->good()) throw std::runtime_error("cannot open the LCM bus " + url);
    return lc;
}

int64_t wall_utime()
{
    using namespace std::chrono;
    return duration_cast<microseconds>(system_clock::now().time_since_epoch()).count();
}

Heartbeat::Heartbeat(lcm::LCM &lc, std::string name) : lc_(lc), name_(std::move(name)) {}

void Heartbeat::send(RunState state, int64_t seq, int64_t sim_utime, const std::string &detail)
{
    heartbeat_t hb;
    hb.utime = wall_utime();
    hb.name = name_;
    hb.pid = static_cast<int32_t>(getpid());
    hb.state = state_text(state);
    hb.seq = seq;
    hb.sim_utime = sim_utime;
    hb.detail = detail;
    publish(lc_, AFM_CH_AFM_HEARTBEAT, hb);
    last_state_ = state;
    sent_ = true;
    last_us_ = hb.utime;
}

void Heartbeat::maybe_send(RunState state, int64_t seq, int64_t sim_utime, int64_t period_us)
{
    if (state == RunState::ready) period_us = kReadyPeriodUs;
    if (!sent_ || state != last_state_ || wall_utime() - last_us_ >= period_us) send(state, seq, sim_utime);
}

}  // namespace afm
