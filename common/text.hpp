// Text from outside (a file, a datagram, a header line, a scene key) made
// safe to show: the one escaper of the C++ side (analysis/text.py is the
// Python side, by the same rule and the same test vectors).
//
// The rule, byte by byte: a backslash becomes two; a C0 control (0x00-0x1F),
// DEL (0x7F), a C1 control (U+0080-U+009F, whose UTF-8 is C2 80-C2 9F) and
// every byte that is not part of a valid UTF-8 sequence (a raw 0x80-0xFF byte,
// an overlong form, a surrogate, a code point past U+10FFFF, a cut sequence)
// becomes \xHH (upper-case hex), one escape per byte; every other valid UTF-8
// sequence stays as it is. So the result is always valid UTF-8 with no
// control character (safe for a terminal, for nlohmann::json's dump, for
// HTML once its own markup characters are escaped), and the escaping can be
// undone: "\\" is a backslash, "\xHH" the byte HH, anything else itself.
#pragma once

#include <string>
#include <string_view>

namespace afm {

// s shown safely, by the rule above.
std::string printable(std::string_view s);

}  // namespace afm
