#include "lifecycle.hpp"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <stdexcept>

#include "process.hpp"

namespace afm {

Lifecycle::Lifecycle(std::string name, std::string report_path, std::vector<std::string> subscribes)
    : name_(std::move(name)), report_path_(std::move(report_path)), subscribes_(std::move(subscribes))
{
}

Lifecycle::Lifecycle(std::string name, lcm::LCM &bus, std::string report_path, std::vector<std::string> subscribes)
    : Lifecycle(std::move(name), std::move(report_path), std::move(subscribes))
{
    bus_ = &bus;
}

lcm::LCM &Lifecycle::bus()
{
    if (!bus_) {
        own_bus_ = open_bus();
        bus_ = own_bus_.get();
    }
    return *bus_;
}

Heartbeat &Lifecycle::heartbeat()
{
    if (!hb_) hb_ = std::make_unique<Heartbeat>(bus(), name_);
    return *hb_;
}

void Lifecycle::starting(const std::string &detail, int64_t seq) { heartbeat().send(RunState::starting, seq, 0, detail); }

void Lifecycle::serve(const std::function<Progress()> &where, const std::function<void(int)> &poll, const std::function<bool()> &over,
                      int running_poll_ms, int64_t running_period_us)
{
    while (!over()) {
        const Progress p = where();
        heartbeat().maybe_send(p.started ? RunState::running : RunState::ready, p.seq, p.sim_utime, running_period_us);
        poll(p.started ? running_poll_ms : kReadyPeriodMs);
    }
}

void Lifecycle::running(int64_t seq, int64_t sim_utime, int64_t period_us) { heartbeat().maybe_send(RunState::running, seq, sim_utime, period_us); }

void Lifecycle::done(int64_t seq, int64_t sim_utime, int times, const std::function<void()> &between)
{
    if (!report_path_.empty() && !written_) {
        take_report();
        write("done", "");
    }
    for (int i = 0; i < times; ++i) {
        heartbeat().send(RunState::done, seq, sim_utime);
        if (between) between();
    }
}

void Lifecycle::stop(const std::string &detail) { heartbeat().send(RunState::stop, 0, 0, detail); }

Lifecycle::ReportScope Lifecycle::report_from(std::function<nlohmann::json()> fill)
{
    fill_ = std::move(fill);
    return ReportScope(this);
}

Lifecycle::ReportScope::~ReportScope()
{
    if (life_) life_->take_report();
}

void Lifecycle::take_report() noexcept
{
    if (!fill_ || written_) return;
    auto fill = std::move(fill_);
    fill_ = nullptr;
    try {
        report_ = fill();
        if (!report_.is_object()) report_ = {{"report", report_}};
    } catch (const std::exception &e) {
        report_ = {{"report_error", e.what()}};
    } catch (...) {
        report_ = {{"report_error", "unknown exception"}};
    }
}

void Lifecycle::write(const std::string &ended, const std::string &error)
{
    nlohmann::json j = report_;
    j["ended"] = ended;
    if (!error.empty()) j["error"] = error;
    write_report(report_path_, j);
    written_ = true;
}

void Lifecycle::end(const std::string &ended, const std::string &error)
{
    if (report_path_.empty() || written_) return;
    take_report();
    // a folder that is not there (a run that failed before making it) keeps nothing: no second complaint
    const std::filesystem::path folder = std::filesystem::path(report_path_).parent_path();
    std::error_code ec;
    if (!folder.empty() && !std::filesystem::is_directory(folder, ec)) return;
    try {
        write(ended, error);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "%s: %s\n", name_.c_str(), e.what());
    }
}

void Lifecycle::check_subscriptions(const std::vector<std::string> &channels) const
{
    for (const auto &ch : channels)
        if (std::find(subscribes_.begin(), subscribes_.end(), ch) == subscribes_.end())
            throw std::runtime_error("subscribes to " + ch + ", which its process description does not declare");
}

}  // namespace afm
