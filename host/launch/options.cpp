#include "options.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <limits>

#include "card_backend.hpp"
#include "processes.hpp"

namespace afm::launch {

namespace {

constexpr const char *kUsageHead =
    "usage: afm_launch --scene FILE --out DIR [options]\n"
    "  Runs one scene through sim_afm, fw_node, operator and renderer on a private\n"
    "  LCM bus, recording it to DIR/bus.lcmlog. ./afm run calls it inside a fresh\n"
    "  network namespace; run directly it refuses unless loopback carries the\n"
    "  multicast route.\n";

// --kill AFTER_S:NAME
std::string set_kill(const std::string &v, Options *o)
{
    const auto colon = v.find(':');
    double after = -1;
    if (colon == std::string::npos || !cli::read_number(v.substr(0, colon), cli::at_least(0), &after).empty() || colon + 1 == v.size())
        return "wants AFTER_S:NAME";
    o->kill_after = after;
    o->kill_name = v.substr(colon + 1);
    return "";
}

// --inject-crash fw_node:N
std::string set_crash(const std::string &v, Options *o)
{
    const char *wants = "wants fw_node:N (the block it crashes on, >= 0)";
    return v.rfind("fw_node:", 0) != 0 || !cli::read_whole(v.substr(8), 0, std::numeric_limits<long long>::max(), &o->crash_block).empty()
               ? wants
               : "";
}

// --view-fd N: a descriptor this process holds open for writing, above
// stdin, stdout and stderr.
std::string set_view_fd(const std::string &v, Options *o)
{
    long long fd = -1;
    const int flags = cli::read_whole(v, 3, 1023, &fd).empty() ? fcntl(static_cast<int>(fd), F_GETFL) : -1;
    if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY) return "wants a descriptor above 2 open for writing";
    o->view_fd = static_cast<int>(fd);
    return "";
}

std::string set_hosts(const std::string &v, Options *o)
{
    std::string h;
    const std::string why = cli::read_choice(v, {"1", "2"}, &h);
    if (why.empty()) o->hosts = h == "2" ? 2 : 1;
    return why;
}

std::string set_placement(const std::string &v, Options *o)
{
    std::string p;
    const std::string why = cli::read_choice(v, {"on", "off"}, &p);
    if (why.empty()) o->placement = p == "on";
    return why;
}

constexpr const char *kRun = "options:", *kBench = "bench options (./afm bench bus):";
constexpr long long kMany = std::numeric_limits<long long>::max();

const std::vector<OptionSpec> kTable = {
    {{"--scene", "FILE", nullptr, nullptr, true}, cli::text(&Options::scene_path)},
    {{"--out", "DIR", nullptr, nullptr}, cli::text(&Options::out_dir)},
    {{"--check", nullptr, kRun, "validate the scene and exit (0: valid, 2: not)"}, cli::flag(&Options::check_only)},
    {{"--resolved", nullptr, kRun,
      "check the scene as --check does, then print it as a run keeps it\n"
      "(its includes merged in, its file paths absolute) on stdout"},
     [](const std::string &, Options *o) { o->check_only = o->resolved = true; return std::string(); }},
    {{"--estimate", nullptr, kRun,
      "check the scene as --check does, then print the run's wall time\n"
      "estimated from its size, with the work it counts, as one JSON line\n"
      "on stdout (host/launch/warnings.hpp: estimate_wall)"},
     [](const std::string &, Options *o) { o->check_only = o->estimate = true; return std::string(); }},
    {{"--spy", nullptr, kRun,
      "also start lcm-spy on the run's bus (needs DISPLAY); the run\n"
      "starts once lcm-spy listens on the bus (10 s at most) and ends\n"
      "when lcm-spy is closed (time_mode: realtime to watch at pace)"},
     cli::flag(&Options::spy)},
    {{"--view", nullptr, kRun,
      "the renderer also publishes its frames on VIEW_FRAME for a page\n"
      "(./afm run --view serves it; docs/view.md)"},
     cli::flag(&Options::view)},
    {{"--view-fd", "N", kRun,
      "with --view: start afm_view_bridge, the launcher's child with the\n"
      "run's key, writing VIEW_FRAME and AFM_HEARTBEAT to descriptor N (the\n"
      "pipe to the page's server, which ./afm run --view hands down)"},
     set_view_fd},
    {{"--inject-drop", "P", kRun, "sim_afm drops each analog block's first send with probability P"},
     cli::number(&Options::drop_p, cli::in_range(0, 1, true), "a probability")},
    {{"--kill", "AFTER_S:NAME", kRun, "failure injection: SIGKILL process NAME AFTER_S wall seconds into the run"}, set_kill},
    {{"--inject-crash", "fw_node:N", kRun, "failure injection: fw_node exits (code 70) on analog block N"}, set_crash},
    {{"--firmware", "host|qemu", kRun,
      "where the card runs: linked into fw_node (host, the default) or\n"
      "built for its processor on an emulated mps2-an386 board (docs/pil.md)"},
     [](const std::string &v, Options *o) { return read_firmware(v, &o->firmware); }},
    {{"--hosts", "1|2", kRun,
      "one network namespace (the default), or the paper's two computers: sim_afm in\n"
      "\"afm\", the rest in \"host\", joined by a veth pair and its link (./afm run\n"
      "--hosts 2 [--link SPEC] makes them: run/two_hosts.sh, docs/hosts.md)"},
     set_hosts},
    {{"--stall-s", "S", kRun, "abort if the run makes no progress for S wall seconds (default 60)"},
     cli::number(&Options::stall_s, cli::above(0), "a number of seconds")},
    {{"--quiet", nullptr, kRun, "no progress line (with --check: no warnings, only refusals)"}, cli::flag(&Options::quiet)},
    {{"--strict", nullptr, kRun, "a warning about the scene (host/launch/warnings.hpp) is an error"}, cli::flag(&Options::strict)},
    {{"--no-verdict", nullptr, kRun,
      "exit 0 when the run completes but fails one of its own checks\n"
      "(the verdict is still in run.json and the last line; else exit 4)"},
     cli::flag(&Options::no_verdict)},
    {{"--log-window", "N", kBench,
      "sim_afm runs at most N blocks ahead of what the record holds\n"
      "(default: as many as the record's receive buffer holds at\n"
      "32 kB a block, 8 to 64; run.json launcher.log_window_blocks);\n"
      "0: no pacing"},
     cli::whole(&Options::log_window, 0, kMany, "a number of blocks")},
    {{"--no-renderer", nullptr, kBench, "no renderer: no frames, no video, no fidelity check"}, cli::flag(&Options::renderer, false)},
    {{"--placement", "off", kBench,
      "no CPU placement (default on: sim_afm, fw_node and operator share\n"
      "one CPU, the launcher and the renderer run on the others;\n"
      "common/placement.hpp)"},
     set_placement},
};

// What the options say together ("" or the refusal).
std::string check_together(const Options &o)
{
    if (o.out_dir.empty() && !o.check_only) return "--out DIR: required unless --check (afm_launch --help: the usage)";
    if (o.resolved && !o.out_dir.empty()) return "--resolved: prints the scene and runs nothing: it takes no --out";
    if (o.estimate && !o.out_dir.empty()) return "--estimate: prints an estimate and runs nothing: it takes no --out";
    if (o.estimate && o.resolved) return "--estimate: goes without --resolved (each prints on stdout)";
    if (o.spy && !o.check_only && !std::getenv("DISPLAY")) return "--spy: needs a display, and DISPLAY is not set (lcm-spy is a window)";
    if (o.view_fd >= 0 && !o.view) return "--view-fd: goes with --view (it is the pipe to the page's server)";
    if (o.view_fd >= 0 && access(view_bridge_path().c_str(), X_OK) != 0)
        return "--view-fd: " + view_bridge_path() + " is missing: build the bench first (./afm build)";
    return "";
}

const cli::CommandLine<Options> kCommandLine = {"afm_launch", kUsageHead, kTable, check_together};

}  // namespace

const std::vector<OptionSpec> &option_table() { return kTable; }

std::string usage() { return kCommandLine.usage(); }

Parsed parse_args(int argc, char **argv, Options *o) { return kCommandLine.parse(argc, argv, o); }

}  // namespace afm::launch
