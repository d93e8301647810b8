#include "hosts.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace afm::launch {

namespace {

std::string env_or(const char *name, const std::string &fallback = "")
{
    const char *v = std::getenv(name);
    return v && *v ? v : fallback;
}

nlohmann::json read_json(const std::string &path)
{
    std::ifstream f(path);
    if (!f) return nullptr;
    nlohmann::json j = nlohmann::json::parse(f, nullptr, false);
    return j.is_discarded() ? nlohmann::json(nullptr) : j;
}

// Why the recorder sits with the card (docs/hosts.md).
constexpr const char *kRecorderWhy =
    "with the card: it records what the card received, after the link, so the replay steps the card on its own inputs; "
    "a block the link lost is resent by the simulator until the card has it, and so the record has it too";

}  // namespace

std::string Hosts::from_env(int n)
{
    count = n;
    if (n == 1) return "";
    const std::string pid = env_or("AFM_HOSTS_AFM_PID");
    if (pid.empty() || std::atoi(pid.c_str()) <= 0)
        return "--hosts 2 needs the run's two namespaces (AFM_HOSTS_AFM_PID is not set): run it with ./afm run --hosts 2, "
               "or AFM_HOSTS=2 run/in_netns.sh";
    afm_ns_pid = std::atoi(pid.c_str());
    if (access(("/proc/" + pid + "/ns/net").c_str(), R_OK) != 0)
        return "the afm namespace's holder (pid " + pid + ", AFM_HOSTS_AFM_PID) is gone";
    drop_caps = env_or("AFM_DROP_CAPS");
    if (drop_caps.empty() || access(drop_caps.c_str(), X_OK) != 0)
        return "AFM_DROP_CAPS does not name run/drop_caps.sh ('" + drop_caps + "')";
    link_dir = env_or("AFM_LINK_DIR");
    link_dir_is_temporary = env_or("AFM_LINK_DIR_TEMPORARY") == "1";
    shaper = env_or("AFM_LINK_SHAPER", "none");
    asked = env_or("AFM_LINK_ASKED");
    std::stringstream ss(env_or("AFM_LINK_SHAPERS"));
    std::string p;
    while (std::getline(ss, p, ','))
        if (std::atoi(p.c_str()) > 0) shapers.push_back(std::atoi(p.c_str()));
    return "";
}

std::string Hosts::where(const std::string &process) const
{
    if (count == 1) return "";
    return process == "sim_afm" ? "afm" : "host";
}

std::string Hosts::bus_link_env(const std::string &process) const
{
    return std::string("AFM_BUS_LINK=") + (on_afm(process) ? "vafm" : "vhost");
}

double Hosts::asked_value(const std::string &key) const
{
    std::stringstream ss(asked);
    std::string item;
    while (std::getline(ss, item, ','))
        if (item.rfind(key + "=", 0) == 0) return std::atof(item.c_str() + key.size() + 1);
    return 0;
}

int Hosts::resend_ms() const
{
    if (count == 1) return -1;
    // a round trip across the link and the card's step, with room for a loaded machine
    return std::max(10, static_cast<int>(std::ceil(4 * (asked_value("delay") + asked_value("jitter")))));
}

void Hosts::stop_shapers()
{
    for (pid_t p : shapers) kill(p, SIGTERM);
    // the host's shaper is the launcher's child (reaped here); the afm's is
    // nsenter's (gone once it has ended)
    auto ended = [](pid_t p) {
        int st = 0;
        const pid_t r = waitpid(p, &st, WNOHANG);
        return r == p || (r < 0 && kill(p, 0) != 0 && errno == ESRCH);
    };
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    for (pid_t p : shapers)
        while (!ended(p) && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    for (const char *dir : {"afm", "host"}) {
        const nlohmann::json r = read_json(link_dir + "/netfault-to-" + dir + ".json");
        if (!r.is_null()) shaper_reports["to_" + std::string(dir)] = r;
    }
    probe_ = read_json(link_dir + "/probe.json");
    std::ifstream down(link_dir + "/down.log");
    if (down) down_ = std::string((std::istreambuf_iterator<char>(down)), std::istreambuf_iterator<char>());
    if (link_dir_is_temporary) {   // two_hosts.sh made it for this run alone: all of it is in run.json now
        std::error_code ec;
        std::filesystem::remove_all(link_dir, ec);
    }
}

// The probe's figures, with the delay asked and how far from it each direction came.
nlohmann::json Hosts::achieved() const
{
    nlohmann::json probe = probe_;
    if (probe.is_null()) return {{"error", "no probe of the link (afm_linkprobe wrote no probe.json)"}};
    const double delay_us = 1000 * asked_value("delay");
    for (const char *dir : {"to_afm", "to_host"}) {
        auto &d = probe[dir];
        if (!d.is_object() || !d["median_us"].is_number()) continue;
        d["median_minus_asked_us"] = d["median_us"].get<double>() - delay_us;
        d["p99_minus_asked_us"] = d["p99_us"].get<double>() - delay_us;
    }
    probe["how"] = "LCM round trips across the link before the run (afm_linkprobe), one-way delays from the machine's shared clock";
    return probe;
}

nlohmann::json Hosts::json(const std::vector<std::string> &processes) const
{
    if (count == 1) return {{"count", 1}, {"namespaces", {{"one", {{"processes", processes}, {"interface", "lo"}}}}}};
    nlohmann::json afm = nlohmann::json::array(), host = nlohmann::json::array({"afm_launch (the record)"});
    for (const auto &p : processes) (where(p) == "afm" ? afm : host).push_back(p);
    nlohmann::json link = {{"asked", asked}, {"shaper", shaper}, {"achieved", achieved()}, {"shaper_reports", shaper_reports},
                           {"resend_ms", resend_ms()}};
    for (const char *k : {"delay", "jitter", "loss", "dup", "reorder", "rate"}) link["asked_" + std::string(k)] = asked_value(k);
    if (!down_.empty()) link["down"] = down_;
    return {{"count", 2},
            {"namespaces",
             {{"afm", {{"processes", afm}, {"interface", "vafm"}, {"address", "169.254.76.2/30"}}},
              {"host", {{"processes", host}, {"interface", "vhost"}, {"address", "169.254.76.1/30"}}}}},
            {"recorder", {{"namespace", "host"}, {"why", kRecorderWhy}}},
            {"link", link}};
}

std::string Hosts::summary() const
{
    if (count == 1) return "";
    const nlohmann::json a = achieved();
    char line[512];
    auto fig = [&](const char *dir, const char *key) {
        return a.contains(dir) && a[dir][key].is_number() ? a[dir][key].get<double>() : NAN;
    };
    std::snprintf(line, sizeof line,
                  "run: two hosts over a link (%s; shaper %s): one-way delay median %.0f / %.0f us, p99 %.0f / %.0f us, "
                  "message loss %.1f %% / %.1f %% (to afm / to host, by LCM round trips)",
                  asked.c_str(), shaper.c_str(), fig("to_afm", "median_us"), fig("to_host", "median_us"), fig("to_afm", "p99_us"),
                  fig("to_host", "p99_us"), 100 * fig("to_afm", "message_loss"), 100 * fig("to_host", "message_loss"));
    return line;
}

}  // namespace afm::launch
