"""Friction loops to the tilted-surface calibration (physics.md section 2,
eq. 16-17), from a researcher's own files or from the bench's runs.

    ./afm calib tilted --loops LOOP.csv|LOOP.gwy|SCAN ... \\
        --angle-deg PHI --spring-N-per-m K_N --deflection-nm-per-V K_N_V [--write FILE] [--json]
        [--up-pass trace|retrace] [--lateral-trace CH] [--lateral-retrace CH] [--normal CH]
        [--s-n-V V ...] [--edge-fraction F]

A loop file is one friction loop at one set point. As CSV (a .csv name),
with a header line and these columns (others are ignored):
  s_n_V      the normal photodiode signal S_n, volts
  s_l_V      the lateral photodiode signal S_l, volts
  direction  up or down: the pass going up or down the tilted facet
  set_point  optional: the set point the row's loop was taken at (any
             label, e.g. 2nN); with it one CSV holds a loop per set point
Each row is a sample from the middle of a pass (leave the turnarounds out).
As a Gwyddion file (.gwy, read with the gwyfile package), or any other
file Gwyddion reads (Nanoscope's; converted by gwyddion --convert-to-gwy
first): the images (channels /N/data) whose titles name the lateral
signal's trace and retrace and the normal signal, the pass by the title or
the channel's Line direction (docs/data.md, 'Friction loops in', says which
titles are recognised); --up-pass says which pass climbs the facet,
the outer --edge-fraction of each line at each end (the turnarounds) is
left out, and --s-n-V gives S_n per file where the file has no normal
channel. Per file the mean S_n and S_l of each direction make one point of
each line; at least 3 set points are needed (files, or set points of one
CSV). The slopes
r_u = dS_l/dS_n (up) and r_d (down) are fitted by least squares with their
standard errors, and the firmware's own solver (afm_calc calib tilted)
turns them into mu and k_theta K_l / h; their uncertainty is propagated
from the slopes' (first order, the solver's derivatives by central
differences). --write FILE writes the scene include as afm_calc does."""
import argparse
import collections
import csv
import dataclasses
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np

from analysis.text import printable

MIN_LOOPS = 3
# A Gwyddion channel's title (case-insensitive) names its signal by one of
# these words, and its pass by a retrace word (or its metadata does; else it
# is the trace). A normal title with "error" is a feedback error signal, not
# S_n, and one with a lateral word ("Lateral deflection") is S_l: neither is
# taken for S_n.
LATERAL_WORDS = ("lateral", "friction", "lfm", "torsion")
NORMAL_WORDS = ("deflection", "normal", "vertical")
RETRACE_WORDS = ("retrace", "backward", "bwd", "reverse")
EDGE_FRACTION = 0.1          # of each line's length, left out at each end (the turnarounds)


class LoopError(Exception):
    pass


# One image of a .gwy file: its title, the GwyDataField, its values (rows
# are lines), and whether it is a retrace (by its title's words, or its
# metadata's "Line direction: Retrace", as Gwyddion keeps Nanoscope's).
Channel = collections.namedtuple("Channel", "title field data retrace")


@dataclasses.dataclass
class GwyChoice:
    """How a loop is found in a .gwy file: the channels named by the user
    (a title or a channel number; None: found by their titles), which pass
    climbs the facet, the fraction of each line left out at each end, and
    S_n in volts when given per file instead of a normal channel."""
    up_pass: str | None = None
    lateral_trace: str | None = None
    lateral_retrace: str | None = None
    normal: str | None = None
    edge_fraction: float = EDGE_FRACTION
    s_n_V: float | None = None


def read_loops(path, gwy=None):
    """[(mean S_n up, mean S_l up, mean S_n down, mean S_l down)], volts, one
    per set point of a loop file (gwy: a GwyChoice): CSV by its .csv name
    (several set points with a set_point column), Gwyddion's own by its
    .gwy name, any other file converted to .gwy by Gwyddion first."""
    if not os.path.isfile(path):
        raise LoopError(f"{path}: not a file")
    if path.lower().endswith(".csv"):
        if gwy is not None and gwy.s_n_V is not None:
            raise LoopError(f"{path}: --s-n-V is for image files; a CSV loop has its own s_n_V column")
        return read_csv_loops(path)
    if path.lower().endswith(".gwy"):
        return [read_gwy_loop(path, path, gwy or GwyChoice())]
    with tempfile.TemporaryDirectory(prefix="afm-loop-") as tmp:
        return [read_gwy_loop(path, convert_to_gwy(path, os.path.join(tmp, "loop.gwy")), gwy or GwyChoice())]


def convert_to_gwy(path, out):
    """Debian's Gwyddion (gwyddion --convert-to-gwy, no display needed)
    writes the file it reads (Nanoscope and the other formats it knows) as
    out, a .gwy; returns out."""
    exe = shutil.which("gwyddion")
    if exe is None:
        raise LoopError(f"{path}: not .csv nor .gwy, and Gwyddion, which would read it, is not installed "
                        f"(./afm setup installs it)")
    p = subprocess.run([exe, "--no-log-to-file", f"--convert-to-gwy={out}", path], capture_output=True, text=True,
                       timeout=120, env=dict(os.environ, DISPLAY=""))
    if p.returncode != 0 or not os.path.isfile(out):
        said = " ".join(p.stderr.split())[-200:] or f"exit {p.returncode}"
        raise LoopError(f"{path}: not .csv nor .gwy, and Gwyddion does not read it (gwyddion: {said})")
    return out


def read_csv_loops(path):
    """read_loops of a CSV loop file (the module's header says its columns):
    UTF-8 text, with or without the byte-order mark Excel writes first; one
    loop per set_point label in the order they first appear (one loop
    without that column)."""
    acc = {}
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = csv.DictReader(f)
            missing = [c for c in ("s_n_V", "s_l_V", "direction") if c not in (rows.fieldnames or [])]
            if missing:
                raise LoopError(f"{path}: line 1: missing column(s) {', '.join(missing)} (have: {', '.join(rows.fieldnames or [])})")
            for i, r in enumerate(rows, start=2):
                read_csv_row(path, i, r, acc)
    except UnicodeDecodeError as e:
        raise LoopError(f"{path}: not UTF-8 text (it has byte 0x{e.object[e.start]:02x} where UTF-8 "
                        f"does not allow it): a CSV loop file is text") from None
    except OSError as e:
        raise LoopError(f"{path}: cannot read ({e.strerror})") from None
    except csv.Error as e:   # a NUL byte, a field over the csv module's limit (131 072 characters)
        raise LoopError(f"{path}: line {rows.line_num + 1}: not a CSV loop file ({e})") from None
    if not acc:
        acc[None] = {"up": [], "down": []}
    loops = []
    for sp, dirs in acc.items():
        where = path if sp is None else f"{path}: set_point {sp}"
        for d, v in dirs.items():
            if len(v) < 2:
                raise LoopError(f"{where}: {len(v)} sample(s) going {d}: a loop needs both passes")
        up, down = np.array(dirs["up"]), np.array(dirs["down"])
        loops.append((up[:, 0].mean(), up[:, 1].mean(), down[:, 0].mean(), down[:, 1].mean()))
    return loops


def read_csv_row(path, i, r, acc):
    """Row i of a CSV loop file into acc {set_point or None: {direction: [(S_n, S_l)]}}."""
    sp = None
    if "set_point" in r:
        sp = (r["set_point"] or "").strip()
        if not sp:
            raise LoopError(f"{path}: line {i}: set_point is empty (the file has a set_point column: every row names one)")
    d = (r["direction"] or "").strip()
    if d not in ("up", "down"):
        raise LoopError(f"{path}: line {i}: direction must be up or down, got '{d[:20]}'")
    try:
        sn, sl = float(r["s_n_V"]), float(r["s_l_V"])
    except (TypeError, ValueError):
        raise LoopError(f"{path}: line {i}: s_n_V and s_l_V must be numbers, got '{str(r['s_n_V'])[:20]}', "
                        f"'{str(r['s_l_V'])[:20]}'") from None
    if not (math.isfinite(sn) and math.isfinite(sl)):
        raise LoopError(f"{path}: line {i}: not finite: s_n_V {sn}, s_l_V {sl}")
    acc.setdefault(sp, {"up": [], "down": []})[d].append((sn, sl))


def gwy_fields(path, gwy_path):
    """{channel number: Channel} of the images of the .gwy file gwy_path
    (path, the user's file, names it in errors)."""
    with open(gwy_path, "rb") as f:
        head = f.read(4 + 64)
        size_B = os.fstat(f.fileno()).st_size
    if head[:4] != b"GWYP":
        raise LoopError(f"{path}: not a Gwyddion file: it starts with {head[:4]!r}, a .gwy file with b'GWYP'")
    name_end = head.find(b"\0", 4)     # the top object: its type name, NUL, its size (uint32, little-endian)
    if name_end < 0 or name_end + 5 > len(head):
        raise LoopError(f"{path}: not a Gwyddion file: no object after b'GWYP'")
    want_B = name_end + 5 + int.from_bytes(head[name_end + 1:name_end + 5], "little")
    if want_B != size_B:
        raise LoopError(f"{path}: cannot be read as a Gwyddion file: its top object ends at byte {want_B}, "
                        f"the file has {size_B} bytes (cut short?)")
    try:
        import gwyfile
    except ImportError:
        raise LoopError(f"{path}: the gwyfile package is not installed in this venv; run ./afm setup") from None
    try:
        obj = gwyfile.load(gwy_path)
        fields = {}
        for key, value in obj.items():
            m = re.fullmatch(r"/(\d+)/data", key)
            if m and isinstance(value, gwyfile.objects.GwyDataField):
                n = int(m.group(1))
                title, meta = str(obj.get(f"/{n}/data/title", "")), obj.get(f"/{n}/meta", {})
                direction = [str(v) for k, v in meta.items() if str(k).lower() == "line direction"]
                retrace = (any(w in title.lower() for w in RETRACE_WORDS)
                           or any(d.strip().lower() == "retrace" for d in direction))
                fields[n] = Channel(title, value, np.asarray(value.data, float), retrace)
    except Exception as e:   # a damaged file can fail anywhere in a third-party parser: name it
        raise LoopError(f"{path}: cannot be read as a Gwyddion file ({type(e).__name__}: {str(e)[:80]})") from None
    if not fields:
        raise LoopError(f"{path}: no image channel (/N/data) in the file")
    return fields


def channel_list(fields):
    """The channels as an error names them: number, title, and (retrace) where
    only the metadata says so."""
    return ", ".join(f"{n} '{c.title}'" + (" (retrace)" if c.retrace and "retrace" not in c.title.lower() else "")
                     for n, c in sorted(fields.items()))


def titled(title, words):
    """Whether a channel's title names a signal of words (LATERAL_WORDS or NORMAL_WORDS)."""
    t = title.lower()
    if words is NORMAL_WORDS and ("error" in t or titled(t, LATERAL_WORDS)):
        return False
    return any(w in t for w in words)


def pick_channel(path, fields, named, words, retrace, option):
    """The number of the channel named by the user (a title or a number), or
    else the one whose title has one of words and is (not) a retrace."""
    if named is not None:
        hits = [n for n, c in fields.items() if (named.isdigit() and n == int(named)) or c.title.lower() == named.lower()]
        if len(hits) != 1:
            raise LoopError(f"{path}: {option} '{named}': {'no' if not hits else len(hits)} channel(s) of that title or "
                            f"number (channels: {channel_list(fields)})")
        return hits[0]
    hits = [n for n, c in fields.items() if titled(c.title, words) and c.retrace == retrace]
    if len(hits) != 1:
        what = f"{'/'.join(words)} ({'retrace' if retrace else 'trace'})"
        raise LoopError(f"{path}: {'no' if not hits else len(hits)} channel(s) titled as {what}; name it with {option} "
                        f"TITLE|NUMBER (channels: {channel_list(fields)})")
    return hits[0]


def channel_mean_V(path, fields, n, edge_fraction):
    """The mean of channel n over its lines' middles, volts."""
    title, field, data, _ = fields[n]
    unit = field.si_unit_z.unitstr if field.si_unit_z is not None else ""
    if unit != "V":
        raise LoopError(f"{path}: channel {n} '{title}': unit '{unit}', the loop needs volts (V); set it in Gwyddion "
                        f"(Dimensions and Units) or name another channel")
    cut = int(edge_fraction * data.shape[1])
    middle = data[:, cut:data.shape[1] - cut]
    if middle.size == 0:
        raise LoopError(f"{path}: channel {n} '{title}': {data.shape[1]} sample(s) a line, none left with "
                        f"--edge-fraction {edge_fraction}")
    bad = int(np.count_nonzero(~np.isfinite(middle)))
    if bad:
        raise LoopError(f"{path}: channel {n} '{title}': {bad} value(s) not finite")
    return float(middle.mean())


def read_gwy_loop(path, gwy_path, choice):
    """read_loop of the .gwy file gwy_path (path: the user's file, as errors
    name it): S_l from the lateral trace and retrace channels, S_n from the
    normal channel(s) or choice.s_n_V."""
    if choice.up_pass not in ("trace", "retrace"):
        raise LoopError(f"{path}: which pass climbs the facet? name it with --up-pass trace or --up-pass retrace "
                        f"(got {choice.up_pass!r})")
    if not 0 <= choice.edge_fraction < 0.5:
        raise LoopError(f"--edge-fraction {choice.edge_fraction}: must be at least 0 and below 0.5")
    fields = gwy_fields(path, gwy_path)
    sl = {p: channel_mean_V(path, fields, pick_channel(path, fields, named, LATERAL_WORDS, p == "retrace", opt),
                            choice.edge_fraction)
          for p, named, opt in (("trace", choice.lateral_trace, "--lateral-trace"),
                                ("retrace", choice.lateral_retrace, "--lateral-retrace"))}
    if choice.s_n_V is not None:
        sn = {"trace": choice.s_n_V, "retrace": choice.s_n_V}
    else:
        sn = {p: channel_mean_V(path, fields, normal_channel(path, fields, choice.normal, p), choice.edge_fraction)
              for p in ("trace", "retrace")}
    down = "retrace" if choice.up_pass == "trace" else "trace"
    return sn[choice.up_pass], sl[choice.up_pass], sn[down], sl[down]


def normal_channel(path, fields, named, pass_):
    """The normal channel for a pass: the one named (both passes), the one
    of that pass by its title, or the only normal channel (both passes)."""
    if named is not None:
        return pick_channel(path, fields, named, NORMAL_WORDS, False, "--normal")
    normals = [n for n, c in fields.items() if titled(c.title, NORMAL_WORDS)]
    if len(normals) == 1:
        return normals[0]
    if not normals:
        raise LoopError(f"{path}: no channel titled as {'/'.join(NORMAL_WORDS)} for S_n (an error signal is not S_n); "
                        f"name it with --normal TITLE|NUMBER or give --s-n-V per file (channels: {channel_list(fields)})")
    return pick_channel(path, fields, None, NORMAL_WORDS, pass_ == "retrace", "--normal")


def fit_line(x, y):
    """Least squares y = r x + b: (r, b, the standard error of r; None with
    only two points)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    (r, b) = np.polyfit(x, y, 1)
    if len(x) < 3:
        return float(r), float(b), None
    resid = y - (r * x + b)
    sxx = float(np.sum((x - x.mean()) ** 2))
    se = math.sqrt(float(np.sum(resid ** 2)) / (len(x) - 2) / sxx) if sxx > 0 else float("inf")
    return float(r), float(b), se


def fit_slopes(means):
    """The loops' means (one 4-tuple per set point) to r_u and r_d with
    their intercepts and standard errors: {'up': (r, b, se), 'down': ...}."""
    m = np.array(means, float)
    if len(m) >= 2 and np.ptp(m[:, 0]) <= 0:
        raise LoopError("every loop has the same S_n: the slopes need loops at different set points")
    return {"up": fit_line(m[:, 0], m[:, 1]), "down": fit_line(m[:, 2], m[:, 3])}


def solve(calc, ru, rd, phi, kn, Kn, write=None):
    args = [calc, "calib", "tilted", "--up", f"{ru:.8f}", "--down", f"{rd:.8f}", "--angle-deg", f"{phi:.6f}",
            "--spring-N-per-m", f"{kn:.8f}", "--deflection-nm-per-V", f"{Kn:.6f}", "--json"]
    if write:
        args += ["--write", write]
    p = subprocess.run(args, capture_output=True, text=True, timeout=60)
    if p.returncode != 0:
        raise LoopError(f"afm_calc calib tilted (r_u {ru:.6f}, r_d {rd:.6f}): {p.stderr.strip()}")
    return json.loads(p.stdout)


def calibrate(calc, files, phi, kn, Kn, write=None, gwy=None, s_n_V=None):
    """The calibration from loop files (gwy: a GwyChoice for .gwy files;
    s_n_V: S_n per file, volts, or None) as the dict main prints."""
    if s_n_V is not None and len(s_n_V) != len(files):
        raise LoopError(f"--s-n-V: {len(s_n_V)} value(s) for {len(files)} loop file(s); give one per file, in their order")
    gwy = gwy or GwyChoice()
    means = [m for i, f in enumerate(files)
             for m in read_loops(f, dataclasses.replace(gwy, s_n_V=None if s_n_V is None else s_n_V[i]))]
    if len(means) < MIN_LOOPS:
        raise LoopError(f"--loops: {len(means)} set point(s) in {len(files)} file(s); at least {MIN_LOOPS} set points "
                        "are needed for the slopes and their errors")
    fit = fit_slopes(means)
    (ru, bu, su), (rd, bd, sd) = fit["up"], fit["down"]
    sol = solve(calc, ru, rd, phi, kn, Kn, write)
    # first-order propagation: the solver's derivatives by central differences
    sigma = {}
    for key in ("mu", "lateral_nN_per_V"):
        var = 0.0
        for i, (r, s) in enumerate(((ru, su), (rd, sd))):
            h = max(abs(r) * 1e-3, 1e-6)
            a = solve(calc, ru + h if i == 0 else ru, rd + h if i == 1 else rd, phi, kn, Kn)[key]
            b = solve(calc, ru - h if i == 0 else ru, rd - h if i == 1 else rd, phi, kn, Kn)[key]
            var += ((a - b) / (2 * h) * s) ** 2
        sigma[key] = math.sqrt(var)
    return {"loops": len(means), "r_u": ru, "r_u_se": su, "r_d": rd, "r_d_se": sd, "intercept_up_V": bu,
            "intercept_down_V": bd, "mu": sol["mu"], "mu_se": sigma["mu"], "lateral_nN_per_V": sol["lateral_nN_per_V"],
            "lateral_nN_per_V_se": sigma["lateral_nN_per_V"], "solver": sol}


def main(argv=None):
    from analysis import helptext
    ap = argparse.ArgumentParser(prog="./afm calib tilted --loops", formatter_class=argparse.RawDescriptionHelpFormatter,
                                 description=helptext.text("calib") + "\n\n" + __doc__.split("\n\n")[0],
                                 epilog="the file format: docs/data.md, 'Friction loops in'")
    ap.add_argument("--loops", nargs="+", required=True, metavar="FILE", help="one friction loop per set point: .csv, .gwy, or a scan Gwyddion reads; "
                    "or one .csv holding every set point (a set_point column)")
    ap.add_argument("--angle-deg", type=float, required=True, help="the facet's slope phi, degrees")
    ap.add_argument("--spring-N-per-m", type=float, required=True, help="k_n, N/m")
    ap.add_argument("--deflection-nm-per-V", type=float, required=True, help="K_n, nm/V")
    ap.add_argument("--write", help="write the scene include (firmware.lateral_nN_per_V, firmware.mu)")
    ap.add_argument("--json", action="store_true", help="the answer as JSON")
    g = ap.add_argument_group("scan files: .gwy, Nanoscope, ... (docs/data.md, 'Friction loops in')")
    g.add_argument("--up-pass", choices=("trace", "retrace"), help="the pass that climbs the facet (needed for a scan file)")
    g.add_argument("--lateral-trace", metavar="CH", help="the lateral trace channel: its title or number")
    g.add_argument("--lateral-retrace", metavar="CH", help="the lateral retrace channel: its title or number")
    g.add_argument("--normal", metavar="CH", help="the normal (S_n) channel for both passes: its title or number")
    g.add_argument("--s-n-V", type=float, nargs="+", metavar="V", help="S_n per file, volts, in the files' order "
                   "(instead of a normal channel)")
    g.add_argument("--edge-fraction", type=float, default=EDGE_FRACTION,
                   help=f"of each line, left out at each end (default {EDGE_FRACTION})")
    ap.add_argument("--calc", default=os.environ.get("AFM_CALC", ""), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if not a.calc or not os.path.exists(a.calc):
        print(f"calib tilted --loops: the calculator is not built ({a.calc or 'AFM_CALC unset'}); run ./afm build", file=sys.stderr)
        return 2
    try:
        gwy = GwyChoice(up_pass=a.up_pass, lateral_trace=a.lateral_trace, lateral_retrace=a.lateral_retrace,
                        normal=a.normal, edge_fraction=a.edge_fraction)
        r = calibrate(a.calc, a.loops, a.angle_deg, a.spring_N_per_m, a.deflection_nm_per_V, a.write, gwy, a.s_n_V)
    except LoopError as e:
        print(f"calib tilted --loops: {printable(str(e))}", file=sys.stderr)   # names and values from the files, escaped
        return 2
    if a.json:
        print(json.dumps(r, indent=1))
        return 0
    se = lambda v: "-" if v is None else f"{v:.6f}"
    print(f"calib tilted: {r['loops']} loops; r_u = {r['r_u']:.6f} +- {se(r['r_u_se'])}, r_d = {r['r_d']:.6f} +- {se(r['r_d_se'])}")
    print(f"calib tilted: mu = {r['mu']:.5f} +- {r['mu_se']:.5f}; k_theta K_l / h = {r['lateral_nN_per_V']:.3f} +- "
          f"{r['lateral_nN_per_V_se']:.3f} nN/V (one standard error, from the slopes' fit)")
    if a.write:
        print(f"calib tilted: wrote {a.write}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
