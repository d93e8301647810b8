"""The C++ field walk generated from the .lcm files (tools/gen_lcm_walk.py,
afm_lcm_walk.hpp; replay compares the card's outputs with it): a field
added to a type is walked, with its name path and unit; a type it does not
know is named; and, with a build, the walk of every committed type visits
exactly the fields analysis/lcmschema.py lists, in its order, nested
structs and arrays expanded (a message of each type, every variable array
two long, encoded by the generated Python classes and walked by
tests/host/lcm_walk_names)."""
import os
import subprocess
import sys

import pytest

from analysis import lcmschema

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GEN = os.path.join(ROOT, "tools", "gen_lcm_walk.py")
BUILD = os.environ.get("AFM_BUILD") or os.path.join(ROOT, "build", "main")
NAMES = os.path.join(BUILD, "tests", "lcm_walk_names")

X_T = """package afm;
// A sample.
struct x_t
{
    int64_t utime;        // time, microseconds
    double  force_nN[3];  // a force, nN
    int32_t n;            // how many follow, count
    y_t     inner[n];     // nested, one a value
    string  name;         // its name
    double  grid_nm[n][2]; // two positions a value, nm
    double  a_nm[n];      // a node's a, nm
    double  b_v[n];       // its b, volts
}
"""
Y_T = "package afm;\nstruct y_t\n{\n    int8_t k; // a small number\n}\n"


def generate(folder, tmp_path):
    out = tmp_path / "walk.hpp"
    p = subprocess.run([sys.executable, GEN, str(folder), str(out)], capture_output=True, text=True)
    return p, (out.read_text() if p.returncode == 0 else "")


@pytest.fixture
def lcm_dir(tmp_path):
    d = tmp_path / "lcm"
    d.mkdir()
    (d / "x_t.lcm").write_text(X_T)
    (d / "y_t.lcm").write_text(Y_T)
    return d


def test_every_field_is_visited_with_its_name_path_and_unit(lcm_dir, tmp_path):
    p, text = generate(lcm_dir, tmp_path)
    assert p.returncode == 0, p.stderr
    for line in ('visit(pre + "utime", m.utime, "us");',
                 'visit(pre + "force_nN[" + std::to_string(i0) + "]", m.force_nN[i0], "nN");',
                 'visit(pre + "n", m.n, "count");',
                 'walk(m.inner[i0], pre + "inner[" + std::to_string(i0) + "].", visit);',
                 'visit(pre + "name", m.name, "");',
                 'visit(pre + "grid_nm[" + std::to_string(i0) + "][" + std::to_string(i1) + "]", m.grid_nm[i0][i1], "nm");',
                 'for (std::size_t i0 = 0; i0 < std::min({std::size(m.a_nm), std::size(m.b_v)}); ++i0) {\n'
                 '        visit(pre + "a_nm[" + std::to_string(i0) + "]", m.a_nm[i0], "nm");\n'
                 '        visit(pre + "b_v[" + std::to_string(i0) + "]", m.b_v[i0], "V");\n    }',
                 'visit(pre + "k", m.k, "");',
                 "#define AFM_LCM_WALK_TYPES(X) X(x_t) X(y_t)"):
        assert line in text, line


def test_a_field_added_to_a_type_is_walked(lcm_dir, tmp_path):
    _, before = generate(lcm_dir, tmp_path)
    assert "added_nm" not in before
    (lcm_dir / "y_t.lcm").write_text(Y_T.replace("}\n", "    double added_nm; // a new one, nm\n}\n"))
    p, after = generate(lcm_dir, tmp_path)
    assert p.returncode == 0, p.stderr
    assert 'visit(pre + "added_nm", m.added_nm, "nm");' in after


def test_a_field_of_an_unknown_type_is_named(lcm_dir, tmp_path):
    (lcm_dir / "y_t.lcm").write_text(Y_T.replace("}\n", "    z_t z; // no such type\n}\n"))
    p, _ = generate(lcm_dir, tmp_path)
    assert p.returncode != 0
    assert "y_t.lcm: field z: unknown type z_t" in p.stderr


# ---- the committed types, through the built walk ---------------------------------

LONG = 2   # every variable array of the sample messages: two long


def expected(name, known, pre=""):
    """[(name path, unit)] of a message of type name whose variable arrays
    are LONG long, from lcmschema alone: fields in order, arrays sized by one
    length field and declared one after another index by index together."""
    groups = []   # [(the length field of a run of arrays, or None; [each field's [entries of an element]])]
    for f in known[name].fields:
        names = [pre + f.name]
        for d in f.dims:
            names = [n + f"[{i}]" for n in names for i in range(d if isinstance(d, int) else LONG)]
        elems = [[(n, f.unit or "-")] if f.primitive else expected(f.type, known, n + ".") for n in names]
        sized = f.dims[0] if len(f.dims) == 1 and isinstance(f.dims[0], str) else None
        if sized and groups and groups[-1][0] == sized:
            groups[-1][1].append(elems)
        else:
            groups.append((sized, [elems]))
    return [e for _, fields in groups for i in range(len(fields[0])) for elems in fields for e in elems[i]]


def sample(afm, name, known):
    """A message of type name (the generated Python class), every variable
    array LONG long and its length field LONG."""
    m = getattr(afm, name)()
    for f in known[name].fields:
        setattr(m, f.name, value(afm, f, known, 0))
    for f in known[name].fields:
        for d in f.dims:
            if not isinstance(d, int):
                setattr(m, d, LONG)
    return m


def value(afm, f, known, depth):
    if depth < len(f.dims):
        d = f.dims[depth]
        return [value(afm, f, known, depth + 1) for _ in range(d if isinstance(d, int) else LONG)]
    if f.type == "string":
        return "s"
    if f.type in ("float", "double"):
        return 0.0
    if f.type == "boolean":
        return False
    return 0 if f.primitive else sample(afm, f.type, known)


def test_each_committed_type_walks_exactly_the_fields_lcmschema_lists():
    if not os.access(NAMES, os.X_OK):
        pytest.skip(f"no {NAMES} (./afm build)")
    from analysis import afmlog   # the build's generated Python types
    known = lcmschema.types()
    assert len(known) > 10
    for name in known:
        data = sample(afmlog.afm, name, known).encode()
        p = subprocess.run([NAMES, name], input=data, capture_output=True, timeout=30)
        assert p.returncode == 0, f"{name}: {p.stderr.decode()}"
        walked = [tuple(line.split(" ")) for line in p.stdout.decode().splitlines()]
        assert walked == expected(name, known), name
