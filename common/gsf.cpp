#include "gsf.hpp"

#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
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

[[noreturn]] void refuse(const std::string &path, const std::string &what)
{
    throw std::runtime_error(path + ": " + what);
}

double header_num(const std::string &path, const std::vector<std::pair<std::string, std::string>> &h, const std::string &key,
                  const double *dflt)
{
    for (const auto &[k, v] : h) {
        if (k != key) continue;
        char *end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end != '\0' || !std::isfinite(x)) refuse(path, "GSF header " + key + " must be a finite number, got '" + v + "'");
        return x;
    }
    if (!dflt) refuse(path, "GSF header " + key + " is missing");
    return *dflt;
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
    std::istringstream lines(raw.substr(sizeof kMagic - 1, nul - (sizeof kMagic - 1)));
    for (std::string line; std::getline(lines, line);) {
        if (line.empty()) continue;
        const std::size_t eq = line.find('=');
        if (eq == std::string::npos) refuse(path, "GSF header line without '=': '" + line.substr(0, 80) + "'");
        auto trim = [](std::string s) {
            const std::size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
            return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
        };
        h.emplace_back(trim(line.substr(0, eq)), trim(line.substr(eq + 1)));
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
    for (const char *k : {"XRes", "YRes"}) {
        const double v = header_num(path, h, k, nullptr);
        if (v != std::floor(v) || v < 2 || v > kGsfMaxRes)
            refuse(path, std::string("GSF header ") + k + " must be an integer in [2, " + std::to_string(kGsfMaxRes) + "], got '" +
                             header_str(h, k, "") + "'");
        (k[0] == 'X' ? g.xres : g.yres) = static_cast<int>(v);
    }
    for (const char *k : {"XReal", "YReal"}) {
        const double v = header_num(path, h, k, nullptr);
        if (!(v > 0)) refuse(path, std::string("GSF header ") + k + " must be positive, got '" + header_str(h, k, "") + "'");
        (k[0] == 'X' ? g.xreal_m : g.yreal_m) = v;
    }
    const double zero = 0;
    g.xoff_m = header_num(path, h, "XOffset", &zero);
    g.yoff_m = header_num(path, h, "YOffset", &zero);
    g.xy_units = header_str(h, "XYUnits", "m");
    g.z_units = header_str(h, "ZUnits", "");
    g.title = header_str(h, "Title", "");
    if (require_metres && g.xy_units != "m") refuse(path, "GSF header XYUnits must be m, got '" + g.xy_units + "'");
    if (require_metres && g.z_units != "m") refuse(path, "GSF header ZUnits must be m (heights), got '" + g.z_units + "'");
    for (const auto &kv : h)
        if (kv.first != "XRes" && kv.first != "YRes" && kv.first != "XReal" && kv.first != "YReal" && kv.first != "XOffset" &&
            kv.first != "YOffset" && kv.first != "XYUnits" && kv.first != "ZUnits" && kv.first != "Title")
            g.keys.push_back(kv);
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
