// A run's process's main, written once: its launcher bound, its bus key
// read, its errors answered by the exit codes of process.hpp. Here and not
// in common/ because reading the run's key is the bus's (bus_key.hpp).
#pragma once

#include <functional>

#include "process.hpp"

namespace afm {

// Runs a process's body under the exit-code contract: an InputError is
// printed as is and answered kExitInput; another exception is printed as
// "NAME: what" and answered kExitFailure; otherwise the body's own code.
// First binds the process to its launcher (bind_to_launcher): a process
// whose launcher is already gone says so and answers kExitFailure.
int run_process(const char *name, const std::function<int()> &body);

}  // namespace afm
