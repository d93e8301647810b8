// A run's process's main, written once: its command line read (its
// options, their parser and its usage: common/command_line.hpp), its
// launcher bound, its bus key read, its errors answered by the exit codes
// of process.hpp. Here and not in common/ because reading the run's key is
// the bus's (bus_key.hpp).
//
// A process describes itself once, as a Process: its name, its usage's head
// and its options (each with its one check). What it reads and publishes
// is in its Inbox's subscriptions and lcmtypes/channels.yaml, said once
// there; its report is the one write_report of its body.
#pragma once

#include <functional>

#include "command_line.hpp"
#include "process.hpp"

namespace afm {

// Runs a process's body under the exit-code contract: an InputError is
// printed as is and answered kExitInput; another exception is printed as
// "NAME: what" and answered kExitFailure; otherwise the body's own code.
// First binds the process to its launcher (bind_to_launcher): a process
// whose launcher is already gone says so and answers kExitFailure.
int run_process(const char *name, const std::function<int()> &body);

// A run's process: its command line, described once (its name is the
// process's).
template <class O>
using Process = cli::CommandLine<O>;

// Reads argv by the process's command line (--help: the usage, exit 0; a
// refusal: one line, kExitInput), then runs body(options) as above.
template <class O, class Body>
int run_process(const Process<O> &process, int argc, char **argv, const Body &body)
{
    O o;
    if (const int code = cli::read_command_line(process, argc, argv, &o); code >= 0) return code;
    return run_process(process.program, [&] { return body(o); });
}

}  // namespace afm
