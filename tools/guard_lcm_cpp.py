#!/usr/bin/env python3
"""Rewrites lcm-gen's C++ headers so that decoding a hostile message cannot
allocate without bound, throw, or hand a handler a NaN (lcmtypes/afm_lcm_guard.h
says why). Every rule must match what lcm-gen wrote; a header left with an
unguarded resize, string length or double decode fails the build, so a new
lcm-gen that writes its decoders differently is caught here, not on the bus.

usage: guard_lcm_cpp.py RAW_DIR OUT_DIR   (RAW_DIR/afm/*.hpp -> OUT_DIR/afm/*.hpp)
"""
import pathlib
import re
import sys

RESIZE = re.compile(r"^(\s*)(this->\w+(?:\[\w+\])*)\.resize\((this->\w+)\);$", re.M)
STRLEN = re.compile(r"if\((__\w+_len__) > maxlen - pos\) return -1;")
INCLUDE = "#include <lcm/lcm_coretypes.h>\n"


def guard(text: str, name: str) -> str:
    if INCLUDE not in text:
        sys.exit(f"guard_lcm_cpp: {name}: no '{INCLUDE.strip()}' to add the guard after")
    text = text.replace(INCLUDE, INCLUDE + '#include "afm_lcm_guard.h"\n', 1)
    text = RESIZE.sub(lambda m: f"{m[1]}if ({m[3]} < 0 || {m[3]} > maxlen - pos) return AFM_LCM_E_LENGTH;\n"
                                f"{m[1]}{m[2]}.resize({m[3]});", text)
    text = STRLEN.sub(lambda m: f"if({m[1]} < 1 || {m[1]} > maxlen - pos || !afm_lcm_string_ok(buf, offset + pos, {m[1]})) "
                                f"return AFM_LCM_E_LENGTH;", text)
    text = text.replace("__double_decode_array(buf", "afm_lcm_decode_finite_double(buf")
    text = text.replace("__float_decode_array(buf", "afm_lcm_decode_finite_float(buf")
    # What must not be left: every resize and string length guarded, no raw
    # double or float decode.
    prev = ""
    for line in text.splitlines():
        s = line.strip()
        if ".resize(" in s and "AFM_LCM_E_LENGTH" not in prev:
            sys.exit(f"guard_lcm_cpp: {name}: an unguarded resize: {s}")
        if re.search(r"_len__ > maxlen - pos\) return -1", s) or re.search(r"__(double|float)_decode_array\(buf", s):
            sys.exit(f"guard_lcm_cpp: {name}: left unguarded: {s}")
        prev = s
    return text


def main() -> int:
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    raw, out = pathlib.Path(sys.argv[1]) / "afm", pathlib.Path(sys.argv[2]) / "afm"
    out.mkdir(parents=True, exist_ok=True)
    headers = sorted(raw.glob("*.hpp"))
    if not headers:
        sys.exit(f"guard_lcm_cpp: no headers in {raw}")
    for h in headers:
        text = guard(h.read_text(), h.name)
        dst = out / h.name
        if not dst.exists() or dst.read_text() != text:
            dst.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
