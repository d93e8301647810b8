#include "env_input.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include <nlohmann/json.hpp>

#include "lockstep.hpp"
#include "planner_internal.hpp"

namespace afm {

EnvDriver::EnvDriver(Operator &op, int fd) : op_(op), fd_(fd)
{
    op_.page = std::make_unique<HandInput>(op_.scene, -1);          // checks and takes SCAN and PUSH lines
    op_.stroke_planner = std::make_unique<Planner>(op_.scene);      // the pushes asked for (PUSH)
    tip_ = {op_.scene.start_nm(), false, 0};
}

int EnvDriver::open_from_env()
{
    return HandInput::open_from_env("operator.mode env takes its actions from a program: run it through analysis.env (docs/env.md)",
                                    "the program's pipe");
}

void EnvDriver::hold() { op_.publish_pose(op_.joy_of(tip_.tip_nm), false); }

void EnvDriver::answer()
{
    op_.count_force();
    if (ended_) return hold();
    if (pushing_) {
        op_.serve_stroke();
        if (op_.stroke) return;   // a block of the push given (or the run is over)
        pushing_ = false;         // it ended: end_stroke gave the lifted pose; ready at the next force
        tip_ = {op_.hold_pose.tip_nm, false, 0};
        return;
    }
    if (!poses_.empty()) {
        tip_ = poses_.front();
        poses_.pop_front();
        op_.publish_pose(op_.joy_of(tip_.tip_nm), tip_.engaged, tip_.load_nN);
        return;
    }
    if (!announced_) {   // the first frame drawn first: the program's first observation
        if (op_.force.seq < static_cast<int64_t>(std::lround(op_.scene.block_hz / op_.scene.frame_rate_hz))) return hold();
        announced_ = true;
        ready(true, "");
    } else if (busy_) {
        busy_ = false;
        ++answered_;
        ready(true, "");
    }
    while (true) {
        std::string line;
        if (!read_line(&line)) {
            end_run(op_.sim_done ? "run over" : "idle");
            return hold();
        }
        const std::string why = start(line);
        if (!why.empty()) {
            ++refused_;
            ++answered_;
            ready(false, why);
            continue;
        }
        if (ended_) return hold();
        if (!busy_) {   // a scan: done already
            ++answered_;
            ready(true, "");
            continue;
        }
        return answer();   // the action's first block
    }
}

bool EnvDriver::read_line(std::string *line)
{
    const auto t0 = std::chrono::steady_clock::now();
    while (true) {
        const std::size_t nl = partial_.find('\n');
        if (nl != std::string::npos) {
            *line = nl > HandInput::kMaxLine ? std::string("(a line too long)") : partial_.substr(0, nl);
            partial_.erase(0, nl + 1);
            return true;
        }
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, 100) > 0) {
            char buf[4096];
            const ssize_t k = read(fd_, buf, sizeof buf);
            if (k > 0) partial_.append(buf, static_cast<std::size_t>(k));
            else usleep(100000);   // the writer gone (a pipe opened read-write never is)
        }
        while (op_.inbox->handle(0) > 0) {}
        if (op_.sim_done) return false;
        op_.hb.maybe_send(RunState::running, op_.force.seq, block_end_utime(op_.scene, op_.force.seq));
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > kIdleLimit_s) return false;
    }
}

std::string EnvDriver::start(const std::string &line)
{
    std::istringstream in(line);
    std::string word;
    in >> word;
    if (word == "END") {
        end_run("END");
        return "";
    }
    if (word == "STROKE") return start_stroke(line);
    if (word != "SCAN" && word != "PUSH") return "not a command";
    if (const std::string why = op_.page->take_line(line); !why.empty()) return why;
    if (word == "SCAN") {
        ++scans_;
        op_.page_scan();   // takes it from the page: at once, at the display's pitch
        if (!op_.pump_until([&] { return !op_.scan.busy(); }, &Operator::retry_scan)) return "the run is over";
        return "";
    }
    HandInput::PushAsk a;
    op_.page->take_push(&a);
    ++pushes_;
    op_.start_stroke(a);
    pushing_ = busy_ = true;
    return "";
}

std::string EnvDriver::start_stroke(const std::string &line)
{
    std::istringstream in(line);
    std::string word, rest;
    Vec2 from, to;
    double load = 0;
    if (!(in >> word >> from.x >> from.y >> to.x >> to.y >> load) || (in >> rest)) return "not a command";
    const Scene &s = op_.scene;
    for (const Vec2 p : {from, to})
        if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::fabs(p.x - s.field_center_nm.x) <= s.field_nm / 2 &&
              std::fabs(p.y - s.field_center_nm.y) <= s.field_nm / 2))
            return "outside the field";
    if (!(std::isfinite(load) && load > 0 && load <= HandInput::kMaxLoad_nN)) return "load out of range";
    const PlanSpec &ps = s.op.plan;
    add_leg(tip_.tip_nm, from, ps.travel_speed_nm_per_s, false, 0);
    poses_.push_back({from, true, load});   // lands
    add_leg(from, to, ps.speed_nm_per_s, true, load);
    poses_.push_back({to, false, 0});       // lifts
    ++strokes_;
    busy_ = true;
    return "";
}

void EnvDriver::add_leg(Vec2 from, Vec2 to, double speed, bool engaged, double load_nN)
{
    const double d = norm(to - from), step = speed / op_.scene.block_hz;
    const int n = std::max(1, static_cast<int>(std::ceil(d / step)));
    for (int i = 1; i <= n; ++i) {
        const double f = static_cast<double>(i) / n;
        poses_.push_back(PlanPose{Vec2{from.x + (to.x - from.x) * f, from.y + (to.y - from.y) * f}, engaged, load_nN});
    }
}

void EnvDriver::ready(bool ok, const std::string &why)
{
    const int64_t n = op_.force.seq;
    std::ostringstream d;
    d << "env: ready " << answered_ << " seq=" << n << " ok=" << (ok ? 1 : 0);
    if (op_.view.ready()) d << " drift_x_nm=" << op_.view.whole().drift_nm[0] << " drift_y_nm=" << op_.view.whole().drift_nm[1];
    if (ok && answered_ > 0 && !op_.strokes_done.empty() && op_.strokes_done.size() == static_cast<std::size_t>(pushes_) &&
        last_push_told_ < pushes_) {
        const PlanItem &i = op_.strokes_done.back().item;
        d << " placed=" << (i.placed ? 1 : 0) << " error_nm=" << i.error_nm << " pushes=" << i.pushes << " scans=" << i.scans;
        last_push_told_ = pushes_;
        if (!i.why.empty()) d << " why=" << i.why;
    }
    if (!why.empty()) d << " why=" << why;
    op_.hb.send(RunState::running, n, block_end_utime(op_.scene, n), d.str());
}

void EnvDriver::end_run(const std::string &by)
{
    ended_ = true;
    ended_by_ = by;
    op_.plan_done = true;
    op_.finished_seq = op_.force.seq;
    op_.hb.send(RunState::finished, op_.force.seq, block_end_utime(op_.scene, op_.force.seq));   // the simulator ends the run
    op_.finished_sent = std::chrono::steady_clock::now();
}

nlohmann::json EnvDriver::report() const
{
    return {{"actions", answered_}, {"strokes", strokes_}, {"scans", scans_}, {"pushes", pushes_},
            {"refused", refused_}, {"ended_by", ended_by_}};
}

}  // namespace afm
