// Unity tests of the one escaper (common/text.hpp): every C0 and C1 control
// byte, DEL, the backslash, raw high bytes and each kind of invalid UTF-8
// come out as \xHH; valid printable UTF-8 stays; the result is valid UTF-8
// (nlohmann::json's strict dump takes it) with no control byte, and undoing
// the escapes gives back the input, for every string of one and two bytes
// and for random strings. analysis/text.py's test holds the Python side to
// the same vectors (kVectors below, the same table there).
#include <nlohmann/json.hpp>   // before unity.h, whose isnan macro breaks nlohmann/json

#include "text.hpp"

#include <unity.h>

#include <cstdint>
#include <cstdio>
#include <string>

namespace {

std::string hex_escape(unsigned b)
{
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02X", b & 0xFFu);
    return buf;
}

// The escapes undone: "\\" a backslash, "\xHH" the byte, anything else itself.
std::string unescape(const std::string &s)
{
    std::string out;
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] != '\\') {
            out += s[i];
            continue;
        }
        TEST_ASSERT_TRUE_MESSAGE(i + 1 < s.size(), "a lone backslash at the end");
        if (s[i + 1] == '\\') {
            out += '\\';
            ++i;
            continue;
        }
        TEST_ASSERT_TRUE_MESSAGE(i + 3 < s.size() && s[i + 1] == 'x', "a backslash neither doubled nor \\xHH");
        out += static_cast<char>(std::stoi(s.substr(i + 2, 2), nullptr, 16));
        i += 3;
    }
    return out;
}

// What the escaper's output must be, whatever came in: no C0 control, no
// DEL, no C1 control, and valid UTF-8 by nlohmann::json's own check.
void expect_safe(const std::string &out)
{
    for (std::size_t i = 0; i < out.size(); ++i) {
        const auto b = static_cast<unsigned char>(out[i]);
        TEST_ASSERT_FALSE_MESSAGE(b < 0x20 || b == 0x7F, "a C0 control or DEL left");
        if (b == 0xC2 && i + 1 < out.size()) {
            TEST_ASSERT_FALSE_MESSAGE(static_cast<unsigned char>(out[i + 1]) <= 0x9F, "a C1 control left");
        }
    }
    try {
        (void)nlohmann::json(out).dump();
    } catch (const nlohmann::json::exception &e) {
        TEST_FAIL_MESSAGE(e.what());
    }
}

void expect_round_trip(const std::string &in)
{
    const std::string out = afm::printable(in);
    expect_safe(out);
    TEST_ASSERT_TRUE_MESSAGE(unescape(out) == in, out.c_str());
}

// Inputs and what the escaper makes of them, one row a case (the same table
// as tests/py/test_text.py, so the two escapers cannot drift apart).
struct Vector {
    const char *in;
    std::size_t len;
    const char *out;
    int line;
};
#define V(in, out) {in, sizeof(in) - 1, out, __LINE__}
const Vector kVectors[] = {
    V("plain text 1.0 = 2", "plain text 1.0 = 2"),
    V("back\\slash", "back\\\\slash"),
    V("\x1b[2J\x1b]0;title\x07", "\\x1B[2J\\x1B]0;title\\x07"),
    V("a\nb\rc\td", "a\\x0Ab\\x0Dc\\x09d"),
    V("nul\0in", "nul\\x00in"),
    V("del\x7f", "del\\x7F"),
    V("\xc2\x85next line, \xc2\x9b" "CSI", "\\xC2\\x85next line, \\xC2\\x9BCSI"),
    V("nbsp\xc2\xa0 \xc2\xb5m caf\xc3\xa9", "nbsp\xc2\xa0 \xc2\xb5m caf\xc3\xa9"),
    V("\xe6\x97\xa5\xe6\x9c\xac \xf0\x9f\x98\x80", "\xe6\x97\xa5\xe6\x9c\xac \xf0\x9f\x98\x80"),
    V("\xed\x9f\xbf \xee\x80\x80 \xf4\x8f\xbf\xbf", "\xed\x9f\xbf \xee\x80\x80 \xf4\x8f\xbf\xbf"),
    V("\xff\xfe" "X", "\\xFF\\xFEX"),
    V("\x80\x9f\xbf", "\\x80\\x9F\\xBF"),
    V("\xc0\x80", "\\xC0\\x80"),                   // overlong NUL
    V("\xc1\xbf", "\\xC1\\xBF"),                   // overlong
    V("\xe0\x80\x80", "\\xE0\\x80\\x80"),          // overlong, 3 bytes
    V("\xf0\x80\x80\x80", "\\xF0\\x80\\x80\\x80"), // overlong, 4 bytes
    V("\xed\xa0\x80", "\\xED\\xA0\\x80"),          // a surrogate, U+D800
    V("\xf4\x90\x80\x80", "\\xF4\\x90\\x80\\x80"), // past U+10FFFF
    V("\xf5\x80\x80\x80", "\\xF5\\x80\\x80\\x80"), // no such lead byte
    V("\xe2\x82" "A", "\\xE2\\x82A"),              // cut by an ASCII byte
    V("end\xe2\x82", "end\\xE2\\x82"),             // cut by the end
    V("\xf0\x9f\x98", "\\xF0\\x9F\\x98"),          // cut 4-byte sequence
};
#undef V

}  // namespace

void setUp() {}
void tearDown() {}

void test_the_table_of_vectors_comes_out_as_written()
{
    for (const Vector &v : kVectors) {
        const std::string out = afm::printable(std::string(v.in, v.len));
        char what[64];
        std::snprintf(what, sizeof what, "row at line %d", v.line);
        TEST_ASSERT_EQUAL_STRING_MESSAGE(v.out, out.c_str(), what);
        expect_round_trip(std::string(v.in, v.len));
    }
}

void test_every_c0_control_and_del_becomes_one_escape()
{
    for (unsigned b = 0; b < 0x20; ++b)
        TEST_ASSERT_EQUAL_STRING(("k" + hex_escape(b) + "v").c_str(),
                                 afm::printable(std::string("k") + static_cast<char>(b) + "v").c_str());
    TEST_ASSERT_EQUAL_STRING("\\x7F", afm::printable("\x7f").c_str());
}

void test_every_c1_control_in_utf8_becomes_two_escapes()
{
    for (unsigned c = 0x80; c <= 0x9F; ++c) {
        const std::string in = {'\xc2', static_cast<char>(c)};
        TEST_ASSERT_EQUAL_STRING((hex_escape(0xC2) + hex_escape(c)).c_str(), afm::printable(in).c_str());
    }
}

void test_every_raw_high_byte_alone_becomes_one_escape()
{
    for (unsigned b = 0x80; b <= 0xFF; ++b)
        TEST_ASSERT_EQUAL_STRING(("a" + hex_escape(b) + "b").c_str(),
                                 afm::printable(std::string("a") + static_cast<char>(b) + "b").c_str());
}

void test_printable_ascii_stays_and_the_backslash_doubles()
{
    for (unsigned b = 0x20; b < 0x7F; ++b) {
        const std::string in(1, static_cast<char>(b));
        TEST_ASSERT_EQUAL_STRING(b == '\\' ? "\\\\" : in.c_str(), afm::printable(in).c_str());
    }
}

void test_every_string_of_one_or_two_bytes_comes_out_safe_and_reversible()
{
    for (unsigned a = 0; a < 256; ++a) {
        expect_round_trip(std::string(1, static_cast<char>(a)));
        for (unsigned b = 0; b < 256; ++b) expect_round_trip({static_cast<char>(a), static_cast<char>(b)});
    }
}

void test_random_strings_come_out_safe_and_reversible()
{
    uint64_t x = 0x9E3779B97F4A7C15ull;   // xorshift64, a fixed seed: the same strings every run
    for (int n = 0; n < 20000; ++n) {
        std::string s;
        const int len = static_cast<int>(x % 12);
        for (int k = 0; k < len; ++k) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Half the bytes from the high half, where UTF-8's leads and continuations are.
            s += static_cast<char>((x & 1) ? 0x80 | ((x >> 8) & 0x7F) : (x >> 8) & 0xFF);
        }
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        expect_round_trip(s);
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_table_of_vectors_comes_out_as_written);
    RUN_TEST(test_every_c0_control_and_del_becomes_one_escape);
    RUN_TEST(test_every_c1_control_in_utf8_becomes_two_escapes);
    RUN_TEST(test_every_raw_high_byte_alone_becomes_one_escape);
    RUN_TEST(test_printable_ascii_stays_and_the_backslash_doubles);
    RUN_TEST(test_every_string_of_one_or_two_bytes_comes_out_safe_and_reversible);
    RUN_TEST(test_random_strings_come_out_safe_and_reversible);
    return UNITY_END();
}
