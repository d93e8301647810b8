"""The Python escaper (analysis/text.py) against the C++ one's table of
vectors (tests/host/test_text.cpp kVectors, the same rows), every C0 and C1
control byte, every raw high byte, every string of one or two bytes and
random strings: the result is valid UTF-8 with no control character, and
undoing its escapes gives back the input. Runs under pytest or as a script."""
import json
import os
import random
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
from analysis.text import printable  # noqa: E402

# (input bytes, output), the rows of tests/host/test_text.cpp's kVectors.
VECTORS = [
    (b"plain text 1.0 = 2", "plain text 1.0 = 2"),
    (b"back\\slash", "back\\\\slash"),
    (b"\x1b[2J\x1b]0;title\x07", "\\x1B[2J\\x1B]0;title\\x07"),
    (b"a\nb\rc\td", "a\\x0Ab\\x0Dc\\x09d"),
    (b"nul\0in", "nul\\x00in"),
    (b"del\x7f", "del\\x7F"),
    (b"\xc2\x85next line, \xc2\x9bCSI", "\\xC2\\x85next line, \\xC2\\x9BCSI"),
    (b"nbsp\xc2\xa0 \xc2\xb5m caf\xc3\xa9", "nbsp\u00a0 \u00b5m caf\u00e9"),
    (b"\xe6\x97\xa5\xe6\x9c\xac \xf0\x9f\x98\x80", "\u65e5\u672c \U0001F600"),
    (b"\xed\x9f\xbf \xee\x80\x80 \xf4\x8f\xbf\xbf", "\ud7ff \ue000 \U0010FFFF"),
    (b"\xff\xfeX", "\\xFF\\xFEX"),
    (b"\x80\x9f\xbf", "\\x80\\x9F\\xBF"),
    (b"\xc0\x80", "\\xC0\\x80"),
    (b"\xc1\xbf", "\\xC1\\xBF"),
    (b"\xe0\x80\x80", "\\xE0\\x80\\x80"),
    (b"\xf0\x80\x80\x80", "\\xF0\\x80\\x80\\x80"),
    (b"\xed\xa0\x80", "\\xED\\xA0\\x80"),
    (b"\xf4\x90\x80\x80", "\\xF4\\x90\\x80\\x80"),
    (b"\xf5\x80\x80\x80", "\\xF5\\x80\\x80\\x80"),
    (b"\xe2\x82A", "\\xE2\\x82A"),
    (b"end\xe2\x82", "end\\xE2\\x82"),
    (b"\xf0\x9f\x98", "\\xF0\\x9F\\x98"),
]

_ESCAPE = re.compile(rb"\\(\\|x([0-9A-F]{2}))")


def unescape(s):
    """The escapes undone, as bytes: "\\\\" a backslash, "\\xHH" the byte."""
    raw = s.encode("utf-8")
    assert re.fullmatch(rb"(?:[^\\]|\\\\|\\x[0-9A-F]{2})*", raw, re.S), s
    return _ESCAPE.sub(lambda m: b"\\" if m.group(1) == b"\\" else bytes([int(m.group(2), 16)]), raw)


def expect_safe_and_reversible(raw):
    out = printable(raw)
    encoded = out.encode("utf-8")   # a lone surrogate would raise here
    json.dumps(out, ensure_ascii=False).encode("utf-8")
    assert not re.search("[\x00-\x1f\x7f-\x9f]", out), (raw, out)
    assert unescape(out) == raw, (raw, out)
    assert encoded.decode("utf-8") == out


def test_the_table_of_vectors_comes_out_as_written():
    for raw, want in VECTORS:
        assert printable(raw) == want, (raw, printable(raw), want)
        expect_safe_and_reversible(raw)


def test_a_str_is_taken_as_its_utf8_bytes():
    for raw, want in VECTORS:
        assert printable(raw.decode("utf-8", "surrogateescape")) == want, raw
    assert printable("\ud800") == "\\xED\\xA0\\x80"   # a lone surrogate is not UTF-8
    assert printable("\u0085") == "\\xC2\\x85"
    assert printable(3) == "3"


def test_every_c0_and_c1_control_and_raw_high_byte():
    for b in range(0x20):
        assert printable(b"k" + bytes([b]) + b"v") == "k\\x%02Xv" % b
    assert printable(b"\x7f") == "\\x7F"
    for c in range(0x80, 0xA0):
        assert printable(bytes([0xC2, c])) == "\\xC2\\x%02X" % c
        assert printable(chr(c)) == "\\xC2\\x%02X" % c
    for b in range(0x80, 0x100):
        assert printable(b"a" + bytes([b]) + b"b") == "a\\x%02Xb" % b


def test_every_string_of_one_or_two_bytes():
    for a in range(256):
        expect_safe_and_reversible(bytes([a]))
        for b in range(256):
            expect_safe_and_reversible(bytes([a, b]))


def test_random_strings():
    rng = random.Random(46)
    for _ in range(20000):
        raw = bytes(rng.choice((rng.randrange(256), 0x80 | rng.randrange(128))) for _ in range(rng.randrange(12)))
        expect_safe_and_reversible(raw)


if __name__ == "__main__":
    tests = [f for name, f in sorted(globals().items()) if name.startswith("test_")]
    for f in tests:
        f()
    print("ok: %d tests" % len(tests))
