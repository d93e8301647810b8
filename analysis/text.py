"""Text from outside (a file, a header line, a scene key, an HTTP request)
made safe to show: the one escaper of the Python side, by the rule of the
C++ one (common/text.hpp), held to the same test vectors (tests/py/test_text.py
and tests/host/test_text.cpp).

The rule, on the text's UTF-8 bytes: a backslash becomes two; a C0 control
(0x00-0x1F), DEL (0x7F), a C1 control (U+0080-U+009F, UTF-8 C2 80-C2 9F) and
every byte that is not part of a valid UTF-8 sequence become \\xHH (upper-case
hex), one escape per byte; all else stays. The result is valid UTF-8 with no
control character, safe for a terminal, for JSON and for HTML once its own
markup is escaped; "\\\\" undoes to a backslash and "\\xHH" to the byte HH.

A str given is taken as its UTF-8 bytes: a byte that a reader kept with
errors="surrogateescape" (U+DC80-U+DCFF) is that byte again, and any other
lone surrogate is not valid UTF-8, so each of its bytes is escaped."""
import re

# What needs escaping in a str: the backslash, the C0 and C1 controls, DEL,
# and the surrogates (an undecodable byte, or a lone surrogate).
_NEEDS = re.compile("[\\\\\x00-\x1f\x7f-\x9f\ud800-\udfff]")


def _escape(match):
    c = match.group(0)
    if c == "\\":
        return "\\\\"
    code = ord(c)
    if 0xDC80 <= code <= 0xDCFF:   # a byte kept by surrogateescape
        raw = bytes([code - 0xDC00])
    else:
        raw = c.encode("utf-8", "surrogatepass")
    return "".join("\\x%02X" % b for b in raw)


def printable(s):
    """s (str or bytes) shown safely, by the rule above; a str."""
    if isinstance(s, (bytes, bytearray)):
        s = bytes(s).decode("utf-8", "surrogateescape")
    elif not isinstance(s, str):
        s = str(s)
    return _NEEDS.sub(_escape, s)
