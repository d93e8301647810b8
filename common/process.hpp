// The life of a run's process, written once for sim_afm, fw_node, the
// operator, the renderer and the launcher: the exit codes the launcher reads,
// the states a process says on AFM_HEARTBEAT, when the run is over for a
// peer, and how a report is written to the run's folder. The skeleton that
// runs a process's body, says its states and writes its report is
// bus/run_process.hpp and bus/lifecycle.hpp.
#pragma once

#include <sys/types.h>

#include <stdexcept>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "afm/heartbeat_t.hpp"

namespace afm {

// Exit codes: 0 the process did its part; 2 its input (the scene, a
// pattern, a plan, its arguments) is wrong, said in one line; 3 the run was
// over before the process could begin its part (the renderer's first scan);
// 1 anything else. The launcher names a child that exits 2 as the scene's
// fault. The launcher's own 4: the run completed but failed one of its own
// checks (host/launch/verdict.hpp; --no-verdict answers 0).
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitInput = 2, kExitRunOverEarly = 3, kExitVerdict = 4 };

// An error in the run's input: main answers it with kExitInput and its text,
// as is. SceneError (scene.hpp), PatternError and PlanError are such errors.
class InputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// The states a process says on AFM_HEARTBEAT (heartbeat_t.state), the one
// list (lcmtypes/heartbeat_t.lcm's comment is held to it by a test):
enum class RunState {
    starting,   // setting up (the launcher recording the bus, the renderer's first scan)
    ready,      // waiting for the run to start, every kReadyPeriodUs
    running,    // the run goes; seq is the last block handled
    finished,   // the operator's planner is done (seq: the block it finished on)
    ending,     // sim_afm: the run ends early, after the planner finished
    done,       // the process ended its part; from sim_afm: the run is over
    stop,       // the launcher: the run is stopped (detail: why)
};
constexpr RunState kRunStates[] = {RunState::starting, RunState::ready,  RunState::running, RunState::finished,
                                   RunState::ending,   RunState::done,   RunState::stop};

// The heartbeat's text of a state ("running").
const char *state_text(RunState s);

// True when `m` is process `name` saying state `s`.
bool says(const heartbeat_t &m, const char *name, RunState s);

// The run is over for a peer: the simulator is done, or the launcher
// stopped the run.
bool run_over(const heartbeat_t &m);

// Writes `j` to `path` (pretty, a newline at the end), through a temporary
// file renamed into place; throws std::runtime_error naming the file and the
// system's reason when it cannot be written whole.
void write_report(const std::string &path, const nlohmann::json &j);

// The run dies with its launcher (issue 46, item 7). The launcher names
// its pid in its children's environment (kLauncherPidEnv); each child, and
// each process a child starts (QEMU under fw_node), is bound to its parent
// with PR_SET_PDEATHSIG (SIGKILL): a launcher killed outright (SIGKILL,
// nothing to catch) takes its processes with it, and theirs with them.
// A change of uid clears that signal (run/drop_caps.sh on two hosts
// changes it between the launcher's fork and the process's main), so each
// process binds itself again at its start (run_process), after any such
// change; and since its parent may have ended before the bind, it then
// checks that its parent is still the one it was started by.
constexpr const char *kLauncherPidEnv = "AFM_LAUNCHER_PID";
// Binds the calling process to `parent` (above). False when its parent is
// no longer `parent` (it ended first): the caller exits at once.
bool bind_to_parent(pid_t parent);
// bind_to_parent($AFM_LAUNCHER_PID) when that is set (a process the
// launcher started); true when it is not set (a process started by hand).
// `parent` (if given) is set to the launcher's pid, or 0.
bool bind_to_launcher(pid_t *parent = nullptr);


}  // namespace afm
