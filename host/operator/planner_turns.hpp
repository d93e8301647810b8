// The turns of the operator's two threads: the planner (planner.hpp) runs in
// a thread of its own and asks the bus side for a block, a scan or a fix;
// each call blocks until the bus side (the operator's main thread) has
// served it. The bus side serves one request at a time: next() waits for
// the planner's request, answer() gives it the model after it (and a scan)
// and lets it go on; stop() makes a waiting or later call throw PlanStopped.
// fix_applied: whether the card took a fix, from its model's answer.
#pragma once

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <string>

#include <opencv2/core.hpp>

#include "afm/object_fix_t.hpp"
#include "planner.hpp"

namespace afm {

// Whether the card applied fix `f`, from its model before (`before`) and
// after it (`after`): the card answers a fix with its model alone. A place
// fix it applied, or a drift fix under the step filter, leaves that
// particle where the scan found it, within pm_nm (the card holds positions
// in whole pm); a drift fix under the Kalman filter moves it by the
// filter's gain, short of the scan; a refused fix leaves it where it was.
inline bool fix_applied(const objects_t &before, const objects_t &after, const object_fix_t &f, double pm_nm)
{
    const auto find = [&](const objects_t &m) -> const particle_t * {
        for (const auto &p : m.particles)
            if (p.id == f.object_id) return &p;
        return nullptr;
    };
    const particle_t *was = find(before), *now = find(after);
    if (!now) return false;
    const bool at_scan = std::fabs(now->x_nm - f.scan_x_nm) <= pm_nm && std::fabs(now->y_nm - f.scan_y_nm) <= pm_nm;
    const bool moved = was && (std::fabs(now->x_nm - was->x_nm) > pm_nm || std::fabs(now->y_nm - was->y_nm) > pm_nm);
    return at_scan || (f.kind == object_fix_t::KIND_DRIFT && moved);
}

// The planner's side of the turns: it blocks in each call until the bus
// side has served it; the bus side serves one request at a time.
class PlannerTurns : public PlanInstrument {
public:
    enum class Req { None, Block, Scan, Fix, Done, Failed };

    // --- the planner's thread
    const objects_t &block(const PlanPose &p) override
    {
        std::unique_lock<std::mutex> lk(m_);
        pose_ = p;
        ask(lk, Req::Block);
        return model_;
    }
    cv::Mat scan(const Field &f) override
    {
        std::unique_lock<std::mutex> lk(m_);
        field_ = f;
        ask(lk, Req::Scan);
        return scan_;
    }
    const objects_t &fix(int id, Vec2 at, bool place, std::string *note) override
    {
        std::unique_lock<std::mutex> lk(m_);
        fix_id_ = id;
        fix_at_ = at;
        fix_place_ = place;
        ask(lk, Req::Fix);
        *note = note_;
        return model_;
    }
    double time_s() const override { return t_s_; }
    void finish(std::exception_ptr e)
    {
        std::lock_guard<std::mutex> lk(m_);
        req_ = e ? Req::Failed : Req::Done;
        error_ = e;
        cv_.notify_all();
    }

    // --- the bus side
    // Waits (up to wait_ms) for the planner's next request; Req::None if none yet.
    Req next(int wait_ms)
    {
        std::unique_lock<std::mutex> lk(m_);
        cv_.wait_for(lk, std::chrono::milliseconds(wait_ms), [&] { return req_ != Req::None; });
        return req_;
    }
    // Answers the request being served (the model after it, the scan) and
    // lets the planner go on.
    void answer(const objects_t &model, double t_s, const cv::Mat *scan = nullptr, const std::string &note = "")
    {
        std::lock_guard<std::mutex> lk(m_);
        model_ = model;
        t_s_ = t_s;
        if (scan) scan_ = scan->clone();
        note_ = note;
        req_ = Req::None;
        cv_.notify_all();
    }
    void stop()
    {
        std::lock_guard<std::mutex> lk(m_);
        stop_ = true;
        cv_.notify_all();
    }
    PlanPose pose() const { return pose_; }
    Field field() const { return field_; }
    int fix_object() const { return fix_id_; }
    Vec2 fix_at() const { return fix_at_; }
    bool fix_place() const { return fix_place_; }
    std::exception_ptr error()
    {
        std::lock_guard<std::mutex> lk(m_);
        return error_;
    }

private:
    void ask(std::unique_lock<std::mutex> &lk, Req r)
    {
        if (stop_) throw PlanStopped{};
        req_ = r;
        cv_.notify_all();
        cv_.wait(lk, [&] { return req_ == Req::None || stop_; });
        if (stop_) throw PlanStopped{};
    }

    std::mutex m_;
    std::condition_variable cv_;
    Req req_ = Req::None;
    bool stop_ = false;
    PlanPose pose_;
    Field field_{};
    int fix_id_ = 0;
    Vec2 fix_at_;
    bool fix_place_ = false;
    objects_t model_;
    double t_s_ = 0;
    cv::Mat scan_;
    std::string note_;
    std::exception_ptr error_;
};


}  // namespace afm
