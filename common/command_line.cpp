#include "command_line.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "placement.hpp"

namespace afm::cli {

namespace {

// The usage's columns: an option and its value in the first kNameWidth,
// its text after, two spaces apart at least; its further lines indented to it.
constexpr std::size_t kIndent = 2, kNameWidth = 19;

std::string num(double x)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", x);
    return buf;
}

std::string wants(const char *what, const std::string &bounds)
{
    return std::string("wants ") + what + (bounds.empty() ? "" : " " + bounds);
}

// One option's lines in the usage.
std::string usage_rows(const OptionRow &r)
{
    std::string head = std::string(kIndent, ' ') + r.name + (r.shown ? std::string(" ") + r.shown : "");
    head += head.size() + 2 <= kIndent + kNameWidth ? std::string(kIndent + kNameWidth - head.size(), ' ') : "  ";
    std::string rows = head;
    for (const char *p = r.help; *p; ++p) {
        rows += *p;
        if (*p == '\n') rows += std::string(kIndent + kNameWidth, ' ');
    }
    return rows + "\n";
}

bool is_option(const std::string &a) { return a.size() > 1 && a[0] == '-'; }

// The row named `name` (an option: is_option), or rows.size().
std::size_t find_row(const std::vector<const OptionRow *> &rows, const std::string &name)
{
    for (std::size_t i = 0; i < rows.size(); ++i)
        if (name == rows[i]->name) return i;
    return rows.size();
}

// The first positional row not yet given, else the last positional row
// (given), else rows.size().
std::size_t positional_row(const std::vector<const OptionRow *> &rows, const std::vector<bool> &seen)
{
    std::size_t last = rows.size();
    for (std::size_t i = 0; i < rows.size(); ++i)
        if (!is_option(rows[i]->name)) {
            if (!seen[i]) return i;
            last = i;
        }
    return last;
}

// The state of one parse: the rows, what was seen, and the refusal's form.
struct Reader {
    const char *program;
    const std::vector<const OptionRow *> &rows;
    const std::function<std::string(std::size_t, const std::string &)> &set;
    std::vector<bool> seen;
    std::string positional;   // the last positional argument taken

    Parsed refuse(const std::string &what) const { return {kExitInput, "", refusal(program, what)}; }

    // Row i's value: set, or refused naming the option and the value.
    Parsed take(std::size_t i, const std::string &value)
    {
        seen[i] = true;
        const std::string why = set(i, value);
        if (!why.empty()) return refuse(std::string(rows[i]->name) + ": " + why + " (got '" + value + "')");
        return {};
    }

    // argv[*i], an option: its value from "=VALUE" or the next argument.
    Parsed option(int argc, char **argv, int *i)
    {
        const std::string a = argv[*i];
        const std::size_t eq = a.rfind("--", 0) == 0 ? a.find('=') : std::string::npos;
        const std::string name = a.substr(0, eq);
        const std::size_t r = find_row(rows, name);
        if (r == rows.size() || !is_option(rows[r]->name))
            return refuse(name + ": unknown option (" + program + " --help lists them)");
        if (!rows[r]->shown) {
            if (eq != std::string::npos) return refuse(name + ": takes no value (got '" + a.substr(eq + 1) + "')");
            return take(r, "");
        }
        if (eq != std::string::npos) return take(r, a.substr(eq + 1));
        if (*i + 1 >= argc) return refuse(name + ": needs a value (" + rows[r]->shown + ")");
        return take(r, argv[++*i]);
    }

    // a, a word that is not an option: the next positional argument.
    Parsed word(const std::string &a)
    {
        const std::size_t r = positional_row(rows, seen);
        if (r == rows.size()) return refuse("'" + a + "': not an option (" + program + " --help lists them)");
        if (seen[r]) return refuse(std::string(rows[r]->name) + ": one only (got '" + a + "' after '" + positional + "')");
        positional = a;
        return take(r, a);
    }

    Parsed missing() const
    {
        for (std::size_t i = 0; i < rows.size(); ++i)
            if (rows[i]->required && !seen[i])
                return refuse(std::string(rows[i]->name) + (rows[i]->shown && is_option(rows[i]->name) ? std::string(" ") + rows[i]->shown : "") +
                              ": required (" + program + " --help: the usage)");
        return {};
    }
};

}  // namespace

std::string Range::text() const
{
    const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
    if (has_lo && has_hi) return "in " + std::string(lo_open ? "(" : "[") + num(lo) + ", " + num(hi) + (hi_open ? ")" : "]");
    if (has_lo) return (lo_open ? "> " : ">= ") + num(lo);
    if (has_hi) return (hi_open ? "< " : "<= ") + num(hi);
    return "";
}

Range at_least(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false}; }
Range above(double lo) { return {lo, std::numeric_limits<double>::infinity(), true, false}; }
Range in_range(double lo, double hi, bool hi_open) { return {lo, hi, false, hi_open}; }

std::string read_text(const std::string &v, std::string *out)
{
    if (v.empty()) return "wants a value, not an empty word";
    *out = v;
    return "";
}

std::string wants_whole(long long lo, long long hi, const char *what)
{
    const std::string bounds = lo > std::numeric_limits<long long>::min() && hi < std::numeric_limits<long long>::max()
                                   ? "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]"
                               : lo > std::numeric_limits<long long>::min() ? ">= " + std::to_string(lo)
                               : hi < std::numeric_limits<long long>::max() ? "<= " + std::to_string(hi)
                                                                            : "";
    return wants(what, bounds);
}

std::string read_whole(const std::string &v, long long lo, long long hi, long long *out, const char *what)
{
    char *end = nullptr;
    errno = 0;
    const long long n = v.empty() || std::isspace(static_cast<unsigned char>(v[0])) ? 0 : std::strtoll(v.c_str(), &end, 10);
    if (!end || *end || errno != 0 || n < lo || n > hi) return wants_whole(lo, hi, what);
    *out = n;
    return "";
}

std::string read_number(const std::string &v, const Range &r, double *out, const char *what)
{
    char *end = nullptr;
    const double x = v.empty() || std::isspace(static_cast<unsigned char>(v[0])) ? NAN : std::strtod(v.c_str(), &end);
    const bool inside = (r.lo_open ? x > r.lo : x >= r.lo) && (r.hi_open ? x < r.hi : x <= r.hi);
    if (!end || *end || !std::isfinite(x) || !inside) return wants(what, r.text());
    *out = x;
    return "";
}

std::string read_cpus(const std::string &v, std::vector<int> *out)
{
    return parse_cpu_list(v, out) ? "" : "wants a CPU list such as 1 or 0-1";
}

std::string read_choice(const std::string &v, const std::vector<std::string> &allowed, std::string *out)
{
    for (const auto &a : allowed)
        if (v == a) {
            *out = v;
            return "";
        }
    std::string list;
    for (std::size_t i = 0; i < allowed.size(); ++i)
        list += (i == 0 ? "" : i + 1 == allowed.size() ? " or " : ", ") + allowed[i];
    return "wants " + list;
}

std::string usage_text(const std::string &head, const std::vector<const OptionRow *> &rows)
{
    std::string u = head;
    std::vector<std::string> sections;
    for (const auto *r : rows)
        if (r->section && std::find(sections.begin(), sections.end(), r->section) == sections.end()) sections.push_back(r->section);
    for (const auto &section : sections) {
        u += section + "\n";
        for (const auto *r : rows)
            if (r->section && section == r->section) u += usage_rows(*r);
    }
    return u;
}

std::string refusal(const char *program, const std::string &what) { return std::string(program) + ": " + what + "\n"; }

Parsed parse_rows(const char *program, const std::string &usage, const std::vector<const OptionRow *> &rows, int argc, char **argv,
                  const std::function<std::string(std::size_t, const std::string &)> &set)
{
    Reader reader{program, rows, set, std::vector<bool>(rows.size(), false), ""};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "-h" || a == "--help") return {kExitOk, usage, ""};
        const Parsed p = is_option(a) ? reader.option(argc, argv, &i) : reader.word(a);
        if (p.code >= 0) return p;
    }
    return reader.missing();
}

int answer(const Parsed &p)
{
    std::fputs(p.out.c_str(), stdout);
    std::fputs(p.err.c_str(), stderr);
    return p.code;
}

}  // namespace afm::cli
