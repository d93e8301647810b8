"""The bus's message types read from their source, lcmtypes/*.lcm: the one
place the Python side learns a field's type, array shape, unit and meaning.

Contract:
  types()              {type name: Struct}, every lcmtypes/*.lcm, parsed once.
  Struct.fields        [Field] in declaration order; Struct.consts, .doc.
  Field.unit           the unit its comment states ("nN", "us", "V", ...), or
                       None: the comment's fields after the first, split at
                       the commas outside brackets, whose first word (a colon
                       after it aside: "nm: measured from ...") is a unit
                       word (UNIT_WORDS below: words, not a table of fields).
  Field.components     a fixed array's element names: those its comment
                       names, "(x, y, z)"; else x, y (, z) for a 2- or
                       3-vector whose comment names its frame ("AFM
                       frame", "device frame"); else "0", "1", ...
  Field.column         the field's name with its unit appended when the name
                       does not already end in it (utime -> utime_us,
                       force_nN stays force_nN).
  json_schema(name)    a JSON Schema (draft 2020-12) of the type's JSON
                       encoding (to_json), nested types under $defs.
  to_json(msg, name)   a decoded message as plain JSON values, by the same
                       description: what export writes into MCAP.

The .lcm files follow the bus's contract (tests/e2e/test_contract.py): one
struct a file, a comment with the unit on every field. A file this parser
cannot read is an error naming the file and the line."""
import glob
import math
import os
import re
from dataclasses import dataclass, field

from analysis import paths

# Words a comment states a unit with, and the symbol a column name takes.
UNIT_WORDS = {
    "microseconds": "us", "seconds": "s", "Hz": "Hz", "volts": "V", "V": "V",
    "nm": "nm", "pm": "pm", "nN": "nN", "pN": "pN", "N": "N", "LSB": "LSB",
    "count": "count", "deg": "deg", "m": "m",
}
PRIMITIVES = {
    "int8_t": (-2 ** 7, 2 ** 7 - 1), "int16_t": (-2 ** 15, 2 ** 15 - 1),
    "int32_t": (-2 ** 31, 2 ** 31 - 1), "int64_t": (-2 ** 63, 2 ** 63 - 1),
    "byte": (0, 255), "float": None, "double": None, "boolean": None, "string": None,
}

_FIELD = re.compile(r"^(\w+)\s+(\w+)((?:\[\s*\w+\s*\])*)\s*;\s*(?://\s*(.*))?$")
_CONST = re.compile(r"^const\s+(\w+)\s+(\w+)\s*=\s*([^;]+);\s*(?://\s*(.*))?$")


@dataclass
class Field:
    type: str
    name: str
    dims: list            # each an int (fixed) or a field's name (its length)
    comment: str

    @property
    def primitive(self):
        return self.type in PRIMITIVES

    @property
    def fixed(self):
        """A fixed-size one-dimensional array (or a scalar: dims empty)."""
        return all(isinstance(d, int) for d in self.dims) and len(self.dims) <= 1

    @property
    def unit(self):
        for part in _split_top(self.comment)[1:]:
            word = (part.split() or [""])[0].rstrip(":")
            if word in UNIT_WORDS:
                return UNIT_WORDS[word]
        return None

    @property
    def components(self):
        n = self.dims[0] if self.dims and isinstance(self.dims[0], int) else 0
        m = re.search(r"\(([a-z](?:,\s*[a-z])*)\)", self.comment)
        names = [s.strip() for s in m.group(1).split(",")] if m else []
        if not names and n in (2, 3) and re.search(r"\bframe\b", self.comment):
            names = ["x", "y", "z"][:n]   # a vector in a named frame: its axes
        return names if len(names) == n else [str(i) for i in range(n)]

    @property
    def column(self):
        u = self.unit
        if u is None or self.name.lower().endswith("_" + u.lower()) or self.name == u:
            return self.name
        return f"{self.name}_{u}"


@dataclass
class Struct:
    name: str
    package: str
    path: str
    doc: str = ""
    consts: list = field(default_factory=list)    # (type, name, value, comment)
    fields: list = field(default_factory=list)


def _split_top(text):
    """text split at the commas outside (), [] and {}, each part stripped."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        depth += ch in "([{"
        depth -= ch in ")]}"
        if ch == "," and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    parts.append(cur.strip())
    return parts


def _dims(text):
    out = []
    for d in re.findall(r"\[\s*(\w+)\s*\]", text):
        out.append(int(d) if d.isdigit() else d)
    return out


def parse(path):
    """One .lcm file as a Struct; ValueError naming the file and line."""
    with open(path) as f:
        lines = f.read().splitlines()
    package, doc, s, inside = "", [], None, False
    for no, raw in enumerate(lines, 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("package "):
            package = line[len("package "):].rstrip(";").strip()
        elif line.startswith("//"):
            if not inside:
                doc.append(line[2:].strip())
        elif line.startswith("struct "):
            s = Struct(line.split()[1], package, path, " ".join(doc))
        elif line == "{" or line == "}":
            inside = line == "{"
        elif inside and _CONST.match(line):
            t, n, v, c = _CONST.match(line).groups()
            s.consts.append((t, n, v.strip(), c or ""))
        elif inside and _FIELD.match(line):
            t, n, d, c = _FIELD.match(line).groups()
            s.fields.append(Field(t, n, _dims(d), (c or "").strip()))
        else:
            raise ValueError(f"{path}:{no}: cannot read this line: {line!r}")
    if s is None:
        raise ValueError(f"{path}: no struct")
    return s


_TYPES = None


def types(folder=None):
    """{name: Struct} of every lcmtypes/*.lcm (parsed once per process)."""
    global _TYPES
    if folder is not None:
        return {s.name: s for s in map(parse, sorted(glob.glob(os.path.join(folder, "*.lcm"))))}
    if _TYPES is None:
        _TYPES = types(os.path.join(paths.ROOT, "lcmtypes"))
    return _TYPES


# ---- JSON Schema ----------------------------------------------------------------

def _primitive_schema(t):
    if t == "boolean":
        return {"type": "boolean"}
    if t == "string":
        return {"type": "string"}
    if t in ("float", "double"):
        return {"type": ["number", "null"]}   # null: NaN or an infinity, which JSON cannot hold
    lo, hi = PRIMITIVES[t]
    return {"type": "integer", "minimum": lo, "maximum": hi}


def _field_schema(f, known):
    if f.primitive:
        item = _primitive_schema(f.type)
    elif f.type in known:
        item = {"$ref": f"#/$defs/{f.type}"}
    else:
        raise ValueError(f"{f.name}: unknown type {f.type}")
    for d in reversed(f.dims):
        item = {"type": "array", "items": item}
        if isinstance(d, int):
            item["minItems"] = item["maxItems"] = d
        else:
            item["description"] = f"as many as the field {d} says"
    out = dict(item)
    desc = f.comment
    out["description"] = (desc + ("; " + item["description"] if "description" in item else "")).strip()
    return out


def _object_schema(s, known):
    consts = "".join(f" {n} = {v}" + (f" ({c})" if c else "") + ";" for _, n, v, c in s.consts)
    return {
        "type": "object",
        "title": f"{s.package}.{s.name}",
        "description": (s.doc + (" Constants:" + consts if consts else "")).strip(),
        "properties": {f.name: _field_schema(f, known) for f in s.fields},
        "required": [f.name for f in s.fields],
        "additionalProperties": False,
    }


def _nested(name, known, seen):
    for f in known[name].fields:
        if not f.primitive and f.type not in seen:
            seen.append(f.type)
            _nested(f.type, known, seen)
    return seen


def json_schema(name, known=None):
    """The JSON Schema of type `name`'s JSON encoding (to_json)."""
    known = known or types()
    if name not in known:
        raise KeyError(f"no lcmtypes/{name}.lcm")
    out = {"$schema": "https://json-schema.org/draft/2020-12/schema"}
    out.update(_object_schema(known[name], known))
    defs = {n: _object_schema(known[n], known) for n in _nested(name, known, [])}
    if defs:
        out["$defs"] = defs
    return out


# ---- JSON values ------------------------------------------------------------------

def _value(v, f, known, depth):
    if depth < len(f.dims):
        if isinstance(v, (bytes, bytearray)):
            return list(v)
        return [_value(x, f, known, depth + 1) for x in v]
    if f.type in ("float", "double"):
        return float(v) if math.isfinite(v) else None
    if f.type == "boolean":
        return bool(v)
    if f.type == "string":
        return v
    if f.primitive:
        return int(v)
    return to_json(v, f.type, known)


def to_json(msg, name, known=None):
    """A decoded message (lcm-gen's Python class) as JSON values."""
    known = known or types()
    return {f.name: _value(getattr(msg, f.name), f, known, 0) for f in known[name].fields}
