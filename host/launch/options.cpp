#include "options.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>

#include "processes.hpp"

namespace afm::launch {

namespace {

constexpr const char *kUsageHead =
    "usage: afm_launch --scene FILE --out DIR [options]\n"
    "  Runs one scene through sim_afm, fw_node, operator and renderer on a private\n"
    "  LCM bus, recording it to DIR/bus.lcmlog. ./afm run calls it inside a fresh\n"
    "  network namespace; run directly it refuses unless loopback carries the\n"
    "  multicast route.\n";
// The usage's columns: an option and its value in the first kNameWidth,
// its text after (two spaces after a longer one), its further lines indented to it.
constexpr std::size_t kIndent = 2, kNameWidth = 19;

// A whole number of the value (strtoll); false when it is not one.
bool whole(const std::string &v, long long *n)
{
    char *end = nullptr;
    errno = 0;
    *n = std::strtoll(v.c_str(), &end, 10);
    return !v.empty() && !*end && errno == 0;
}

// A finite number (strtod); false when it is not one.
bool number(const std::string &v, double *x)
{
    char *end = nullptr;
    *x = std::strtod(v.c_str(), &end);
    return !v.empty() && !*end && std::isfinite(*x);
}

std::string got(const char *opt, const char *wants, const std::string &v)
{
    return std::string(opt) + " wants " + wants + ", got '" + v + "'";
}

std::string set_drop(const std::string &v, Options *o)
{
    if (!number(v, &o->drop_p)) return got("--inject-drop", "a probability in [0, 1)", v);
    if (!(o->drop_p >= 0 && o->drop_p < 1)) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "--inject-drop must be in [0, 1), got %g", o->drop_p);
        return buf;
    }
    return "";
}

std::string set_kill(const std::string &v, Options *o)
{
    const auto colon = v.find(':');
    if (colon == std::string::npos || !number(v.substr(0, colon), &o->kill_after) || o->kill_after < 0 || colon + 1 == v.size())
        return got("--kill", "AFTER_S:NAME", v);
    o->kill_name = v.substr(colon + 1);
    return "";
}

std::string set_crash(const std::string &v, Options *o)
{
    if (v.rfind("fw_node:", 0) != 0 || !whole(v.substr(8), &o->crash_block) || o->crash_block < 0)
        return "--inject-crash supports fw_node:N, got '" + v + "'";
    return "";
}

// --view-fd N: a descriptor this process holds open for writing, above
// stdin, stdout and stderr.
std::string set_view_fd(const std::string &v, Options *o)
{
    long long fd = -1;
    const int flags = whole(v, &fd) && fd > 2 && fd < 1024 ? fcntl(static_cast<int>(fd), F_GETFL) : -1;
    if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY) return "--view-fd wants a descriptor above 2 open for writing, got '" + v + "'";
    o->view_fd = static_cast<int>(fd);
    return "";
}

std::string set_one_of(const char *opt, const std::string &v, const std::map<std::string, std::string> &allowed, std::string *to,
                       const char *wants)
{
    if (!allowed.count(v)) return got(opt, wants, v);
    *to = v;
    return "";
}

// A flag's setter: the member it sets.
template <bool Options::*Member>
std::string set_flag(const std::string &, Options *o)
{
    o->*Member = true;
    return "";
}

using S = OptionSpec::Section;

const std::vector<OptionSpec> kTable = {
    {"--scene", "FILE", S::usage_line, nullptr, [](const std::string &v, Options *o) { o->scene_path = v; return std::string(); }},
    {"--out", "DIR", S::usage_line, nullptr, [](const std::string &v, Options *o) { o->out_dir = v; return std::string(); }},
    {"--check", nullptr, S::run, "validate the scene and exit (0: valid, 2: not)", set_flag<&Options::check_only>},
    {"--spy", nullptr, S::run,
     "also start lcm-spy on the run's bus (needs DISPLAY); the run\n"
     "starts once lcm-spy listens on the bus (10 s at most) and ends\n"
     "when lcm-spy is closed (time_mode: realtime to watch at pace)",
     set_flag<&Options::spy>},
    {"--view", nullptr, S::run,
     "the renderer also publishes its frames on VIEW_FRAME for a page\n"
     "(./afm run --view serves it; docs/view.md)",
     set_flag<&Options::view>},
    {"--view-fd", "N", S::run,
     "with --view: start afm_view_bridge, the launcher's child with the\n"
     "run's key, writing VIEW_FRAME and AFM_HEARTBEAT to descriptor N (the\n"
     "pipe to the page's server, which ./afm run --view hands down)",
     set_view_fd},
    {"--inject-drop", "P", S::run, "sim_afm drops each analog block's first send with probability P", set_drop},
    {"--kill", "AFTER_S:NAME", S::run, "failure injection: SIGKILL process NAME AFTER_S wall seconds into the run", set_kill},
    {"--inject-crash", "fw_node:N", S::run, "failure injection: fw_node exits (code 70) on analog block N", set_crash},
    {"--firmware", "host|qemu", S::run,
     "where the card runs: linked into fw_node (host, the default) or\n"
     "built for its processor on an emulated mps2-an386 board (docs/pil.md)",
     [](const std::string &v, Options *o) { return set_one_of("--firmware", v, {{"host", ""}, {"qemu", ""}}, &o->firmware, "host or qemu"); }},
    {"--hosts", "1|2", S::run,
     "one network namespace (the default), or the paper's two computers: sim_afm in\n"
     "\"afm\", the rest in \"host\", joined by a veth pair and its link (./afm run\n"
     "--hosts 2 [--link SPEC] makes them: run/two_hosts.sh, docs/hosts.md)",
     [](const std::string &v, Options *o) {
         std::string h;
         const std::string why = set_one_of("--hosts", v, {{"1", ""}, {"2", ""}}, &h, "1 or 2");
         if (why.empty()) o->hosts = std::atoi(h.c_str());
         return why;
     }},
    {"--stall-s", "S", S::run, "abort if the run makes no progress for S wall seconds (default 60)",
     [](const std::string &v, Options *o) { return number(v, &o->stall_s) && o->stall_s > 0 ? std::string() : got("--stall-s", "a number of seconds > 0", v); }},
    {"--quiet", nullptr, S::run, "no progress line (with --check: no warnings, only refusals)", set_flag<&Options::quiet>},
    {"--strict", nullptr, S::run, "a warning about the scene (host/launch/warnings.hpp) is an error", set_flag<&Options::strict>},
    {"--no-verdict", nullptr, S::run,
     "exit 0 when the run completes but fails one of its own checks\n"
     "(the verdict is still in run.json and the last line; else exit 4)",
     set_flag<&Options::no_verdict>},
    {"--log-window", "N", S::bench,
     "sim_afm runs at most N blocks ahead of what the record holds\n"
     "(default: as many as the record's receive buffer holds at\n"
     "32 kB a block, 8 to 64; run.json launcher.log_window_blocks);\n"
     "0: no pacing",
     [](const std::string &v, Options *o) {
         return whole(v, &o->log_window) && o->log_window >= 0 ? std::string() : got("--log-window", "a number of blocks >= 0", v);
     }},
    {"--no-renderer", nullptr, S::bench, "no renderer: no frames, no video, no fidelity check",
     [](const std::string &, Options *o) { o->renderer = false; return std::string(); }},
    {"--placement", "off", S::bench,
     "no CPU placement (default on: sim_afm, fw_node and operator share\n"
     "one CPU, the launcher and the renderer run on the others;\n"
     "common/placement.hpp)",
     [](const std::string &v, Options *o) {
         std::string p;
         const std::string why = set_one_of("--placement", v, {{"on", ""}, {"off", ""}}, &p, "on or off");
         if (why.empty()) o->placement = p == "on";
         return why;
     }},
};

// One option's lines in the usage.
std::string usage_rows(const OptionSpec &s)
{
    std::string head = std::string(kIndent, ' ') + s.name + (s.shown ? std::string(" ") + s.shown : "");
    head += head.size() < kIndent + kNameWidth ? std::string(kIndent + kNameWidth - head.size(), ' ') : "  ";
    std::string rows = head;
    for (const char *p = s.help; *p; ++p) {
        rows += *p;
        if (*p == '\n') rows += std::string(kIndent + kNameWidth, ' ');
    }
    return rows + "\n";
}

// What the options say together ("" or the refusal).
std::string check_together(const Options &o)
{
    if (o.spy && !o.check_only && !std::getenv("DISPLAY")) return "--spy needs a display and DISPLAY is not set (lcm-spy is a window)";
    if (o.view_fd >= 0 && !o.view) return "--view-fd goes with --view (it is the pipe to the page's server)";
    if (o.view_fd >= 0 && access(view_bridge_path().c_str(), X_OK) != 0)
        return "--view-fd: " + view_bridge_path() + " is missing: build the bench first (./afm build)";
    return "";
}

}  // namespace

const std::vector<OptionSpec> &option_table() { return kTable; }

std::string usage()
{
    std::string u = kUsageHead;
    for (const auto &[section, title] : {std::pair{S::run, "options:\n"}, std::pair{S::bench, "bench options (./afm bench bus):\n"}}) {
        u += title;
        for (const auto &s : kTable)
            if (s.section == section) u += usage_rows(s);
    }
    return u;
}

Parsed parse_args(int argc, char **argv, Options *o)
{
    auto refuse = [](const std::string &why) { return Parsed{2, "", "afm_launch: " + why + "\n"}; };
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "-h" || a == "--help") return {0, usage(), ""};
        const OptionSpec *spec = nullptr;
        for (const auto &s : kTable)
            if (a == s.name) spec = &s;
        if (!spec) return {2, "", "afm_launch: unknown argument '" + a + "'\n" + usage()};
        if (spec->shown && i + 1 >= argc) return refuse(a + " needs a value");
        const std::string why = spec->set(spec->shown ? argv[++i] : "", o);
        if (!why.empty()) return refuse(why);
    }
    if (o->scene_path.empty() || (o->out_dir.empty() && !o->check_only)) return {2, "", usage()};
    if (const std::string why = check_together(*o); !why.empty()) return refuse(why);
    return {};
}

}  // namespace afm::launch
