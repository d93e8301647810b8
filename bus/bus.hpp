// The bus of a run: the LCM URL every process uses, the guard that keeps
// datagrams off the machine's network interfaces, and the heartbeat.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "afm/heartbeat_t.hpp"
#include "afm_channels.h"
#include "process.hpp"

namespace afm {

// udpm on loopback only: ttl=0, a 4 MB receive buffer (design.md, "The bus").
constexpr const char *kBusUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
// Two hosts (docs/hosts.md): the same group and port with ttl=1 (one hop:
// no router forwards it), across the veth pair that joins the run's two
// namespaces.
constexpr const char *kLinkBusUrl = "udpm://239.255.76.67:7667?ttl=1&recv_buf_size=4194304";
// The environment variable that names this namespace's end of that pair
// (run/two_hosts.sh sets it); unset: one namespace, the bus on loopback.
constexpr const char *kBusLinkEnv = "AFM_BUS_LINK";
constexpr const char *kBusGroup = "239.255.76.67";

// The UDP port of a udpm URL ("udpm://GROUP:PORT?..."), at compile time; -1
// for a URL without one.
constexpr int udpm_port(const char *url)
{
    int colon = -1, i = 0;
    for (; url[i] && url[i] != '?'; ++i)
        if (url[i] == ':') colon = i;
    if (colon < 0 || url[colon + 1] < '0' || url[colon + 1] > '9') return -1;
    int port = 0;
    for (int k = colon + 1; url[k] >= '0' && url[k] <= '9'; ++k) port = port * 10 + (url[k] - '0');
    return port;
}
constexpr int kBusPort = udpm_port(kBusUrl);   // 7667: where afm_netfault's rule queues datagrams
static_assert(kBusPort > 0 && kBusPort < 65536, "kBusUrl names no UDP port");
// Messages a subscription may hold before LCM drops (its default is 30, which
// a process starved of CPU for a few ms exceeds).
constexpr int kQueueCapacity = 10000;

// True when datagrams to the bus's multicast group stay inside the run: routed
// through the loopback interface (the run's private namespace), or, with
// $AFM_BUS_LINK set (two hosts), through that interface when it is a veth
// and the namespace holds no interface but it and lo (the pair joins the
// run's two namespaces and nothing else). `why` says what was found
// otherwise; `via` (if given) the interface the group is routed through.
bool multicast_stays_in_run(std::string *why, std::string *via = nullptr);

// The interfaces of this network namespace (/proc/net/dev), and whether one
// is a veth (its driver, as ethtool reports it).
std::vector<std::string> namespace_interfaces();
bool is_veth(const std::string &iface);

// The bus's URL: $LCM_DEFAULT_URL, or kBusUrl.
std::string bus_url();

// Opens the bus. A udpm URL (from $LCM_DEFAULT_URL or kBusUrl) is refused
// unless multicast_stays_in_run(), and unless it carries ttl=0 (ttl=1 when
// routed through the link of two hosts); memq:// and file:// are always allowed.
// Throws std::runtime_error with the reason.
std::unique_ptr<lcm::LCM> open_bus();

int64_t wall_utime();

// Publishes one encoded message on `channel`: the one place a process of
// the run publishes (every publish site calls this or publish()). With the
// run's key (bus_key.hpp) the message goes with its trailer (its proof);
// without one, as it is. Returns liblcm's answer (0: sent).
int publish_raw(lcm::LCM &lc, const std::string &channel, const void *data, std::size_t size);
template <class M>
int publish(lcm::LCM &lc, const std::string &channel, const M &m)
{
    thread_local std::vector<unsigned char> buf;   // kept between messages: no allocation a message
    buf.resize(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(buf.data(), 0, static_cast<int>(buf.size()));
    return publish_raw(lc, channel, buf.data(), buf.size());
}

// While a process waits for the run to start, it says "ready" this often
// (and waits for the bus no longer than that between two): the simulator
// starts the loop once it has heard every peer say so, and a peer that
// began listening after another's first "ready" hears the next within this
// period, short beside a run's start.
constexpr int64_t kReadyPeriodUs = 10000;
constexpr int kReadyPeriodMs = static_cast<int>(kReadyPeriodUs / 1000);

// Publishes AFM_HEARTBEAT for one process, in the states of process.hpp.
class Heartbeat {
public:
    Heartbeat(lcm::LCM &lc, std::string name);
    void send(RunState state, int64_t seq, int64_t sim_utime, const std::string &detail = "");
    // Sends at most once per `period_us` of wall time unless the state changed;
    // ready every kReadyPeriodUs, whatever period_us says.
    void maybe_send(RunState state, int64_t seq, int64_t sim_utime, int64_t period_us = 1000000);

private:
    lcm::LCM &lc_;
    std::string name_;
    RunState last_state_ = RunState::starting;
    bool sent_ = false;
    int64_t last_us_ = 0;
};

}  // namespace afm
