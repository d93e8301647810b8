#include "gsf.hpp"

#include "text.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <stdexcept>

namespace afm {

namespace {
const char kMagic[] = "Gwyddion Simple Field 1.0\n";
constexpr std::size_t kMaxHeaderBytes = 65536;   // a header longer than this is not a GSF file's

std::string fmt(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", v);
    return b;
}

// `what` quotes the file's own text through printable(); the path is escaped here.
[[noreturn]] void refuse(const std::string &path, const std::string &what)
{
    throw std::runtime_error(printable(path) + ": " + what);
}

// A header value as a message quotes it: escaped, at most 80 bytes.
std::string header_quoted(const std::string &v)
{
    return "'" + printable(v.substr(0, 80)) + (v.size() > 80 ? "...'" : "'");
}

// The field `r.key` as a number in its range (0 when missing and not required).
double header_num(const std::string &path, const std::vector<std::pair<std::string, std::string>> &h, const GsfRange &r)
{
    for (const auto &[k, v] : h) {
        if (k != r.key) continue;
        char *end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end != '\0' || !std::isfinite(x) || (r.integer && x != std::floor(x)) || !(x >= r.lo && x <= r.hi))
            refuse(path, std::string("GSF header ") + r.key + " must be " + (r.integer ? "a whole number" : "a number") + " in [" +
                             fmt(r.lo) + ", " + fmt(r.hi) + "], got " + header_quoted(v));
        return x;
    }
    if (r.required) refuse(path, std::string("GSF header ") + r.key + " is missing");
    return 0;
}

std::string header_str(const std::vector<std::pair<std::string, std::string>> &h, const std::string &key, const std::string &dflt)
{
    for (const auto &[k, v] : h)
        if (k == key) return v;
    return dflt;
}

// The header's "Key = value" lines before the NUL; *data_start: the first data byte.
std::vector<std::pair<std::string, std::string>> parse_header(const std::string &path, const std::string &raw, std::size_t *data_start)
{
    if (raw.compare(0, sizeof kMagic - 1, kMagic) != 0) refuse(path, "not a Gwyddion Simple Field file (no 'Gwyddion Simple Field 1.0' line)");
    const std::size_t nul = raw.find('\0');
    if (nul == std::string::npos || nul > kMaxHeaderBytes) refuse(path, "no NUL padding after the GSF header (within 64 KiB)");
    *data_start = nul + (4 - nul % 4);
    if (*data_start > raw.size()) refuse(path, "the GSF header's NUL padding is cut short");
    for (std::size_t i = nul; i < *data_start; ++i)
        if (raw[i] != '\0') refuse(path, "the GSF header's padding is not NULs");
    std::vector<std::pair<std::string, std::string>> h;
    std::set<std::string> seen;
    std::istringstream lines(raw.substr(sizeof kMagic - 1, nul - (sizeof kMagic - 1)));
    for (std::string line; std::getline(lines, line);) {
        if (line.empty()) continue;
        const std::size_t eq = line.find('=');
        if (eq == std::string::npos) refuse(path, "GSF header line without '=': " + header_quoted(line));
        auto trim = [](std::string s) {
            const std::size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
            return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
        };
        std::string key = trim(line.substr(0, eq));
        if (!seen.insert(key).second) refuse(path, "GSF header " + header_quoted(key) + " given twice");   // which would a reader take?
        h.emplace_back(std::move(key), trim(line.substr(eq + 1)));
    }
    return h;
}
}  // namespace

bool write_gsf_grid(const std::string &path, const GsfGrid &g, std::string *err)
{
    std::string header = std::string(kMagic) + "XRes = " + std::to_string(g.xres) + "\nYRes = " + std::to_string(g.yres) +
                         "\nXReal = " + fmt(g.xreal_m) + "\nYReal = " + fmt(g.yreal_m) + "\nXOffset = " + fmt(g.xoff_m) +
                         "\nYOffset = " + fmt(g.yoff_m) + "\nXYUnits = " + g.xy_units + "\nZUnits = " + g.z_units +
                         "\nTitle = " + g.title + "\n";
    for (const auto &[key, value] : g.keys) {
        if (key.empty() || key.find_first_of(" =\n\r\t") != std::string::npos || value.find_first_of("\n\r") != std::string::npos) {
            if (err) *err = path + ": GSF header key '" + key + "' or its value cannot be written (space, '=' or a line break)";
            return false;
        }
        header += key + " = " + value + "\n";
    }
    header.append(4 - header.size() % 4, '\0');
    std::ofstream out(path, std::ios::binary);
    if (!out) {
        if (err) *err = "cannot open " + path + " for writing";
        return false;
    }
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    static_assert(sizeof(float) == 4, "GSF stores float32");
    // x86-64 and Cortex hosts are little-endian; GSF is little-endian
    out.write(reinterpret_cast<const char *>(g.values.data()), static_cast<std::streamsize>(4 * g.values.size()));
    out.close();
    if (!out) {
        if (err) *err = "write failed on " + path;
        return false;
    }
    return true;
}

GsfGrid read_gsf(const std::string &path, bool require_metres)
{
    struct stat st{};
    if (::stat(path.c_str(), &st) != 0) refuse(path, std::string("cannot read the GSF file: ") + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) refuse(path, "is not a regular file (a GSF file was expected)");
    const auto max_bytes = static_cast<off_t>(kMaxHeaderBytes + 4ull * kGsfMaxRes * kGsfMaxRes);
    if (st.st_size > max_bytes) refuse(path, "is " + std::to_string(st.st_size) + " bytes, more than a " + std::to_string(kGsfMaxRes) + " x " +
                                             std::to_string(kGsfMaxRes) + " GSF file's");
    std::ifstream in(path, std::ios::binary);
    if (!in) refuse(path, "cannot open the GSF file");
    const std::string raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::size_t start = 0;
    const auto h = parse_header(path, raw, &start);
    GsfGrid g;
    double v[std::size(kGsfRanges)];
    for (std::size_t i = 0; i < std::size(kGsfRanges); ++i) v[i] = header_num(path, h, kGsfRanges[i]);
    // kGsfRanges' order: XRes, YRes, XReal, YReal, XOffset, YOffset
    g.xres = static_cast<int>(v[0]);
    g.yres = static_cast<int>(v[1]);
    g.xreal_m = v[2];
    g.yreal_m = v[3];
    g.xoff_m = v[4];
    g.yoff_m = v[5];
    g.xy_units = header_str(h, "XYUnits", "m");
    g.z_units = header_str(h, "ZUnits", "");
    g.title = header_str(h, "Title", "");
    if (require_metres && g.xy_units != "m") refuse(path, "GSF header XYUnits must be m, got " + header_quoted(g.xy_units));
    if (require_metres && g.z_units != "m") refuse(path, "GSF header ZUnits must be m (heights), got " + header_quoted(g.z_units));
    for (const auto &kv : h) {
        const bool numeric = std::any_of(std::begin(kGsfRanges), std::end(kGsfRanges), [&](const GsfRange &r) { return kv.first == r.key; });
        if (!numeric && kv.first != "XYUnits" && kv.first != "ZUnits" && kv.first != "Title") g.keys.push_back(kv);
    }
    const std::size_t n = static_cast<std::size_t>(g.xres) * static_cast<std::size_t>(g.yres);
    if (raw.size() - start != 4 * n)
        refuse(path, std::to_string(raw.size() - start) + " data bytes for XRes " + std::to_string(g.xres) + " x YRes " +
                         std::to_string(g.yres) + " float32 values (" + std::to_string(4 * n) + " expected)");
    g.values.resize(n);
    std::memcpy(g.values.data(), raw.data() + start, 4 * n);   // little-endian host
    for (std::size_t i = 0; i < n; ++i)
        if (!std::isfinite(g.values[i]))
            refuse(path, "value at row " + std::to_string(i / static_cast<std::size_t>(g.xres)) + ", column " +
                             std::to_string(i % static_cast<std::size_t>(g.xres)) + " is not finite (" + fmt(g.values[i]) + ")");
    return g;
}

}  // namespace afm
