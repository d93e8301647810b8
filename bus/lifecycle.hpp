// A run's process's life on the bus, written once: the states it says on
// AFM_HEARTBEAT in their order (starting, ready, running, done; the
// launcher's stop) and its report. The skeleton (run_process.hpp) owns one
// and hands it to the body; the body calls it where it reaches each state.
//
// Contract:
//  - The bus: bus() opens the run's bus (open_bus) on its first call, and
//    the heartbeat on it; a Lifecycle made on a bus (a test's memq, the
//    launcher's) uses that one. heartbeat() is the same Heartbeat, for the
//    body's parts that say the other states (the operator's "finished",
//    the simulator's "ending") or a running state with news: one Heartbeat
//    a process, so that running's rate limit is one.
//  - starting(detail): "starting" at once. serve(): the waiting loop,
//    written once: "ready" every kReadyPeriodUs until the body says it has
//    started, then "running" rate-limited (Heartbeat::maybe_send), polling
//    the body between two, until the body says the run is over.
//    running(seq, utime): "running", rate-limited. done(seq, utime): the
//    report written (below), then "done". stop(detail): "stop" at once.
//  - The report: a process that declares one (its path, from its options;
//    "": none) has it written whole, once, whatever way its body ends: at
//    done(), else by the skeleton when the body returns or throws. Its
//    content is what the body's fill (report_from) answers, taken at done()
//    or as the body leaves (the guard report_from returns), plus "ended":
//    "done", "ok", "run_over_early", "exit N", "input_error" or "failure",
//    and "error" (the exception's text) for the last two. A fill that
//    throws leaves "report_error" instead of its content. A report whose
//    folder is not there when the body fails is not written (nothing to
//    keep it in).
//  - Its declared subscriptions: check_subscriptions(channels) refuses
//    (std::runtime_error naming the channel) an Inbox's subscription the
//    process did not declare.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bus.hpp"

namespace afm {

// Where the body is, as serve() reads it each turn: started (false: it
// waits for the run, and says ready), its last block and its simulated time.
struct Progress {
    bool started = false;
    int64_t seq = -1;
    int64_t sim_utime = 0;
};

class Lifecycle {
public:
    // `report_path` "": no report. `subscribes`: the channels the process
    // declared it reads.
    Lifecycle(std::string name, std::string report_path = "", std::vector<std::string> subscribes = {});
    Lifecycle(std::string name, lcm::LCM &bus, std::string report_path = "", std::vector<std::string> subscribes = {});
    Lifecycle(const Lifecycle &) = delete;
    Lifecycle &operator=(const Lifecycle &) = delete;

    lcm::LCM &bus();
    Heartbeat &heartbeat();

    void starting(const std::string &detail, int64_t seq = -1);
    // Until over(): say ready (while !where().started) or running (every
    // running_period_us), then poll(ms): kReadyPeriodMs while waiting,
    // running_poll_ms once started.
    void serve(const std::function<Progress()> &where, const std::function<void(int ms)> &poll, const std::function<bool()> &over,
               int running_poll_ms = 100, int64_t running_period_us = 1000000);
    void running(int64_t seq, int64_t sim_utime, int64_t period_us = 1000000);
    // The report, then "done" `times` times, calling between() after each.
    void done(int64_t seq, int64_t sim_utime, int times = 1, const std::function<void()> &between = nullptr);
    void stop(const std::string &detail);

    // The report's content from `fill` (above). The guard takes it as the
    // body leaves without done(): declare it after what fill reads.
    class ReportScope {
    public:
        explicit ReportScope(Lifecycle *life) : life_(life) {}
        ReportScope(ReportScope &&o) noexcept : life_(o.life_) { o.life_ = nullptr; }
        ReportScope(const ReportScope &) = delete;
        ~ReportScope();

    private:
        Lifecycle *life_;
    };
    [[nodiscard]] ReportScope report_from(std::function<nlohmann::json()> fill);

    // The skeleton's end: the report, if not yet written, saying `ended`
    // (and `error` when not empty). Prints (does not throw) a failure to
    // write; writes nothing into a folder that is not there.
    void end(const std::string &ended, const std::string &error = "");

    void check_subscriptions(const std::vector<std::string> &channels) const;

private:
    void take_report() noexcept;
    void write(const std::string &ended, const std::string &error);

    std::string name_;
    std::unique_ptr<lcm::LCM> own_bus_;
    lcm::LCM *bus_ = nullptr;
    std::unique_ptr<Heartbeat> hb_;
    std::string report_path_;
    std::vector<std::string> subscribes_;
    std::function<nlohmann::json()> fill_;
    nlohmann::json report_ = nlohmann::json::object();
    bool written_ = false;
};

}  // namespace afm
