// What a person at the page means to do with the stylus (operator.mode:
// browser, time_mode: realtime; docs/view.md): the hand's target, the load
// and the stylus button, as the page's server (analysis/view/live.py)
// writes them to a named pipe, $AFM_HAND_FIFO (a file crosses the run's
// network namespace; the launcher passes its children no descriptor). The hand (haptic_device.hpp) pulls the stylus towards the target
// as it pulls it towards a script's aim: the device model, its stability
// bound and its passivity controller stay; the page publishes nothing.
//
// Contract:
//   - A line a command: "HAND X_NM Y_NM LOAD_NN ENGAGED\n", the target in
//     frame A (nm), the load (nN), ENGAGED 0 or 1. poll() reads what is
//     there without waiting and keeps the newest valid command; a line that
//     is not one (a number not finite, a target outside the field, a load
//     outside (0, kMaxLoad_nN], a line over kMaxLine bytes) is refused and
//     counted, and changes nothing.
//   - A second command: "SCAN X_NM Y_NM SIZE_NM\n", a local scan the person
//     asks for, centred at (X, Y) in frame A (nm), SIZE_NM on a side: the
//     centre inside the field and the side in [kMinScanPx display pixels,
//     the field's side], else refused and counted. The newest one not yet
//     taken waits (take_scan()); counted in scans_asked().
//   - A third: "PUSH ID X_NM Y_NM\n", a planner stroke the person asks for:
//     particle ID (one of the scene's, digits only) pushed to (X, Y) in
//     frame A (nm), a place where the particle lies wholly inside the
//     field. The newest one not yet taken waits (take_push()); counted in
//     pushes_asked().
//   - Every line refused is counted, and by its reason (refusals(): "not a
//     command", "line too long", "outside the field", "load out of range",
//     "scan size out of range", "unknown particle", "target outside the
//     field").
//   - yield(true) while a stroke drives the tip: HAND lines are read and
//     counted (held()) but leave the command as it was; hand_back(aim)
//     then puts the hand's target where the stroke left the tip, lifted.
//   - Until the first command: the scene's start (operator.path_nm's first
//     point), its load, the tip lifted (engaged false).
//   - A pipe closed by the server leaves the last command in force.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include "scene.hpp"

namespace afm {

class HandInput {
public:
    static constexpr double kMaxLoad_nN = 1000;   // the scene's operator.load_nN range
    static constexpr std::size_t kMaxLine = 200;

    struct Command {
        Vec2 aim_nm;
        double load_nN;
        bool engaged;
    };

    struct ScanAsk {
        Vec2 center_nm;
        double size_nm;
    };
    static constexpr int kMinScanPx = 4;

    struct PushAsk {
        int id;
        Vec2 target_nm;
    };

    // fd: the pipe's read end (made non-blocking here).
    HandInput(const Scene &s, int fd);
    // $AFM_HAND_FIFO opened to read, without waiting; throws InputError
    // naming the variable when it is unset (saying `unset_why`, what the
    // mode takes its commands from) or does not open (naming the pipe as
    // `what`). The page's hand by default; operator.mode env's program
    // through EnvDriver::open_from_env.
    static int open_from_env(const char *unset_why = "operator.mode browser takes the hand from the page: run it with "
                                                     "./afm run SCENE --view",
                             const char *what = "the page's hand");

    // Takes the commands that came since the last call.
    void poll();
    // Takes one line (without its newline) as poll() takes each: "" taken,
    // else why not (not counted: the caller says so). operator.mode env
    // hands it the SCAN and PUSH lines it reads itself (env_input.hpp).
    std::string take_line(const std::string &line);
    const Command &command() const { return cmd_; }
    int64_t taken() const { return taken_; }
    int64_t refused() const { return refused_; }
    int64_t scans_asked() const { return scans_asked_; }
    int64_t pushes_asked() const { return pushes_asked_; }
    int64_t held() const { return held_; }
    const std::map<std::string, int64_t> &refusals() const { return refusals_; }
    // The scan asked for and not yet taken, once (false: none).
    bool take_scan(ScanAsk *s);
    // The stroke asked for and not yet taken, once (false: none).
    bool take_push(PushAsk *p);
    // A stroke drives the tip (true): HAND lines are held, not taken.
    void yield(bool on) { yielded_ = on; }
    // The stroke has ended with the tip lifted at aim_nm: the hand's target.
    void hand_back(Vec2 aim_nm);

private:
    void refuse(const std::string &why);
    std::string parse(const std::string &line, Command *c) const;
    std::string parse_scan(const std::string &line, ScanAsk *s) const;
    std::string parse_push(const std::string &line, PushAsk *p) const;
    bool in_field(Vec2 p_nm, double margin_nm = 0) const;

    const Scene &scene_;
    int fd_;
    std::string partial_;
    Command cmd_;
    ScanAsk scan_{};
    bool scan_pending_ = false;
    PushAsk push_{};
    bool push_pending_ = false;
    bool yielded_ = false;
    int64_t taken_ = 0, refused_ = 0, scans_asked_ = 0, pushes_asked_ = 0, held_ = 0;
    std::map<std::string, int64_t> refusals_;
};

}  // namespace afm
