// Fuzz target "calc": the lever calculator (./afm calc|calib|model,
// host/calc/afm_calc.c and its calc_*.c) in-process: its argument parsing and the
// firmware's solvers behind it.
//
// Input: the command line after the program's name, one argument per line
// (or NUL-separated). A line "@probe" ends the command line; the bytes after
// it are the probe file --probe reads. Every --probe value is replaced by
// that file, every --write value by a file in the harness's private folder:
// the fuzzer never names a file of its own (/dev/zero, the tree's files).
//
// Exit status 0 or 2 is the calculator's answer; anything else, or a
// sanitizer's report, is a crash. Its output goes nowhere (run with
// -close_fd_mask=3, as tools/fuzz.sh does).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "afm_calc.h"
#include "fuzz_files.hpp"

namespace {

const char kProbeMark[] = "@probe";
const std::size_t kMaxArgs = 64;

const afm_fuzz::Folder &folder()
{
    static const afm_fuzz::Folder f("calc");
    return f;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, std::size_t size)
{
    const afm_fuzz::Folder &dir = folder();
    const char *p = reinterpret_cast<const char *>(data);
    const char *end = p + size;
    std::vector<std::string> args = {"afm_calc"};
    const char *probe = end;
    while (p < end) {
        const char *q = p;
        while (q < end && *q != '\n' && *q != '\0') ++q;
        std::string a(p, q);
        p = q < end ? q + 1 : q;
        if (a == kProbeMark) {
            probe = p;
            break;
        }
        if (args.size() > kMaxArgs) return -1;   // nothing new past this many
        args.push_back(std::move(a));
    }
    const std::string probe_path = dir.write("probe.txt", reinterpret_cast<const uint8_t *>(probe), static_cast<std::size_t>(end - probe));
    const std::string write_path = dir.file("calibration.yaml");
    for (std::size_t i = 1; i + 1 < args.size(); ++i) {
        if (args[i] == "--probe") args[i + 1] = probe_path;
        else if (args[i] == "--write") args[i + 1] = write_path;
    }
    std::vector<char *> argv;
    for (auto &a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int rc = afm_calc_main(static_cast<int>(args.size()), argv.data());
    if (rc != 0 && rc != 2) afm_fuzz::broken("afm_calc_main returned neither 0 nor 2");
    return 0;
}
