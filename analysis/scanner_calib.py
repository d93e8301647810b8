"""./afm calib scanner: the scanner's hysteresis measured on the bench, as a
lab measures it, from scans of a calibration grating (issue 48, item 2).

    ./afm calib scanner SCENE [--write FILE] [--out DIR] [--px N] [--plays N]

The scene gives the instrument: its effects and their levels (afm.*), its
probe, its field and seed. The calibration runs a scene of its own on that
instrument (DIR/grating.yaml): no objects, the substrate a grating of known
pitch P (DIR/grating.gsf: h = A [cos(2 pi x / P) + cos(2 pi y / P)], a
lab's calibration grating), the tip resting at the field's top right
corner. The run's initial scan (scan_initial.gsf) is what the calibration
reads: its image is drawn at the commanded positions, so the grating's
features appear where the scanner's hysteresis put the tip.

Registration (nothing of the scene's afm.* keys is read):
  x  the scan lines, each levelled (its mean taken off), averaged, detrended
     (a quadratic: the scanner's bow): the fast axis's profile; its
     mid-height crossings by linear interpolation; the centre of each pair
     of consecutive crossings (a ridge's or a groove's: the tip's dilation
     and the servo's lag shift a pair's crossings alike) is one point, its
     commanded position against its place on the grating, j P / 2 (the
     grating's zero unknown: the fit's offset takes it);
  y  likewise along the slow axis, each line's mean (the line offsets
     stay in it: noise the pairs and the fit average).
A trace line runs up the field after a retrace down it, and the raster
climbs from the field's bottom after the tip came from its top: both are
the ascending branch of the full-field cycle, from which the whole loop
follows (analysis/scanner_fit.py, loop_from_branch); fit_branch fits the
card's direct Prandtl-Ishlinskii model (N plays, NNLS).

Writes DIR/scanner_loop.png (each axis's branch, the fit, the residual),
DIR/scanner_fit.json, and with --write FILE the include a scene takes
(firmware.scanner: run, x, y; the card's hyst_enable is the scene's
switch). The creep law is not measured here (a scene gives it as
firmware.creep_gamma_pct_per_decade and firmware.creep_t0_s: a lab's step
test), and the grating is scanned without piezo_creep: a lab lets its
scanner settle before it calibrates the hysteresis, while the bench's
raster after the move to its first point creeps line by line (physics.md
17.2: about 300 nm over the 200 s of a 320-line scan), which would bend
the measured loop.
Exit 0 with a fit, 2 when a step fails (one line naming it)."""
import argparse
import hashlib
import json
import os
import struct
import sys

import numpy as np
import yaml

from analysis import paths, point, scanner_fit
from analysis.paper import common
from analysis.resolved import SceneRefused, resolved_scene

# The effects that shape a scan (those of objects and of the lever's
# pushes have nothing to act on in the grating's scene; piezo_creep is left
# out: the scanner settled, above).
SCAN_EFFECTS = ("piezo_hysteresis", "scan_artefacts", "z_drift", "photodiode_noise", "tip_convolution",
                "roughness", "bending_offset", "adhesion")
AMPLITUDE_NM = 10.0     # A: each axis's cosine, 20 nm peak to peak
MAP_PITCH_NM = 10.0     # the grating map's pixels
CORNER_NM = 10.0        # the tip's rest inside the field's top right corner
# The grating's scan spans this times the scene's field: a play of the
# scanner whose threshold is near half the field turns only at the very end
# of a branch the field's own width spans, so its weight would rest on the
# last point or two; unmeasured, the fit leaves it out, and the model's
# level on the field's full-width branch (a full scan's: de-warped by the
# card's model) is off by its weight times its threshold (14 nm at the lab
# scene's 5 um). A quarter more measures it.
SPAN_FIELD = 1.25


class CalibError(Exception):
    """A step of the calibration failed (its message names it)."""


def say(msg):
    print(f"calib scanner: {msg}", flush=True)


def load_instrument(scene_path):
    """The scene as the launcher resolves it (analysis/resolved.py: its
    includes merged by the C++ reader). A scene that includes the
    calibration's own output before it exists is refused there: calibrate
    it without that include first."""
    try:
        return resolved_scene(scene_path)
    except SceneRefused as e:
        raise CalibError(f"{e} (a scene that includes this calibration's output is calibrated without that include "
                         "the first time)") from None


def pitch_nm(field_nm, px):
    """The grating's pitch: 200 nm, or 10 of the scan's pixels if coarser."""
    return max(200.0, 10.0 * field_nm / px)


def write_grating(path, field_nm, centre, pitch):
    """The grating's height map as GSF (row 0 at the top), covering the
    field and 30 % of it to spare on every side (a scanner with hysteresis
    puts the tip beyond the field its command spans)."""
    side = 1.6 * field_nm + 2 * pitch
    n = int(np.ceil(side / MAP_PITCH_NM)) + 1
    x0, y0 = centre[0] - side / 2, centre[1] - side / 2
    xs = x0 + (np.arange(n) + 0.5) * side / n
    ys = y0 + side - (np.arange(n) + 0.5) * side / n
    k = 2 * np.pi / pitch
    h = AMPLITUDE_NM * (np.cos(k * xs)[None, :] + np.cos(k * ys)[:, None])
    head = (f"Gwyddion Simple Field 1.0\nXRes = {n}\nYRes = {n}\nXReal = {side * 1e-9:.9g}\nYReal = {side * 1e-9:.9g}\n"
            f"XOffset = {x0 * 1e-9:.9g}\nYOffset = {y0 * 1e-9:.9g}\nXYUnits = m\nZUnits = m\nTitle = calibration grating, "
            f"pitch {pitch:g} nm\n").encode()
    head += b"\0" * (4 - len(head) % 4)
    with open(path, "wb") as f:
        f.write(head + struct.pack(f"<{n * n}f", *(h * 1e-9).astype(np.float32).ravel()))


def grating_scene(scene, px, duration_s):
    """The calibration's scene on the instrument of `scene`."""
    sample = scene.get("sample") or {}
    field = SPAN_FIELD * float(sample.get("field_nm", 2000))
    centre = sample.get("field_center_nm", [0, 0])
    rest = [centre[0] + field / 2 - CORNER_NM, centre[1] + field / 2 - CORNER_NM]
    fw = {k: v for k, v in (scene.get("firmware") or {}).items()
          if k not in ("hyst_enable", "creep_enable", "scanner", "calibration")}
    out = {"name": "scanner-calibration", "seed": scene.get("seed", 1), "duration_s": duration_s,
           "effects": [e for e in scene.get("effects") or [] if e in SCAN_EFFECTS],
           "sample": {"substrate": {"gsf": "grating.gsf"}, "field_nm": field,
                      **{k: sample[k] for k in ("field_center_nm", "tip_substrate") if k in sample}},
           "probe": scene.get("probe") or {}, "firmware": fw,
           "operator": {"load_nN": (scene.get("operator") or {}).get("load_nN", 5), "speed_nm_per_s": 1000,
                        "path_nm": [rest, [rest[0] - 5, rest[1]]]},
           "outputs": {"image_px": px, "video": "none"}}
    for k in ("sample_rate_hz", "block_hz", "frame_rate_hz"):
        if k in scene:
            out[k] = scene[k]
    if scene.get("afm"):
        out["afm"] = scene["afm"]
    if not out["probe"]:
        del out["probe"]
    return out, field, centre


def crossings(u, h):
    """Where h crosses its mean, by linear interpolation (u increasing)."""
    h = h - np.mean(h)
    s = np.sign(h)
    i = np.nonzero(s[:-1] * s[1:] < 0)[0]
    return u[i] - h[i] * (u[i + 1] - u[i]) / (h[i + 1] - h[i])


def branch_points(u, profile, pitch):
    """An axis's registered points: (commanded centres, grating places)."""
    q = np.polyval(np.polyfit(u, profile, 2), u)
    c = crossings(u, profile - q)
    if len(c) < 6:
        raise CalibError(f"the scan shows {len(c)} crossings of the grating along an axis (6 at least): is the grating "
                         f"in the field and the scan fine enough (pitch {pitch:g} nm)?")
    centres = 0.5 * (c[:-1] + c[1:])
    return centres, np.arange(len(centres)) * pitch / 2


def register(run_dir, pitch):
    """Each axis's points from the run's initial scan: {"x": (cmd, place), "y": ...},
    and each axis's pixel centres (the command's turning points are its ends)."""
    h, xs, ys = common.scan(run_dir, "scan_initial")
    x_profile = (h - h.mean(axis=1, keepdims=True)).mean(axis=0)   # each line levelled: its offset and the y part gone
    y_profile = h.mean(axis=1)                                     # each line's mean: the y part, with its offset
    order = np.argsort(ys)
    return {"x": branch_points(xs, x_profile, pitch), "y": branch_points(ys[order], y_profile[order], pitch)}, (xs, ys)


def half_ranges(pixels, centre):
    """Each axis's cycle half range about the centre: its farthest pixel, pm."""
    return [float(np.max(np.abs(p - c))) * 1e3 for p, c in zip(pixels, centre)]


def fit_axes(points, centre, plays, halves):
    """fit_branch per axis, in pm, about the field's centre, over the scan's
    cycle (halves: its half range per axis, pm)."""
    out = {}
    for i, ax in enumerate(("x", "y")):
        cmd, place = points[ax]
        try:
            out[ax] = scanner_fit.fit_branch(cmd * 1e3, place * 1e3, centre[i] * 1e3, plays, halves[i])
        except ValueError as e:
            raise CalibError(f"axis {ax}: {e}")
        sums = np.cumsum(out[ax]["w"])
        if sums.min() < 0.5 or sums.max() > 2:
            raise CalibError(f"axis {ax}: the fit's partial sums span [{sums.min():.3f}, {sums.max():.3f}], outside the "
                             f"card's [0.5, 2] (fw_hyst.h): not a scanner the card can invert")
    return out


def plot(points, fits, centre, halves, path):
    plt = common.plt()
    fig, axes = plt.subplots(2, 2, figsize=(10, 7))
    for i, ax in enumerate(("x", "y")):
        cmd, place = points[ax]
        f = fits[ax]
        lcmd, lmeas = scanner_fit.loop_from_branch(cmd * 1e3, place * 1e3, centre[i] * 1e3, halves[i])
        model = scanner_fit.pi_model(lcmd - centre[i] * 1e3, f["r_pm"], f["w"]) + f["offset_pm"] + centre[i] * 1e3
        a = axes[0][i]
        a.plot(lcmd * 1e-3, (lmeas * 1e-3 - lcmd * 1e-3), color="0.7", label="the loop (from the branch)")
        a.plot(lcmd * 1e-3, model * 1e-3 - lcmd * 1e-3, "b-", lw=1, label=f"PI fit, {len(f['w'])} plays")
        a.plot(cmd, place - cmd, "k.", ms=4, label="registered (ascending branch)")
        a.set_xlabel(f"{ax} commanded (nm)")
        a.set_ylabel("position - command (nm; grating's zero free)")
        a.set_title(f"{ax}: the scanner's loop")
        a.legend(fontsize=7)
        b = axes[1][i]
        up = scanner_fit.ascending(len(lcmd))
        at = np.interp(cmd * 1e3, lcmd[up], model[up]) * 1e-3
        b.plot(cmd, at - place, "r.-", ms=4)
        b.set_xlabel(f"{ax} commanded (nm)")
        b.set_ylabel("fit - registered (nm)")
        b.set_title(f"residual: rms {f['rms_pm'] * 1e-3:.2f} nm, worst {f['worst_pm'] * 1e-3:.2f} nm")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_id(grating_yaml_text, gsf_path):
    """The calibration's id: its scene's text and its grating, hashed."""
    h = hashlib.sha256(grating_yaml_text.encode())
    with open(gsf_path, "rb") as f:
        h.update(f.read())
    return "scanner sha256:" + h.hexdigest()[:16]


def write_include(path, rid, fits, scene_path):
    def axis(f):
        return {"r_nm": [round(r * 1e-3, 4) for r in f["r_pm"]], "w": [round(w, 8) for w in f["w"]]}
    doc = {"firmware": {"scanner": {"run": rid, "x": axis(fits["x"]), "y": axis(fits["y"])}}}
    with open(path, "w") as f:
        f.write(f"# The scanner's direct hysteresis model, x and y, as ./afm calib scanner {scene_path} fitted it\n"
                f"# from scans of a grating on that scene's instrument (residual: x {fits['x']['rms_pm'] * 1e-3:.2f} nm,"
                f" y {fits['y']['rms_pm'] * 1e-3:.2f} nm rms).\n"
                f"# A scene includes this file and turns the card's compensation on with firmware.hyst_enable: true.\n")
        yaml.safe_dump(doc, f, sort_keys=False, default_flow_style=None, width=120)


def calibrate(a):
    os.makedirs(a.out, exist_ok=True)
    scene = load_instrument(a.scene)
    cal, field, centre = grating_scene(scene, a.px, a.duration_s)
    pitch = pitch_nm(field, a.px)
    gsf_path = os.path.join(a.out, "grating.gsf")
    write_grating(gsf_path, field, centre, pitch)
    text = f"# ./afm calib scanner {a.scene}: the grating on the scene's instrument\n" + yaml.safe_dump(cal, sort_keys=False)
    scene_path = os.path.join(a.out, "grating.yaml")
    with open(scene_path, "w") as f:
        f.write(text)
    say(f"grating pitch {pitch:g} nm over the {field:g} nm field ({scene_path}); scanning at {a.px} px")
    run_dir = os.path.join(a.out, "run")
    code, err, rj, wall = point.run_scene(scene_path, run_dir, a.timeout_s)
    if code != 0 or not rj or rj.get("status") != "ok":
        raise CalibError(f"the grating's run failed (exit {code}): {point.failure_of(code, err, rj, run_dir)}")
    say(f"scanned in {wall:.1f} s ({run_dir})")
    points, pixels = register(run_dir, pitch)
    say(f"registered {len(points['x'][0])} points along x, {len(points['y'][0])} along y")
    halves = half_ranges(pixels, centre)
    fits = fit_axes(points, centre, a.plays, halves)
    for ax in ("x", "y"):
        f = fits[ax]
        say(f"{ax}: {len(f['w'])} plays, slopes {np.cumsum(f['w'])[0]:.3f} to {np.sum(f['w']):.3f}, residual rms "
            f"{f['rms_pm'] * 1e-3:.2f} nm, worst {f['worst_pm'] * 1e-3:.2f} nm")
    rid = run_id(text, gsf_path)
    png = os.path.join(a.out, "scanner_loop.png")
    plot(points, fits, centre, halves, png)
    with open(os.path.join(a.out, "scanner_fit.json"), "w") as f:
        json.dump({"run": rid, "pitch_nm": pitch, "fit": fits,
                   "points": {ax: {"commanded_nm": p[0].tolist(), "grating_nm": p[1].tolist()} for ax, p in points.items()}},
                  f, indent=1)
    say(f"plot {png}")
    if a.write:
        write_include(a.write, rid, fits, a.scene)
        say(f"wrote {a.write} (firmware.scanner; include it and set firmware.hyst_enable: true)")
    return 0


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="./afm calib scanner",
                                 description="The scanner's hysteresis from scans of a grating on the scene's instrument.")
    ap.add_argument("scene", metavar="SCENE", help="the scene whose instrument (effects, afm.*, probe, field) is calibrated")
    ap.add_argument("--write", metavar="FILE", help="write the include a scene takes (firmware.scanner)")
    ap.add_argument("--out", metavar="DIR", default=os.path.join(paths.ROOT, "runs", "calib_scanner"),
                    help="the calibration's folder: its scene, grating, run, plot (default runs/calib_scanner)")
    ap.add_argument("--px", type=int, default=256, help="the scan's pixels a side (default 256)")
    ap.add_argument("--plays", type=int, default=16, help="the model's play operators, 1 to 16 (default 16)")
    ap.add_argument("--duration-s", dest="duration_s", type=float, default=0.2, help=argparse.SUPPRESS)
    ap.add_argument("--timeout-s", dest="timeout_s", type=float, default=600, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if not 1 <= a.plays <= 16:
        ap.error(f"--plays must be 1 to 16 (fw_hyst.h), got {a.plays}")
    if not 32 <= a.px <= 4096:
        ap.error(f"--px must be 32 to 4096, got {a.px}")
    return a


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        return calibrate(a)
    except (CalibError, common.PaperError, OSError) as e:
        print(f"calib scanner: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
