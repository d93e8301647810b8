#!/usr/bin/env python3
"""Generate the C++ field walk of the bus's message types from their .lcm
files, read by analysis/lcmschema.py (the one parser of .lcm files).

usage: gen_lcm_walk.py LCM_DIR OUT_HEADER

The header declares, in namespace afm::lcm_walk, for every type T of
LCM_DIR/*.lcm:

  template <class V> void walk(const T &m, const std::string &pre, V &visit);

which calls visit(name, value, unit) for every field of m in declaration
order: name is pre and the field's path ("objects.particles[3].x_nm"),
value the member as lcm-gen's C++ class holds it (a number, a bool or a
std::string), unit the symbol lcmschema.Field.unit reads from its comment
("nm", "nN", "us", ...; "" when it states none). A nested struct is walked
with its name and a dot added to pre; an array, fixed or variable, element
by element with its index ("force_nN[2]"), a variable one as long as the
vector holds. One-dimensional arrays sized by the same length field and
declared one after another are walked index by index together, as the nodes
they describe: x_nm[0], y_nm[0], x_nm[1], y_nm[1], ... AFM_LCM_WALK_TYPES(X)
calls X(T) for every type.

A field whose type is neither primitive nor one of LCM_DIR's types is an
error naming the file and the field."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from analysis import lcmschema  # noqa: E402  (the checkout's own parser)


def _cxx_type(s):
    return f"::{s.package}::{s.name}" if s.package else f"::{s.name}"


def _name(parts):
    """The C++ expression of a field's name: pre, then the parts (a part in
    quotes is a literal, else an index), adjacent literals joined."""
    out, lit = ["pre"], ""
    for p in parts:
        if p.startswith('"'):
            lit += p[1:-1]
            continue
        out += [f'"{lit}["', f"std::to_string({p})"]
        lit = "]"
    return " + ".join(out + ([f'"{lit}"'] if lit else []))


def _visit(f, member, parts):
    """The statement that visits one element of f: a number or a string, or
    a nested struct (walked with its name and a dot)."""
    if f.primitive:
        return f'visit({_name(parts)}, {member}, "{f.unit or ""}");'
    return f'walk({member}, {_name(parts + [chr(34) + "." + chr(34)])}, visit);'


def _field(f):
    """The statements that visit field f, an array element by element."""
    member, parts, lines = f"m.{f.name}", [f'"{f.name}"'], []
    for depth in range(len(f.dims)):
        i = f"i{depth}"
        lines.append("    " * (depth + 1) + f"for (std::size_t {i} = 0; {i} < std::size({member}); ++{i})")
        member += f"[{i}]"
        parts.append(i)
    return lines + ["    " * (len(f.dims) + 1) + _visit(f, member, parts)]


def _parallel(group):
    """The statements that visit arrays sized by one length field, declared
    one after another, index by index together."""
    sizes = ", ".join(f"std::size(m.{f.name})" for f in group)
    lines = [f"    for (std::size_t i0 = 0; i0 < std::min({{{sizes}}}); ++i0) {{"]
    lines += ["        " + _visit(f, f"m.{f.name}[i0]", [f'"{f.name}"', "i0"]) for f in group]
    return lines + ["    }"]


def _groups(fields):
    """fields in order, as runs: a run of one-dimensional arrays sized by the
    same length field together, every other field alone."""
    out = []
    for f in fields:
        sized = len(f.dims) == 1 and isinstance(f.dims[0], str)
        prev = out[-1][-1] if out else None
        if sized and prev is not None and prev.dims == f.dims:
            out[-1].append(f)
        else:
            out.append([f])
    return out


def _walk(s, known):
    out = [f"// {s.name} ({os.path.basename(s.path)})",
           "template <class V>",
           f"void walk(const {_cxx_type(s)} &m, const std::string &pre, V &visit)",
           "{"]
    for f in s.fields:
        if not f.primitive and f.type not in known:
            raise ValueError(f"{s.path}: field {f.name}: unknown type {f.type}")
    for g in _groups(s.fields):
        out += _field(g[0]) if len(g) == 1 else _parallel(g)
    if not s.fields:
        out += ["    (void)m;", "    (void)pre;", "    (void)visit;"]
    return out + ["}", ""]


def header(known):
    """The header's text for {name: Struct} (lcmschema.types())."""
    structs = [known[n] for n in sorted(known)]
    out = ["// Generated from lcmtypes/*.lcm by tools/gen_lcm_walk.py (analysis/lcmschema.py reads the files).",
           "// Do not edit. The contract: tools/gen_lcm_walk.py's docstring.",
           "#pragma once", "", "#include <algorithm>", "#include <cstddef>", "#include <iterator>", "#include <string>", ""]
    out += [f'#include "{s.package}/{s.name}.hpp"' for s in structs]
    out += ["", "namespace afm::lcm_walk {", ""]
    out += [f"template <class V>\nvoid walk(const {_cxx_type(s)} &m, const std::string &pre, V &visit);"
            for s in structs]
    out.append("")
    for s in structs:
        out += _walk(s, known)
    out.append("#define AFM_LCM_WALK_TYPES(X) " + " ".join(f"X({s.name})" for s in structs))
    out += ["", "}  // namespace afm::lcm_walk", ""]
    return "\n".join(out)


def main(argv):
    if len(argv) != 3:
        sys.exit("usage: gen_lcm_walk.py LCM_DIR OUT_HEADER")
    try:
        known = lcmschema.types(argv[1])
        if not known:
            raise ValueError(f"{argv[1]}: no .lcm files")
        text = header(known)
    except ValueError as e:
        sys.exit(f"gen_lcm_walk: {e}")
    tmp = argv[2] + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, argv[2])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
