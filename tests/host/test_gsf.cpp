// Unity tests of the GSF reader's ranges (common/gsf.hpp kGsfRanges, one
// table for every numeric header field): each entry is taken at both of its
// bounds and refused just past each, naming the field and the value; a
// missing required field is refused and a missing offset is 0; the finite
// but huge extent that crashed the simulator (XReal = 1e300) is refused; the
// file's own text (a header line, a unit, its name) is quoted escaped.
#include "gsf.hpp"

#include <unity.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>

namespace {

std::string dir;

// A valid header's fields, each of which a test may replace (or drop: "").
std::map<std::string, std::string> valid_fields()
{
    return {{"XRes", "2"}, {"YRes", "2"}, {"XReal", "1e-6"}, {"YReal", "1e-6"}, {"XOffset", "0"}, {"YOffset", "0"}};
}

// A GSF file with these fields (and extra header text), XRes x YRes zeros.
std::string write(const std::map<std::string, std::string> &fields, const std::string &extra = "", const std::string &name = "t.gsf")
{
    std::string h = "Gwyddion Simple Field 1.0\n";
    for (const auto &[k, v] : fields)
        if (!v.empty()) h += k + " = " + v + "\n";
    h += (extra.rfind("XYUnits", 0) == 0 ? "" : "XYUnits = m\n") + std::string("ZUnits = m\n") + extra;
    h.append(4 - h.size() % 4, '\0');
    const auto num = [&](const char *k) {
        const auto it = fields.find(k);
        const double v = it == fields.end() || it->second.empty() ? 2 : std::strtod(it->second.c_str(), nullptr);
        return v >= 2 && v <= afm::kGsfMaxRes && v == std::floor(v) ? static_cast<std::size_t>(v) : 2;
    };
    h.append(4 * num("XRes") * num("YRes"), '\0');   // float32 zeros
    const std::string path = dir + "/" + name;
    std::ofstream(path, std::ios::binary) << h;
    return path;
}

// The reader's refusal of path ("" when it reads).
std::string refusal(const std::string &path)
{
    try {
        (void)afm::read_gsf(path);
    } catch (const std::runtime_error &e) {
        return e.what();
    }
    return "";
}

std::string text(double v)
{
    char b[40];
    std::snprintf(b, sizeof b, "%.17g", v);
    return b;
}

void expect_read(const std::string &key, const std::string &value)
{
    auto f = valid_fields();
    f[key] = value;
    const std::string why = refusal(write(f));
    const std::string what = key + " = " + value + ": " + why;
    TEST_ASSERT_TRUE_MESSAGE(why.empty(), what.c_str());
}

void expect_refused(const std::string &key, const std::string &value)
{
    auto f = valid_fields();
    f[key] = value;
    const std::string why = refusal(write(f));
    const std::string what = key + " = " + value + ": " + (why.empty() ? "read" : why);
    TEST_ASSERT_TRUE_MESSAGE(why.find("GSF header " + key) != std::string::npos, what.c_str());
    TEST_ASSERT_TRUE_MESSAGE(why.find("'" + value + "'") != std::string::npos, what.c_str());
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_every_range_holds_at_its_bounds_and_refuses_past_them()
{
    TEST_ASSERT_EQUAL_INT(6, static_cast<int>(std::size(afm::kGsfRanges)));
    for (const afm::GsfRange &r : afm::kGsfRanges) {
        expect_read(r.key, text(r.lo));
        expect_read(r.key, text(r.hi));
        if (r.integer) {
            expect_refused(r.key, text(r.lo - 1));
            expect_refused(r.key, text(r.hi + 1));
            expect_refused(r.key, text(r.lo + 0.5));   // not whole
        } else {
            expect_refused(r.key, text(std::nextafter(r.lo, -HUGE_VAL)));
            expect_refused(r.key, text(std::nextafter(r.hi, HUGE_VAL)));
        }
        for (const char *bad : {"nan", "inf", "-inf", "1e300", "-1e300", "12abc", "0x"}) expect_refused(r.key, bad);
    }
}

void test_the_fields_land_where_the_table_says()
{
    auto f = valid_fields();
    f["XRes"] = "3";
    f["YRes"] = "4";
    f["XReal"] = "2e-6";
    f["YReal"] = "3e-6";
    f["XOffset"] = "-0.5";
    f["YOffset"] = "0.25";
    const afm::GsfGrid g = afm::read_gsf(write(f));
    TEST_ASSERT_EQUAL_INT(3, g.xres);
    TEST_ASSERT_EQUAL_INT(4, g.yres);
    TEST_ASSERT_EQUAL_DOUBLE(2e-6, g.xreal_m);
    TEST_ASSERT_EQUAL_DOUBLE(3e-6, g.yreal_m);
    TEST_ASSERT_EQUAL_DOUBLE(-0.5, g.xoff_m);
    TEST_ASSERT_EQUAL_DOUBLE(0.25, g.yoff_m);
    TEST_ASSERT_EQUAL_INT(12, static_cast<int>(g.values.size()));
}

void test_a_missing_required_field_is_refused_and_a_missing_offset_is_zero()
{
    for (const afm::GsfRange &r : afm::kGsfRanges) {
        auto f = valid_fields();
        f[r.key] = "";
        const std::string why = refusal(write(f));
        if (r.required) {
            TEST_ASSERT_TRUE_MESSAGE(why.find(std::string("GSF header ") + r.key + " is missing") != std::string::npos, why.c_str());
        } else {
            TEST_ASSERT_EQUAL_STRING_MESSAGE("", why.c_str(), r.key);
            const afm::GsfGrid g = afm::read_gsf(write(f));
            TEST_ASSERT_EQUAL_DOUBLE(0.0, r.key[0] == 'X' ? g.xoff_m : g.yoff_m);
        }
    }
}

// The case: a header with finite but huge extents passed the reader
// and ./afm check, and segfaulted sim_afm (MeasuredSurface::height).
void test_a_huge_finite_extent_is_refused()
{
    auto f = valid_fields();
    f["XReal"] = "1e300";
    const std::string why = refusal(write(f));
    TEST_ASSERT_TRUE_MESSAGE(why.find("GSF header XReal must be a number in [1e-10, 1], got '1e300'") != std::string::npos, why.c_str());
}

// Every C0 and C1 control byte in a header line, a unit and the file's name
// comes out escaped (common/text.hpp), never raw.
void test_the_files_own_text_is_quoted_escaped()
{
    for (unsigned b = 1; b < 0xA0; ++b) {
        if (b >= 0x20 && b < 0x7F) continue;
        const std::string raw = b < 0x80 ? std::string(1, static_cast<char>(b)) : std::string{'\xc2', static_cast<char>(b)};
        char esc[16];
        if (b < 0x80) std::snprintf(esc, sizeof esc, "\\x%02X", b);
        else std::snprintf(esc, sizeof esc, "\\xC2\\x%02X", b);
        if (b == '\n' || b == '\r') continue;   // a line break ends a header line: its own case below
        for (const std::string &why : {refusal(write(valid_fields(), "bad" + raw + "line\n")),
                                       refusal(write(valid_fields(), "XYUnits = m" + raw + "x\n", "u.gsf")),
                                       refusal(dir + "/no" + raw + "file.gsf")}) {
            TEST_ASSERT_TRUE_MESSAGE(why.find(esc) != std::string::npos, why.c_str());
            TEST_ASSERT_TRUE_MESSAGE(why.find(raw) == std::string::npos, esc);
        }
    }
    const std::string why = refusal(write(valid_fields(), "\x1b[2J\r\n"));
    TEST_ASSERT_TRUE_MESSAGE(why.find("GSF header line without '=': '\\x1B[2J\\x0D'") != std::string::npos, why.c_str());
}

void test_a_field_given_twice_is_refused()
{
    const std::string why = refusal(write(valid_fields(), "XReal = 2e-6\n"));
    TEST_ASSERT_TRUE_MESSAGE(why.find("GSF header 'XReal' given twice") != std::string::npos, why.c_str());
}

int main()
{
    char tmpl[] = "/tmp/afm-test-gsf-XXXXXX";
    if (!mkdtemp(tmpl)) return 1;
    dir = tmpl;
    UNITY_BEGIN();
    RUN_TEST(test_every_range_holds_at_its_bounds_and_refuses_past_them);
    RUN_TEST(test_the_fields_land_where_the_table_says);
    RUN_TEST(test_a_missing_required_field_is_refused_and_a_missing_offset_is_zero);
    RUN_TEST(test_a_huge_finite_extent_is_refused);
    RUN_TEST(test_the_files_own_text_is_quoted_escaped);
    RUN_TEST(test_a_field_given_twice_is_refused);
    const int failures = UNITY_END();
    std::system(("rm -rf " + dir).c_str());
    return failures;
}
