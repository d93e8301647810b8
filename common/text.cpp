// The one escaper of the C++ side (text.hpp states the rule).
#include "text.hpp"

#include <cstddef>

namespace afm {
namespace {

// The length of the valid UTF-8 sequence at s[i] (2 to 4), or 0 when the
// bytes there are not one (RFC 3629's table: no overlong form, no
// surrogate, nothing past U+10FFFF, no cut sequence). s[i] is >= 0x80.
std::size_t utf8_sequence_length(std::string_view s, std::size_t i)
{
    const auto at = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
    const unsigned char b0 = at(i);
    std::size_t n = 0;
    unsigned char lo = 0x80, hi = 0xBF;   // the allowed range of the second byte
    if (b0 >= 0xC2 && b0 <= 0xDF) n = 2;
    else if (b0 >= 0xE0 && b0 <= 0xEF) {
        n = 3;
        if (b0 == 0xE0) lo = 0xA0;        // overlong below U+0800
        if (b0 == 0xED) hi = 0x9F;        // surrogates U+D800-U+DFFF
    } else if (b0 >= 0xF0 && b0 <= 0xF4) {
        n = 4;
        if (b0 == 0xF0) lo = 0x90;        // overlong below U+10000
        if (b0 == 0xF4) hi = 0x8F;        // past U+10FFFF
    } else
        return 0;
    if (i + n > s.size()) return 0;
    if (at(i + 1) < lo || at(i + 1) > hi) return 0;
    for (std::size_t k = 2; k < n; ++k)
        if (at(i + k) < 0x80 || at(i + k) > 0xBF) return 0;
    return n;
}

void append_escape(std::string &out, unsigned char b)
{
    static const char hex[] = "0123456789ABCDEF";
    out += "\\x";
    out += hex[b >> 4];
    out += hex[b & 0xF];
}

}  // namespace

std::string printable(std::string_view s)
{
    std::string out;
    out.reserve(s.size());
    std::size_t i = 0;
    while (i < s.size()) {
        const auto b = static_cast<unsigned char>(s[i]);
        if (b == '\\') {
            out += "\\\\";
            ++i;
        } else if (b < 0x20 || b == 0x7F) {
            append_escape(out, b);
            ++i;
        } else if (b < 0x80) {
            out += static_cast<char>(b);
            ++i;
        } else if (const std::size_t n = utf8_sequence_length(s, i); n == 0) {
            append_escape(out, b);        // not valid UTF-8: this byte alone
            ++i;
        } else if (n == 2 && b == 0xC2 && static_cast<unsigned char>(s[i + 1]) <= 0x9F) {
            append_escape(out, b);        // a C1 control, U+0080-U+009F
            append_escape(out, static_cast<unsigned char>(s[i + 1]));
            i += 2;
        } else {
            out.append(s.substr(i, n));
            i += n;
        }
    }
    return out;
}

}  // namespace afm
