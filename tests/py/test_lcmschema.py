"""analysis.lcmschema: the message types read from lcmtypes/*.lcm, without
the generated classes (tests/e2e/test_export.py holds the schemas against
lcm-gen's classes). A field's unit, components and column; the JSON Schema;
to_json; a file it cannot read is named with its line."""
import json
import math
import re
import os

import jsonschema
import pytest

from analysis import lcmschema


def lcm(tmp_path, text, name="x_t"):
    path = tmp_path / f"{name}.lcm"
    path.write_text(text)
    return str(path)


SAMPLE = """package afm;
// A sample message: its doc.
struct x_t
{
    const int32_t MAX = 4; // at most this many
    int64_t utime;         // time of the block, microseconds
    double force_nN[3];    // the tip's force (x, y, z), nN
    double pos[2];         // the apex in the AFM frame, nm
    int16_t raw[4];        // four raw words, LSB
    int32_t n;             // how many values follow, count
    float values[n];       // the values, volts
    boolean on;            // whether it is on
    string name;           // its name
    y_t inner[n];          // nested, one a value
}
"""
INNER = "package afm;\nstruct y_t\n{\n    int8_t k; // a small number\n}\n"


@pytest.fixture
def known(tmp_path):
    lcm(tmp_path, SAMPLE)
    lcm(tmp_path, INNER, "y_t")
    return lcmschema.types(str(tmp_path))


def test_a_file_reads_as_its_struct_with_fields_in_order(known):
    s = known["x_t"]
    assert (s.name, s.package, s.doc) == ("x_t", "afm", "A sample message: its doc.")
    assert [f.name for f in s.fields] == ["utime", "force_nN", "pos", "raw", "n", "values", "on", "name", "inner"]
    assert s.consts == [("int32_t", "MAX", "4", "at most this many")]
    assert [f.dims for f in s.fields if f.dims] == [[3], [2], [4], ["n"], ["n"]]


def test_units_components_and_columns_come_from_the_comment(known):
    f = {f.name: f for f in known["x_t"].fields}
    assert [f[n].unit for n in ("utime", "force_nN", "pos", "raw", "n", "values", "on")] == \
        ["us", "nN", "nm", "LSB", "count", "V", None]
    assert f["utime"].column == "utime_us"          # the unit appended
    assert f["force_nN"].column == "force_nN"       # the name ends in it already
    assert f["on"].column == "on"
    assert f["force_nN"].components == ["x", "y", "z"]   # named in the comment
    assert f["pos"].components == ["x", "y"]             # a 2-vector in a named frame
    assert f["raw"].components == ["0", "1", "2", "3"]
    assert f["utime"].fixed and f["force_nN"].fixed and not f["values"].fixed
    assert f["utime"].primitive and not f["inner"].primitive


def test_a_unit_followed_by_a_colon_is_read(tmp_path):
    lcm(tmp_path, "package afm;\nstruct z_t\n{\n    double axis_nm; // its height, nm: half the diameter\n}\n", "z_t")
    assert lcmschema.types(str(tmp_path))["z_t"].fields[0].unit == "nm"


def test_the_committed_types_all_read_with_utime_in_microseconds():
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    known = lcmschema.types(os.path.join(root, "lcmtypes"))
    assert len(known) > 10
    for name, s in known.items():
        if s.fields and s.fields[0].name == "utime":
            assert s.fields[0].unit == "us", name
        for f in s.fields:
            assert f.primitive or f.type in known, f"{name}.{f.name}: {f.type}"


def test_the_schema_validates_a_message_and_refuses_a_wrong_one(known):
    schema = lcmschema.json_schema("x_t", known)
    jsonschema.Draft202012Validator.check_schema(schema)
    v = jsonschema.Draft202012Validator(schema)
    assert schema["title"] == "afm.x_t"
    assert "MAX = 4 (at most this many)" in schema["description"]
    assert set(schema["$defs"]) == {"y_t"}
    msg = {"utime": 1, "force_nN": [0.1, 0.2, None], "pos": [1.0, 2.0], "raw": [1, -2, 3, 32767], "n": 1,
           "values": [0.5], "on": True, "name": "a", "inner": [{"k": 3}]}
    assert list(v.iter_errors(msg)) == []
    assert not v.is_valid(dict(msg, raw=[1, 2, 3, 32768])), "out of int16_t's range"
    assert not v.is_valid(dict(msg, force_nN=[0.1, 0.2])), "a fixed array's length"
    assert not v.is_valid(dict(msg, inner=[{"k": 3, "extra": 1}])), "a field no type has"
    missing = dict(msg)
    del missing["name"]
    assert not v.is_valid(missing)
    with pytest.raises(KeyError, match="no lcmtypes/z_t.lcm"):
        lcmschema.json_schema("z_t", known)


class Msg:
    def __init__(self, **kw):
        self.__dict__.update(kw)


def test_to_json_gives_plain_values_by_the_same_description(known):
    msg = Msg(utime=7, force_nN=(0.5, math.nan, math.inf), pos=[1, 2], raw=bytearray(b"\x01\x02\x03\x04"), n=1,
              values=[0.25], on=1, name="a", inner=[Msg(k=-1)])
    out = lcmschema.to_json(msg, "x_t", known)
    assert out == {"utime": 7, "force_nN": [0.5, None, None], "pos": [1.0, 2.0], "raw": [1, 2, 3, 4], "n": 1,
                   "values": [0.25], "on": True, "name": "a", "inner": [{"k": -1}]}
    json.dumps(out, allow_nan=False)   # NaN and infinities became null
    assert list(jsonschema.Draft202012Validator(lcmschema.json_schema("x_t", known)).iter_errors(out)) == []


@pytest.mark.parametrize("text, line", [
    ("package afm;\nstruct bad_t\n{\n    int64_t utime // no semicolon\n}\n", 4),
    ("package afm;\nstruct bad_t\n{\n    int64_t utime; // ok\n    what is this\n}\n", 5),
])
def test_a_line_it_cannot_read_is_named_with_the_file_and_line(tmp_path, text, line):
    path = lcm(tmp_path, text, "bad_t")
    with pytest.raises(ValueError, match="^" + re.escape(f"{path}:{line}: cannot read this line")):
        lcmschema.parse(path)


def test_a_file_without_a_struct_is_named(tmp_path):
    path = lcm(tmp_path, "package afm;\n// nothing here\n", "empty_t")
    with pytest.raises(ValueError, match="^" + re.escape(f"{path}: no struct")):
        lcmschema.parse(path)
