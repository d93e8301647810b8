#include "bus.hpp"

#include <arpa/inet.h>
#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace afm {

bool multicast_routed_on_loopback(std::string *why)
{
    // /proc/net/route: Iface Destination Gateway Flags RefCnt Use Metric Mask ...
    // (addresses little-endian hex). Pick the most specific route that covers
    // the group, as the kernel would for an unbound multicast send.
    std::ifstream f("/proc/net/route");
    if (!f) {
        if (why) *why = "cannot read /proc/net/route";
        return false;
    }
    in_addr group{};
    inet_pton(AF_INET, kBusGroup, &group);
    const uint32_t g = group.s_addr;
    std::string line, best_if;
    int best_len = -1;
    std::getline(f, line);  // header
    while (std::getline(f, line)) {
        std::istringstream in(line);
        std::string iface, dst_hex, gw_hex, flags, ref, use, metric, mask_hex;
        if (!(in >> iface >> dst_hex >> gw_hex >> flags >> ref >> use >> metric >> mask_hex)) continue;
        const uint32_t dst = static_cast<uint32_t>(std::stoul(dst_hex, nullptr, 16));
        const uint32_t mask = static_cast<uint32_t>(std::stoul(mask_hex, nullptr, 16));
        if ((g & mask) != dst) continue;
        const int len = __builtin_popcount(mask);
        if (len > best_len) {
            best_len = len;
            best_if = iface;
        }
    }
    if (best_len < 0) {
        if (why) *why = "no route to the multicast group " + std::string(kBusGroup);
        return false;
    }
    if (best_if != "lo") {
        if (why) *why = "multicast to " + std::string(kBusGroup) + " would leave through '" + best_if +
                        "' (run inside the run's network namespace: ./afm run)";
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
        if (!multicast_routed_on_loopback(&why)) throw std::runtime_error("refusing to open the bus " + url + ": " + why);
        if (url.find("ttl=0") == std::string::npos)
            throw std::runtime_error("refusing to open the bus " + url + ": udpm URLs must carry ttl=0");
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
    lc_.publish(AFM_CH_AFM_HEARTBEAT, &hb);
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
