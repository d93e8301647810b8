// operator.mode env: the operator driven by a program outside the run, one
// action at a time (analysis/env/, docs/env.md), in lockstep: the card's
// block n + 1 waits for the operator's pose, and between two actions the
// operator waits for the program's next one, so the run stands still while
// the program thinks. The actions come as a page's do, on the named pipe
// $AFM_HAND_FIFO (a file crosses the run's network namespace); the answers
// go on the operator's heartbeat, which the program reads through
// afm_view_bridge with the display's VIEW_FRAMEs (the launcher's --view).
//
// Contract:
//   - A line an action:
//       "STROKE X0 Y0 X1 Y1 LOAD_NN": the tip travels lifted (at
//         operator.plan.travel_speed_nm_per_s) from where it is to (X0, Y0),
//         lands, runs engaged at LOAD_NN in a straight line to (X1, Y1) (at
//         operator.plan.speed_nm_per_s) and lifts; frame A, nm, both ends
//         inside the field, the load in (0, HandInput::kMaxLoad_nN].
//       "SCAN X Y SIZE_NM" and "PUSH ID X Y": a local scan and the
//         planner's one-particle push (Planner::push_particle), exactly as
//         the page's (hand_input.hpp checks them; Operator::page_scan,
//         start_stroke): the scan is pasted into the display, no fix sent.
//       "END": the run ends as after the planner has finished (the
//         simulator ends it; the fresh scan at the end judges the sites).
//   - Between two actions the operator does not answer the card's force:
//     the run waits. One frame into the run, and after each action (done or
//     refused), it says on its heartbeat
//       "env: ready K seq=N ok=1|0 drift_x_nm=X drift_y_nm=Y[ placed=0|1 error_nm=E pushes=P scans=S][ why=...]"
//     K: the actions answered (0 at the start), N: the last block the card
//     has stepped (its FW_STATE and the display's frames up to N are out);
//     the card's drift estimate (FW_STATE's objects: frame A less the
//     sample's coordinates);
//     ok=0 and why for a line refused; a PUSH adds the planner's account.
//   - No action for kIdleLimit_s of wall time (the program gone): the run
//     ends as at END, and the report says so.
//   - operator_report.json "env": actions by kind, refused, ended by.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "operator.hpp"

namespace afm {

class EnvDriver {
public:
    static constexpr double kIdleLimit_s = 120;

    // op: the operator it drives (its page and stroke planner are made
    // here, as operator.mode browser's); fd: the pipe's read end.
    EnvDriver(Operator &op, int fd);
    // $AFM_HAND_FIFO opened to read, without waiting; throws InputError
    // naming the variable when it is unset or does not open.
    static int open_from_env();
    // Answers op.force: the next block of the action under way, else waits
    // for the next action.
    void answer();
    nlohmann::json report() const;

private:
    bool read_line(std::string *line);           // false: idle too long, or the run is over
    std::string start(const std::string &line);  // "" started (or, a scan, done), else why refused
    std::string start_stroke(const std::string &line);
    void add_leg(Vec2 from, Vec2 to, double speed, bool engaged, double load_nN);
    void ready(bool ok, const std::string &why);
    void end_run(const std::string &by);
    void hold();

    Operator &op_;
    int fd_;
    std::string partial_;
    std::deque<PlanPose> poses_;   // the stroke's blocks still to give
    PlanPose tip_;                 // the last pose given (frame A)
    bool busy_ = false;            // an action under way (its ready still to say)
    bool pushing_ = false;         // ... the planner's push (op.stroke)
    bool announced_ = false, ended_ = false;
    std::string ended_by_;
    int64_t last_push_told_ = 0;
    int64_t answered_ = 0, strokes_ = 0, scans_ = 0, pushes_ = 0, refused_ = 0;
};

}  // namespace afm
