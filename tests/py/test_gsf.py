"""The Python GSF reader's ranges (analysis/gsf.py RANGES): the same table
as the C++ reader's (common/gsf.hpp kGsfRanges, read here from its source),
each entry taken at both bounds and refused just past each, naming the
field and the value; a missing required field refused, a missing offset 0;
XReal = 1e300 refused; a field given twice refused; the file's own text
(a header line, its name) quoted escaped for every C0 and C1 control.
Runs under pytest or as a script."""
import atexit
import math
import os
import re
import shutil
import sys
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
sys.path.insert(0, ROOT)
from analysis import gsf  # noqa: E402

VALID = {"XRes": "2", "YRes": "2", "XReal": "1e-6", "YReal": "1e-6", "XOffset": "0", "YOffset": "0"}
TMP = tempfile.mkdtemp(prefix="afm-test-gsf-py-")
atexit.register(shutil.rmtree, TMP, True)


def write(fields, extra=b"", name="t.gsf"):
    head = b"Gwyddion Simple Field 1.0\n"
    for k, v in fields.items():
        if v != "":
            head += f"{k} = {v}\n".encode()
    head += b"XYUnits = m\nZUnits = m\n" + extra
    head += b"\0" * (4 - len(head) % 4)

    def res(k):
        try:
            v = float(fields.get(k) or 2)
        except ValueError:
            return 2
        return int(v) if math.isfinite(v) and 2 <= v <= gsf.MAX_RES and v == int(v) else 2
    path = os.path.join(TMP, name) if isinstance(name, str) else os.path.join(TMP.encode(), name)
    with open(path, "wb") as f:
        f.write(head + b"\0" * (4 * res("XRes") * res("YRes")))
    return path


def refusal(path):
    try:
        gsf.read(path)
    except ValueError as e:
        return str(e)
    return ""


def with_field(key, value):
    return dict(VALID, **{key: value})


def test_the_table_is_the_cpp_readers():
    with open(os.path.join(ROOT, "common", "gsf.hpp")) as f:
        src = f.read()
    max_res = int(re.search(r"kGsfMaxRes = (\d+);", src).group(1))
    table = src[src.index("kGsfRanges[] = {"):]
    table = table[:table.index("};")]
    rows = re.findall(r'\{"(\w+)", ([^,]+), ([^,]+), (true|false), (true|false)\}', table)
    num = lambda t: max_res if t.strip() == "kGsfMaxRes" else float(t)
    cpp = {k: (num(lo), num(hi), w == "true", r == "true") for k, lo, hi, w, r in rows}
    assert len(rows) == 6 and cpp == gsf.RANGES, (cpp, gsf.RANGES)
    assert max_res == gsf.MAX_RES


def test_every_range_holds_at_its_bounds_and_refuses_past_them():
    for key, (lo, hi, whole, _) in gsf.RANGES.items():
        for v in (lo, hi):
            assert refusal(write(with_field(key, repr(float(v))))) == "", (key, v)
        past = [lo - 1, hi + 1, lo + 0.5] if whole else [math.nextafter(lo, -math.inf), math.nextafter(hi, math.inf)]
        for v in [repr(float(p)) for p in past] + ["nan", "inf", "-inf", "1e300", "-1e300", "12abc", "0x", "1_0"]:
            why = refusal(write(with_field(key, v)))
            assert f"GSF header {key}" in why and f"'{v}'" in why, (key, v, why)


def test_the_fields_read_and_a_missing_offset_is_zero():
    header, z = gsf.read(write(dict(VALID, XRes="3", YRes="4")))
    assert z.shape == (4, 3)
    for key, (_, _, _, required) in gsf.RANGES.items():
        why = refusal(write(with_field(key, "")))
        if required:
            assert f"GSF header {key} is missing" in why, why
        else:
            assert why == "", why
            assert gsf.number("f", gsf.read(write(with_field(key, "")))[0], key) == 0


def test_a_huge_finite_extent_and_a_field_given_twice_are_refused():
    why = refusal(write(with_field("XReal", "1e300")))
    assert "GSF header XReal must be a number in [1e-10, 1], got '1e300'" in why, why
    why = refusal(write(VALID, b"XReal = 2e-6\n"))
    assert "GSF header XReal given twice" in why, why


def test_the_files_own_text_is_quoted_escaped():
    for b in list(range(1, 0x20)) + [0x7F] + list(range(0x80, 0xA0)):
        if b in (0x0A, 0x0D):
            continue
        raw = bytes([b]) if b < 0x80 else bytes([0xC2, b])
        esc = "".join("\\x%02X" % c for c in raw)
        for why in (refusal(write(VALID, b"bad" + raw + b"line\n")), refusal(write(VALID, b"bad\n", name=b"no" + raw + b"file.gsf")),
                    refusal(os.path.join(TMP.encode(), b"missing" + raw))):
            assert esc in why, (b, why)
            assert not re.search("[\x00-\x1f\x7f-\x9f]", why), (b, why)


if __name__ == "__main__":
    tests = [f for name, f in sorted(globals().items()) if name.startswith("test_")]
    for f in tests:
        f()
    print("ok: %d tests" % len(tests))
