// A program's command line, described once: a table of its options (each
// one's name, the value as the usage shows it, its usage text and the one
// check of its value), from which both its parser and its usage come.
// Every host program reads its argv through it (bus/run_process.hpp's
// Process for a run's processes).
//
// Contract:
//  - argv is read left to right. "-h" or "--help" where an option may
//    stand: the usage on stdout, exit kExitOk (process.hpp). An option is its name alone (a
//    flag: "--quiet"), or a value option's name and the next argument
//    ("--scene F", whatever F begins with) or "--name=VALUE". A word that
//    does not begin with '-' is the next positional argument, for a
//    program that has them (Options whose names do not begin with '-', in
//    the table's order). The last of a repeated option wins.
//  - A refusal is one line on stderr, exit kExitInput:
//      PROG: --opt: why (got 'value')
//    for a value its reader refuses, a flag given a value ("--quiet=yes");
//      PROG: --opt: why
//    for an unknown option, a value option at the end without its value, a
//    required option (or positional) missing, a positional too many.
//  - The readers (read_*) check and convert a value, each written once:
//    text (not empty), a whole number or a number in a range, a CPU list
//    (placement.hpp), one word of a list. They answer "" when they took the
//    value, else why ("wants ..."), which the parser completes as above.
//  - Parsing prints nothing: Parsed carries the exit code and the texts.
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "process.hpp"

namespace afm::cli {

// What a command line says: go on (code -1), or exit with code, having
// printed out (stdout) and err (stderr).
struct Parsed {
    int code = -1;
    std::string out;
    std::string err;
};

// One option, whatever the program's options struct: what the parser and
// the usage read.
struct OptionRow {
    const char *name;      // "--stall-s"; a name without '-' ("RUN_DIR"): the positional argument
    const char *shown;     // the value as the usage shows it ("S"); nullptr: a flag
    const char *section;   // the usage's heading it is listed under ("options:"); nullptr: named in the usage's first line only
    const char *help;      // its usage text; lines after the first are indented by the formatter
    bool required = false; // refused when absent
};

// Checks `value` and stores it in the options struct: "" when taken, else
// why ("wants ..."): the parser adds the program, the option and the value.
template <class O>
using Setter = std::function<std::string(const std::string &value, O *o)>;

template <class O>
struct Option : OptionRow {
    Setter<O> set;
    Option(OptionRow row, Setter<O> s) : OptionRow(row), set(std::move(s)) {}
};

// A program's command line: its name, the usage's head (what it is, in a
// few lines, starting "usage: "), its options in the usage's order, and a
// check of what they say together ("" or the refusal's text after "PROG: ").
template <class O>
struct CommandLine {
    const char *program;
    std::string head;
    std::vector<Option<O>> options;
    std::function<std::string(const O &)> check_together = nullptr;

    std::string usage() const;
    Parsed parse(int argc, char **argv, O *o) const;
};

// ---- the readers, written once ---------------------------------------------

// Bounds of a number: lo and hi, each inclusive or not; infinite: none.
struct Range {
    double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
    bool lo_open = false, hi_open = false;
    std::string text() const;   // ">= 0", "> 0", "in [0, 1)"
};
Range at_least(double lo);
Range above(double lo);
Range in_range(double lo, double hi, bool hi_open = false);

// Not empty.
std::string read_text(const std::string &v, std::string *out);
// A whole number in [lo, hi] (strtoll, the whole word); `what` names it in
// the refusal ("a number of blocks"), whose bounds wants_whole writes (a
// bound at the end of long long's range is no bound: not shown).
std::string read_whole(const std::string &v, long long lo, long long hi, long long *out, const char *what = "a whole number");
std::string wants_whole(long long lo, long long hi, const char *what);
// A finite number in `r` (strtod, the whole word).
std::string read_number(const std::string &v, const Range &r, double *out, const char *what = "a number");
// A CPU list as the kernel writes one ("0", "1-3", "0,2-3"; "": no CPU).
std::string read_cpus(const std::string &v, std::vector<int> *out);
// One of `allowed`.
std::string read_choice(const std::string &v, const std::vector<std::string> &allowed, std::string *out);

// ---- setters over a member of the options struct ----------------------------

template <class O>
Setter<O> text(std::string O::*m)
{
    return [m](const std::string &v, O *o) { return read_text(v, &(o->*m)); };
}
template <class O>
Setter<O> flag(bool O::*m, bool to = true)
{
    return [m, to](const std::string &, O *o) { o->*m = to; return std::string(); };
}
// A whole number in [lo, hi] that the member's type I holds (hi beyond
// it: I's largest, the refusal showing hi as given).
template <class O, class I>
Setter<O> whole(I O::*m, long long lo, long long hi = std::numeric_limits<long long>::max(), const char *what = "a whole number")
{
    using U = unsigned long long;
    const long long top = hi >= 0 && static_cast<U>(std::numeric_limits<I>::max()) < static_cast<U>(hi)
                              ? static_cast<long long>(std::numeric_limits<I>::max())
                              : hi;
    return [=](const std::string &v, O *o) {
        long long n = 0;
        if (!read_whole(v, lo, top, &n, what).empty()) return wants_whole(lo, hi, what);
        o->*m = static_cast<I>(n);
        return std::string();
    };
}
template <class O>
Setter<O> number(double O::*m, Range r, const char *what = "a number")
{
    return [=](const std::string &v, O *o) { return read_number(v, r, &(o->*m), what); };
}
template <class O>
Setter<O> cpus(std::vector<int> O::*m)
{
    return [m](const std::string &v, O *o) { return read_cpus(v, &(o->*m)); };
}
template <class O>
Setter<O> choice(std::string O::*m, std::vector<std::string> allowed)
{
    return [m, allowed](const std::string &v, O *o) { return read_choice(v, allowed, &(o->*m)); };
}

// ---- the parser and the usage, over the rows (command_line.cpp) -------------------

// The usage: the head, then each section's options, in the order of the rows.
std::string usage_text(const std::string &head, const std::vector<const OptionRow *> &rows);
// Reads argv against `rows`; set(i, value) stores row i's value ("" or why).
Parsed parse_rows(const char *program, const std::string &usage, const std::vector<const OptionRow *> &rows, int argc, char **argv,
                  const std::function<std::string(std::size_t, const std::string &)> &set);
// The refusal's line: "PROG: WHAT\n".
std::string refusal(const char *program, const std::string &what);
// Prints what `p` says; -1 to go on, else the exit code.
int answer(const Parsed &p);

// The command line read into `o` (--help and refusals printed): -1 to go
// on, else the exit code. A run's process reads it through run_process.
template <class O>
int read_command_line(const CommandLine<O> &cl, int argc, char **argv, O *o)
{
    return answer(cl.parse(argc, argv, o));
}

template <class O>
std::string CommandLine<O>::usage() const
{
    std::vector<const OptionRow *> rows;
    for (const auto &opt : options) rows.push_back(&opt);
    return usage_text(head, rows);
}

template <class O>
Parsed CommandLine<O>::parse(int argc, char **argv, O *o) const
{
    std::vector<const OptionRow *> rows;
    for (const auto &opt : options) rows.push_back(&opt);
    Parsed p = parse_rows(program, usage_text(head, rows), rows, argc, argv,
                          [&](std::size_t i, const std::string &v) { return options[i].set(v, o); });
    if (p.code < 0 && check_together)
        if (const std::string why = check_together(*o); !why.empty()) return {kExitInput, "", refusal(program, why)};
    return p;
}

}  // namespace afm::cli
