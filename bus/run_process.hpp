// A run's process's main, written once: its command line read (its
// options, their parser and its usage: common/command_line.hpp), its
// channels checked against lcmtypes/channels.yaml, its launcher bound, its
// bus key read, its life on the bus and its report (lifecycle.hpp) handed
// to its body, its errors answered by the exit codes of process.hpp. Here
// and not in common/ because reading the run's key is the bus's
// (bus_key.hpp).
//
// A process describes itself once, as a Process: its name, its usage's
// head and its options (each with its one check); the channels it reads
// and those it publishes besides AFM_HEARTBEAT (by name); and its report's
// path for the options it was given ("": none). The skeleton refuses at
// once, naming the channel, a process that publishes a channel
// channels.yaml does not give it, or that reads one channels.yaml does not
// list (channels_refusal); the Lifecycle refuses an Inbox subscription the
// description does not declare (check_subscriptions).
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "command_line.hpp"
#include "lifecycle.hpp"
#include "process.hpp"

namespace afm {

template <class O>
struct Process : cli::CommandLine<O> {
    std::vector<std::string> subscribes;                    // the channels it reads
    std::vector<std::string> publishes;                     // the channels it publishes (AFM_HEARTBEAT: every process's)
    std::function<std::string(const O &)> report = nullptr;   // its report's path ("" or nullptr: none)
};

// "" when program `name` may publish each of `publishes` (channels.yaml's
// publisher, AFM_CHANNEL_PUBLISHERS) and read each of `subscribes`
// (channels.yaml's readers, AFM_CHANNEL_READERS: SIM_TRUTH has none, so no
// process of the run can take the truth); else why, naming the channel.
std::string channels_refusal(const std::string &name, const std::vector<std::string> &subscribes,
                             const std::vector<std::string> &publishes);

// Runs a process's body under the exit-code contract: an InputError is
// printed as is and answered kExitInput; another exception is printed as
// "NAME: what" and answered kExitFailure; otherwise the body's own code.
// First binds the process to its launcher (bind_to_launcher): a process
// whose launcher is already gone says so and answers kExitFailure. `life`
// (if given) writes its report at the end (Lifecycle::end), saying how the
// body ended.
int run_process(const char *name, const std::function<int()> &body, Lifecycle *life = nullptr);

// Reads argv by the process's command line (--help: the usage, exit 0; a
// refusal: one line, kExitInput), checks its channels (a refusal: one
// line, kExitFailure), then runs body(options, lifecycle) as above.
template <class O, class Body>
int run_process(const Process<O> &process, int argc, char **argv, const Body &body)
{
    O o;
    if (const int code = cli::read_command_line(process, argc, argv, &o); code >= 0) return code;
    if (const std::string why = channels_refusal(process.program, process.subscribes, process.publishes); !why.empty()) {
        std::fputs(cli::refusal(process.program, why).c_str(), stderr);
        return kExitFailure;
    }
    Lifecycle life(process.program, process.report ? process.report(o) : std::string(), process.subscribes);
    return run_process(process.program, [&] { return body(o, life); }, &life);
}

}  // namespace afm
