// Who sent a datagram, from the kernel, not from what the message says of
// itself (issue 35: a heartbeat's name and pid are the sender's own claim).
//
// Every process of a run receives through a BusTap, which sees each
// datagram's source address and port. Senders maps a source port to the
// run's process that owns the UDP socket bound to it: the socket's inode in
// /proc/PID/net/udp (that process's namespace: the run's one, or either of
// the two of a run on two hosts, docs/hosts.md) and that inode among the file descriptors of the run's processes
// (/proc/PID/fd). Which processes are the run's: for a child of the launcher
// (Scope::siblings), its parent and its parent's children; for the launcher
// (Scope::children), itself and its own children. A process is named by its
// executable (the basename of /proc/PID/exe), which the launcher chose.
//
// A channel's publishers are channels.yaml's (AFM_CHANNEL_PUBLISHERS,
// generated): a message on a channel is admitted only from a process whose
// program publishes it ("*": every process of the run). Anything else (a
// port no process of the run owns, or a process that does not publish the
// channel) is foreign: counted by channel and by sender, never handed on.
//
// Cost: a port is looked up once and remembered (admitted or not). A port
// not yet known rescans /proc (well under a millisecond for a run's
// processes), at most kMaxScansPerSecond times a second: past that, a new
// port is foreign without a look. A flood from fresh sockets thus costs at
// most that many scans a second; the run's own processes send their first
// datagrams at start, long before any flood could use the budget up.
// Thread-safe: a process's receive thread admits, its main thread reports.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

namespace afm {

// AFM_ADMIT_ANY_SENDER=1 in the environment admits every sender, as before
// this check: the inboxes' own checks of what a message holds (inbox.hpp)
// are then reachable from a hostile process, which tests/e2e/test_hostile.py
// needs to test them. Only whoever starts the run can set it.
class Senders {
public:
    enum class Scope { siblings, children };
    explicit Senders(Scope scope);

    // True when the datagram from source `port` on `channel` comes from a
    // process of the run that publishes it; otherwise counts it as foreign.
    bool admit(const std::string &channel, uint16_t port);

    // False (and the datagram counted foreign, its sender "port P (PROGRAM,
    // pid N) naming itself NAME") when a heartbeat names a process other
    // than the program behind its source port ("launcher" is afm_launch;
    // every other name is its program's); true for anything else (a
    // message that does not decode is the inbox's to refuse).
    bool vet(const std::string &channel, const unsigned char *data, std::size_t size, uint16_t port);

    // Counts one datagram on `channel` from source `port` as foreign (what
    // admit() does with one it refuses; the recorder's fuzz target calls it).
    void count_foreign(const std::string &channel, uint16_t port);

    // Foreign datagrams: {"CHANNEL": {"SENDER": count}} with SENDER "port P
    // (program, pid N)" or "port P (no process of the run)". CHANNEL is the
    // datagram's name as afm::printable shows it (text.hpp): a name is any
    // bytes a sender chose, and run.json holds only valid UTF-8.
    nlohmann::json foreign() const;
    int64_t foreign_count() const;

    // This process's program and UDP ports, "PROGRAM:P,P,...": a launcher whose children cannot
    // read its file descriptors (a two-host run: they are in a user
    // namespace below its own, docs/hosts.md) puts them in their environment
    // as kParentPortsEnv, and a child takes those ports as its parent's
    // (when it cannot read them itself: the parent's word, like its pid).
    static std::string own_ports();
    static constexpr const char *kParentPortsEnv = "AFM_PARENT_UDP_PORTS";

    // AFM_ADMIT_ANY_SENDER=1 (above): the one reader of it.
    static bool admit_any();

    // The channel's publishers from channels.yaml; "*" for every process.
    static bool publishes(const std::string &program, const std::string &channel);

    // The parent pid of `pid` from /proc/PID/stat, or -1 when it has none
    // to show: gone, or going while its file is read (read() then fails
    // with ESRCH; this never throws).
    static int parent_pid(int pid);

    static constexpr int kMaxScansPerSecond = 200;

private:
    struct Owner {
        std::string program;   // "" when no process of the run owns the port
        int pid = 0;
    };
    void rescan();
    void count_foreign_locked(const std::string &channel, uint16_t port);
    std::string describe(uint16_t port) const;

    Scope scope_;
    bool any_ = false;   // AFM_ADMIT_ANY_SENDER
    mutable std::mutex m_;
    std::map<uint16_t, Owner> owners_;
    int64_t scan_second_ = -1;   // the second (steady clock) the scan budget counts
    int scans_ = 0;              // scans in it
    std::map<std::string, std::map<std::string, int64_t>> foreign_;
    int64_t foreign_total_ = 0;
};

}  // namespace afm
