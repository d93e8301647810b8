"""What a report shows of a value: the one formatter of the run's, the
sweep's and the paper's pages (analysis/run_report.py, sweep_report.py,
paper/paper_report.py).

The unit of a field is where the house defines it, in the field's own name
(docs: "units and formats in names": `adhesion_pn`, `mu_ppm`,
`scan_angle_mdeg`, `deflection_pm_per_v`, `gain_N_per_nN`, `force_nN_x`,
`wall_seconds`), as lcmschema.py reads a bus field's unit from its comment
(its Field.column is such a name). This module knows unit *symbols*, not
fields: SYMBOLS below maps a symbol a name may end in to how it is shown.

Contract:
  split(name)            (label, unit): the name without its unit suffix,
                         underscores as spaces ("mu_ppm" -> ("mu", "ppm"),
                         "force_nN_x" -> ("force x", "nN"),
                         "samples_per_block" -> ("samples per block", None)).
  number(v)              a float at most 4 significant digits, no exponent
                         (below 1e-4 a power of ten: 1e-14 as "1×10⁻¹⁴");
                         an int exactly.
  show(v, unit, sign)    a value in its physical unit: a scaled symbol
                         (ppm and % as plain numbers, mdeg as deg) and, when
                         the number would read outside [0.01, 10000), the
                         SI prefix that brings it to [1, 1000) ("106800 pN"
                         -> "106.8 nN"; none past femto or giga: the
                         field's unit, the number with a power of ten); True/False as yes/no; None as
                         "none"; a string as it is. sign: a "+" before a
                         positive number; like: the prefix of another
                         value (a bias in its RMS's unit).
  listed(vs, unit, sign) values in one unit, joined: "1.2, 3.4 nm" (each
                         show()n, the unit said once, at the end; the
                         prefix the largest value takes).
  field(name, v)         (label, text) for a field named in the house's way.
  html_table(d)          a dict as an HTML table, labels and values through
                         field(); nested dicts as nested tables, lists of
                         scalars joined, lists of dicts as rows: nothing cut.
  raw_values(text)       what a page's text must not show, each found: a
                         True/False/None/nan, a number with more than 4
                         significant digits or an exponent ("1e-08"), a
                         field's code name with its unit ("mu_ppm",
                         "scan_angle_mdeg", "check_us"). The reports' tests
                         hold every page to it.
"""
import html
import math
import numbers
import re

# symbol in a name -> (symbol shown, factor to it, SI base or None: no prefix)
SYMBOLS = {
    "m": ("m", 1, "m"), "mm": ("mm", 1, "m"), "um": ("µm", 1, "m"), "nm": ("nm", 1, "m"), "pm": ("pm", 1, "m"),
    "N": ("N", 1, "N"), "mN": ("mN", 1, "N"), "uN": ("µN", 1, "N"), "un": ("µN", 1, "N"), "nN": ("nN", 1, "N"),
    "pN": ("pN", 1, "N"), "pn": ("pN", 1, "N"),
    "s": ("s", 1, "s"), "seconds": ("s", 1, "s"), "ms": ("ms", 1, "s"), "us": ("µs", 1, "s"), "ns": ("ns", 1, "s"),
    "V": ("V", 1, "V"), "v": ("V", 1, "V"), "mV": ("mV", 1, "V"),
    "J": ("J", 1, "J"), "kg": ("kg", 1, None), "Hz": ("Hz", 1, "Hz"), "hz": ("Hz", 1, "Hz"),
    "deg": ("deg", 1, None), "mdeg": ("deg", 1e-3, None),
    "rad": ("rad", 1, "rad"), "mrad": ("mrad", 1, "rad"), "urad": ("µrad", 1, "rad"),
    "ppm": ("", 1e-6, None), "pct": ("%", 1, None),
    "kpa": ("kPa", 1, "Pa"), "Pa": ("Pa", 1, "Pa"),
    "bytes": ("B", 1, "B"), "B": ("B", 1, "B"), "kb": ("kB", 1, "B"), "MB": ("MB", 1, "B"),
    "Ns": ("N s", 1, None), "bits": ("bits", 1, None), "LSB": ("LSB", 1, None),
}
PREFIXES = [(1e-15, "f"), (1e-12, "p"), (1e-9, "n"), (1e-6, "µ"), (1e-3, "m"), (1, ""), (1e3, "k"), (1e6, "M"), (1e9, "G")]
_SUPER = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
DIGITS = 4


def _symbol(token):
    """SYMBOLS' entry of a name's token, or None."""
    return SYMBOLS.get(token)


def split(name):
    """(label, unit): module docstring. The unit is the suffix of symbols
    SYMBOLS knows, "_per_" joining two ("pm_per_v"); a one-letter axis
    ("_x") after the unit stays in the label."""
    parts = str(name).split("_")
    axis = [parts.pop()] if len(parts) > 2 and parts[-1] in ("x", "y", "z") and _symbol(parts[-2]) else []
    unit = None
    if len(parts) >= 3 and parts[-2] == "per" and _symbol(parts[-3]):
        unit = f"{parts[-3]}/{parts[-1]}"   # the denominator a symbol or a word ("ms_per_frame")
        parts = parts[:-3]
    elif len(parts) >= 2 and _symbol(parts[-1]):
        unit = parts.pop()
    label = " ".join(p for p in parts + axis if p) or str(name)
    return label, unit


def number(v, sign=False):
    """A number as the pages show it (module docstring)."""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, numbers.Integral):
        return f"{int(v):+d}" if sign else str(int(v))
    v = float(v)
    if math.isnan(v):
        return "not a number"
    if math.isinf(v):
        return ("+" if sign else "") + "∞" if v > 0 else "−∞"
    if v == 0:
        return "0"
    s = "+" if sign and v > 0 else ""
    e = math.floor(math.log10(abs(v)))
    r = round(v, DIGITS - 1 - e)
    if r != 0 and math.floor(math.log10(abs(r))) != e:   # 9.9996 -> 10: one digit fewer after the point
        e += 1
    if e >= DIGITS:
        return s + f"{r:.0f}"
    if e < -4:
        m = f"{v / 10 ** e:.{DIGITS - 1}f}".rstrip("0").rstrip(".")
        return s + f"{m}×10{str(e).translate(_SUPER)}"
    t = f"{r:.{max(0, DIGITS - 1 - e)}f}"
    return s + (t.rstrip("0").rstrip(".") if "." in t else t)


def _scaled(v, unit):
    """(value, unit text) with the symbol's factor applied and, where the
    number would read outside [0.01, 10000), an SI prefix chosen."""
    num, _, den = unit.partition("/")
    sym = _symbol(num)
    if sym is None:
        return v, unit
    shown, factor, base = sym
    v = v * factor
    den_text = ""
    if den:
        d = _symbol(den)
        den_text = "/" + (d[0] if d else den)
    if base and v != 0 and not 0.01 <= abs(v) < 1e4:
        prefix = shown[:-len(base)] if shown.endswith(base) else ""
        scale = 1.0 if not prefix else next(f for f, p in PREFIXES if p == prefix)
        si = v * scale
        fits = [(f, p) for f, p in PREFIXES if f * 0.9995 <= abs(si) < f * 999.95]
        if fits:
            return si / fits[0][0], fits[0][1] + base + den_text
    return v, shown + den_text


def show(v, unit=None, sign=False, like=None):
    """A value with its unit (module docstring); like: another value whose
    prefix it takes (a bias shown in its RMS's unit)."""
    if v is None:
        return "none"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, str):
        return v
    if not isinstance(v, numbers.Number):
        return str(v)
    if unit:
        x, text = _scaled(v, unit)
        if like is not None and like != 0:
            lx, text = _scaled(like, unit)
            x = v * (lx / like)
        n = number(x if not isinstance(v, numbers.Integral) or x != v else v, sign)
        return f"{n} {text}".strip() if text else n
    return number(v, sign)


def listed(vs, unit=None, sign=False):
    """Values in one unit, joined (module docstring)."""
    vs = list(vs)
    if not vs:
        return "none"
    big = max(vs, key=lambda v: abs(v) if isinstance(v, numbers.Number) and not isinstance(v, bool) else -1)
    shown = [show(v, unit, sign, like=big if isinstance(v, numbers.Number) else None) for v in vs]
    tail = show(big, unit, like=big).partition(" ")[2] if unit else ""
    cut = len(tail) + 1 if tail else 0
    return ", ".join(t[:-cut] if cut and t.endswith(" " + tail) else t for t in shown) + (f" {tail}" if tail else "")


def field(name, v):
    """(label, text) of a field named in the house's way."""
    label, unit = split(name)
    return label, show(v, unit)


def _cell(name, v):
    if isinstance(v, dict):
        return html_table(v, nested=True)
    if isinstance(v, list):
        if not v:
            return "none"
        if all(isinstance(x, dict) for x in v):
            return "".join(html_table(x, nested=True) for x in v)
        unit = split(name)[1]
        return html.escape(", ".join(show(x, unit) if not isinstance(x, (list, dict)) else str(x) for x in v))
    return html.escape(field(name, v)[1])


def html_table(d, nested=False):
    """A dict as an HTML table (module docstring)."""
    if not isinstance(d, dict) or not d:
        return "<p>(none)</p>" if not nested else "none"
    rows = "".join(f"<tr><th>{html.escape(split(k)[0])}</th><td>{_cell(k, v)}</td></tr>" for k, v in d.items())
    return f'<table class="{"sub" if nested else "kv"}">{rows}</table>'


_WORDS = re.compile(r"\b(True|False|None|nan|NaN)\b")
_FLOAT = re.compile(r"(?<![\w.])[-+]?\d+\.\d+(?![\w.])")
_EXPONENT = re.compile(r"(?<![\w.])\d+(?:\.\d+)?[eE][-+]?\d+\b")
_CODE = re.compile(r"\b[A-Za-z]\w*_(?:ppm|mdeg|us|urad|pn|pm_per_v)\b")


def raw_values(text):
    """The raw values in a page's text (module docstring), in order."""
    out = [m.group(0) for m in _WORDS.finditer(text)]
    out += [m.group(0) for m in _FLOAT.finditer(text) if len(re.sub(r"[-+.]", "", m.group(0)).lstrip("0")) > DIGITS]
    out += [m.group(0) for m in _EXPONENT.finditer(text)]
    out += [m.group(0) for m in _CODE.finditer(text)]
    return out


def page_text(page):
    """The text a person reads of an HTML page: its tags, scripts, styles
    and an SVG's metadata left out (an inline SVG's labels kept)."""
    page = re.sub(r"(?is)<(script|style|metadata)\b.*?</\1>", " ", page)
    return html.unescape(re.sub(r"(?s)<[^>]*>", " ", page))
