// afm_launch's command line: Options, the table of its options (each one's
// name, value, usage text and the one check of its value), the parser and
// the usage text, generated from that table.
//
// parse_args() reads argv into Options and checks what the options say
// together; it prints nothing: its Parsed says whether the run goes on
// (code -1) or the exit code, with what goes to stdout (--help: the usage)
// and to stderr (a refusal: one line naming the option and the value).
#pragma once

#include <string>
#include <vector>

namespace afm::launch {

struct Options {
    std::string scene_path, out_dir;
    bool spy = false, quiet = false, check_only = false, no_verdict = false, strict = false;
    bool view = false;          // the renderer publishes VIEW_FRAME (docs/view.md)
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

// One option. set() checks the value and stores it; "" when it took it,
// else the refusal (without the "afm_launch: " that parse_args adds).
struct OptionSpec {
    enum class Section { usage_line, run, bench };
    const char *name;    // "--stall-s"
    const char *shown;   // the value as the usage shows it ("S"); nullptr: a flag
    Section section;     // usage_line: named in the usage's first line, not listed
    const char *help;    // its usage text, lines after the first indented by the formatter
    std::string (*set)(const std::string &value, Options *o);
};

// Every option, in the usage's order.
const std::vector<OptionSpec> &option_table();

// The usage text (--help, and after a refusal of the whole command line).
std::string usage();

struct Parsed {
    int code = -1;     // -1: go on; else the exit code
    std::string out;   // for stdout
    std::string err;   // for stderr
};
Parsed parse_args(int argc, char **argv, Options *o);

}  // namespace afm::launch
