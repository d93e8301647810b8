// afm_launch's command line: Options and the table of its options (each
// one's name, value, usage text and the one check of its value), read by
// the parser and the usage of common/command_line.hpp.
//
// parse_args() reads argv into Options and checks what the options say
// together; it prints nothing: its Parsed says whether the run goes on
// (code -1) or the exit code, with what goes to stdout (--help: the usage)
// and to stderr (a refusal: one line naming the option and the value).
#pragma once

#include <string>
#include <vector>

#include "command_line.hpp"

namespace afm::launch {

struct Options {
    std::string scene_path, out_dir;
    bool spy = false, quiet = false, check_only = false, no_verdict = false, strict = false;
    bool view = false;          // the renderer publishes VIEW_FRAME (docs/view.md)
    bool resolved = false;      // --resolved: checked as --check does, then the scene as a run keeps it on stdout
    bool estimate = false;      // --estimate: checked as --check does, then the wall time's estimate as JSON on stdout
    int view_fd = -1;           // --view-fd: the pipe afm_view_bridge writes to (-1: no bridge)
    double drop_p = 0, stall_s = 60, kill_after = -1;
    std::string kill_name;
    long long crash_block = -1;
    std::string firmware = "host";   // fw_node --firmware: host, or qemu (the card on its board, docs/pil.md)
    long long log_window = -1;  // sim_afm --log-window; 0: no --follow-log; -1: log_window_blocks() of the tap's buffer
    bool renderer = true;
    bool placement = true;      // common/placement.hpp; --placement off
    int hosts = 1;              // 2: the two computers on a link (hosts.hpp)
};

// One option (common/command_line.hpp): its name, value, usage section and
// text, and set(), which checks the value and stores it ("" when it took
// it, else why).
using OptionSpec = afm::cli::Option<Options>;
using Parsed = afm::cli::Parsed;

// Every option, in the usage's order.
const std::vector<OptionSpec> &option_table();

// The usage text (--help).
std::string usage();

Parsed parse_args(int argc, char **argv, Options *o);

}  // namespace afm::launch
