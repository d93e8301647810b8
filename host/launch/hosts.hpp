// Hosts: the run on one network namespace, or on the paper's two computers
// (--hosts 2, docs/hosts.md). run/two_hosts.sh makes the second namespace
// ("afm", held by a process whose pid it exports), the veth pair, the link's
// shapers and its probe, then runs the launcher in the first ("host") with
// no privilege. This module reads what it exported, says where each process
// runs (sim_afm in "afm"; the card's node, the operator, the renderer and
// the launcher with its record in "host"). The launcher starts every
// process in the afm namespace's user namespace (spawn's Entry: the
// launcher's uid owns it, so entering needs no privilege; each process then
// drops what that gives through run/drop_caps.sh), sim_afm in its network
// namespace too. It stops the shapers at the end so that they write their
// counts, and writes run.json's "hosts".
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace afm::launch {

struct Hosts {
    int count = 1;
    int afm_ns_pid = -1;          // the holder of the afm namespace (/proc/PID/ns/{user,net})
    std::string drop_caps;        // run/drop_caps.sh
    std::string link_dir;         // the link's probe and shaper reports (run/two_hosts.sh)
    bool link_dir_is_temporary = false;   // made for this run alone: removed once read
    std::string shaper = "none";  // what shaped the link: none, tbf, nfqueue, netem (+tbf)
    std::string asked;            // the link asked: delay=MS,jitter=MS,loss=P,dup=P,reorder=P,rate=MBIT
    std::vector<pid_t> shapers;   // afm_netfault processes (SIGTERM: they write their reports)
    nlohmann::json shaper_reports = nlohmann::json::object();

    // Reads what run/two_hosts.sh exported for `count` hosts; "" or why
    // the run cannot go on (count 2 outside two namespaces).
    std::string from_env(int count);

    // "afm" or "host" for a run's process (two hosts); "" for one namespace.
    std::string where(const std::string &process) const;
    bool on_afm(const std::string &process) const { return where(process) == "afm"; }

    // The interface the process's bus goes through (AFM_BUS_LINK), for its environment.
    std::string bus_link_env(const std::string &process) const;

    // The simulator's resend period across the link, ms (-1: its own default).
    int resend_ms() const;

    // SIGTERM to the shapers, each waited for (they are the launcher's
    // children once two_hosts.sh has exec'd it); their reports, the probe's
    // and the link's down/up times read.
    void stop_shapers();

    // run.json "hosts": count, namespaces with their processes, the
    // recorder's place, the link asked, its shaper and what it achieved.
    nlohmann::json json(const std::vector<std::string> &processes) const;

    // One line for the run's summary ("" for one namespace).
    std::string summary() const;

private:
    nlohmann::json probe_;   // DIR/probe.json (afm_linkprobe)
    std::string down_;       // DIR/down.log (AFM_LINK_DOWN)
    double asked_value(const std::string &key) const;   // 0 when not asked
    nlohmann::json achieved() const;
};

}  // namespace afm::launch
