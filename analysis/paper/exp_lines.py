"""Lines inscribed on polycarbonate along the same piezo path at four push
depths, without compensation; S_n saturates, so the virtual S_n' = dz / K_n
stands in (dz read from the run's z piezo against the surface in its
initial scan); each line is found in its run's final scan (the
depth-weighted centre of its groove); the firmware's fw_calib_lines_cn
(afm_calc calib lines) fits C_n. The simulated lever's true C_n differs from
the beam's estimate. Then afm_calc calib lines --write makes the include
file a scene takes, and a push with the estimate and one with the
calibrated value, each cutting a line with compensation on, show the apex
error as the paper reads it: the line's x in a fresh scan against the
card's apex (FW_STATE); the simulator's apex (SIM_TRUTH) is the truth."""
import os

import numpy as np

from analysis.units import show, listed
from analysis.paper import common

NAME = "lines"
TITLE = "C_n from inscribed lines"
FIGURES = "fig. 8"

DEPTHS_UM = [0.5, 1.0, 1.5, 2.0]      # the paper's dz
CUT_HALF_NM = 200                     # the middle of the 600 nm line
INCLUDE = "calibrated_lever.yaml"
SATURATES_FROM_UM = 1.0               # a cut this deep or deeper saturates S_n (its run's verdict expects it)
# Fig. 8's frame: the same lines at other scan angles, the scene turned with
# the lever (path and field rotated by scan angle - 270 about z, eq. 2), so
# that in frame C every run is the 270 deg run. 0 deg: the paper's setting;
# 90 deg: where frame A is a half turn from frame C (the paper's claim for 0).
ANGLES = {"full": {0: DEPTHS_UM, 90: DEPTHS_UM}, "reduced": {0: [0.5, 2.0]}}


def runs(size):
    kn = common.paper_probe()["spring_N_per_m"]   # the scene's lever: the paper's k_n
    out = [common.Run(name=f"dz_{d:.1f}um", scene="lines.yaml", cost_s=4,
                      settings={"operator.load_nN": round(kn * d * 1000, 3), **expect(d)}) for d in DEPTHS_UM]
    scene = common.load_scene("lines.yaml")
    for angle, depths in ANGLES[size].items():
        rot = lambda p: [round(float(v), 3) for v in lever_to_A(angle) @ np.asarray(p, float)]
        turned = {"probe.scan_angle_deg": angle, "operator.path_nm": [rot(p) for p in scene["operator"]["path_nm"]],
                  "sample.field_center_nm": rot(scene["sample"]["field_center_nm"])}
        out += [common.Run(name=angle_run(angle, d), scene="lines.yaml", cost_s=4,
                           settings={**turned, "operator.load_nN": round(kn * d * 1000, 3), **expect(d)}) for d in depths]
    return out


def expect(depth_um):
    """The verdict's checks a cut fails on purpose: from 1 um of dz on, the
    lines are cut without compensation past S_n's range (saturation), which
    is why S_n' = dz / K_n stands in."""
    return {"expect": ["saturation"]} if depth_um >= SATURATES_FROM_UM else {}


LINE_RUNS = tuple(f"dz_{d:.1f}um" for d in DEPTHS_UM)   # the 270 deg lines the calibration is fitted to


def angle_run(angle, d):
    return f"a{angle}_dz_{d:.1f}um"


def lever_to_A(angle):
    """R(alpha) of eq. 2, alpha = scan angle - 270 deg, rounded (a quarter
    turn's multiple): frame A of the 270 deg run into frame A at this angle."""
    if angle % 90:
        raise common.PaperError(f"scan angle {angle}: the lines' frame check takes multiples of 90 deg")
    a = np.radians(angle - 270)
    return np.round(np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]))


def more_runs(size, dirs, exp_dir):
    cal = calibrate(dirs, exp_dir)
    return [common.Run(name="push_estimate", scene="lines_push.yaml", cost_s=3),
            common.Run(name="push_calibrated", scene="lines_push.yaml", settings={"include": cal["include"]}, cost_s=3)]


def line_x(run_dir, min_depth_nm=0.5):
    """The line's x (nm, frame A) in the run's final scan at 270 deg: see line_at."""
    return line_at(run_dir, 270, min_depth_nm)


def line_at(run_dir, angle, min_depth_nm=0.5):
    """The line in the run's final scan, cut at this scan angle: the
    depth-weighted centre of the groove in the mean profile across the
    cut's middle, along the frame-A axis the lever's x_C lies on (x at 270
    and 90 deg, y at 0 and 180). Returns (the centre's coordinate on that
    axis, nm, frame A; the axis's coordinates; the profile)."""
    R = lever_to_A(angle)
    u, w = R @ np.array([1.0, 0.0]), R @ np.array([0.0, 1.0])   # the lever's x_C and the cut's direction, frame A
    h, xs, ys = common.scan(run_dir, "scan_final")
    if abs(u[0]) > 0.5:
        coord, prof = xs, h[np.abs(ys * w[1]) < CUT_HALF_NM].mean(axis=0)
    else:
        coord, prof = ys, h[:, np.abs(xs * w[0]) < CUT_HALF_NM].mean(axis=1)
    i = int(prof.argmin())
    if prof[i] > -min_depth_nm:
        raise common.PaperError(f"{run_dir}/scan_final.gsf: no groove deeper than {min_depth_nm} nm")
    near = (np.abs(coord - coord[i]) < 40) & (prof < 0)
    wt = -prof[near]
    return float((coord[near] * wt).sum() / wt.sum()), coord, prof


def push_depth(run_dir, angle=270):
    """dz (nm): the surface (initial scan, mean) above the z piezo, mid-cut
    (the cut runs along the lever's y_C, turned into frame A by the scan angle)."""
    a, fs = common.analog(run_dir)
    h0, _, _ = common.scan(run_dir, "scan_initial")
    w = lever_to_A(angle) @ np.array([0.0, 1.0])
    along = a["x_nm"] * w[0] + a["y_nm"] * w[1]
    v = np.gradient(along) * fs
    mid = (np.abs(along) < CUT_HALF_NM) & (v > 1000)
    if mid.sum() < 100:
        raise common.PaperError(f"{run_dir}: too few samples mid-cut ({mid.sum()})")
    return float(h0.mean() - np.median(a["z_nm"][mid])), float(np.mean(a["sn_v"][mid]))


_CALIBRATED = {}   # (exp_dir, the lines' run folders) -> calibrate's answer: the second round and the analysis share it


def calibrate(dirs, exp_dir):
    """The lines found, their dz, C_n fitted and the include file written
    (once per set of runs)."""
    names = [f"dz_{d:.1f}um" for d in DEPTHS_UM]
    key = (exp_dir, tuple(dirs[n] for n in names))
    if key not in _CALIBRATED:
        _CALIBRATED[key] = _calibrate([dirs[n] for n in names], exp_dir)
    return _CALIBRATED[key]


def _calibrate(run_dirs, exp_dir):
    found = [line_x(d) for d in run_dirs]
    xs = [f[0] for f in found]
    dz = [push_depth(d)[0] for d in run_dirs]
    card = common.run_json(run_dirs[0])["card"]
    Kn = card["deflection_pm_per_v"] * 1e-3
    offsets = [x - xs[0] for x in xs]
    include = os.path.join(exp_dir, INCLUDE)
    sol = common.calc("calib", "lines", "--depths-nm", ",".join(f"{d:.3f}" for d in dz),
                      "--offsets-nm", ",".join(f"{o:.3f}" for o in offsets), "--deflection-nm-per-V", f"{Kn:.4f}",
                      "--write", include)
    return {"x": xs, "profiles": [(f[1], f[2]) for f in found], "dz": dz, "offsets": offsets, "Kn": Kn, "sol": sol,
            "include": include}


def analyse(dirs, exp_dir, size):
    cal = calibrate(dirs, exp_dir)
    truth = common.truth(dirs["dz_0.5um"])
    cn_t = float(truth["probe"]["cn_nm_per_V"])
    p = common.paper_probe()
    estimate = 3 * p["tip_height_um"] * p["deflection_nm_per_V"] / (2 * p["lever_length_um"])
    spacing = float(np.mean(np.diff(cal["offsets"])))
    spacing_t = cn_t * (np.mean(np.diff(cal["dz"]))) / cal["Kn"]
    res = common.Result()
    res.rows = [
        common.Row("line spacing per 0.5 um of dz", "nm", key="lines.spacing", paper=130, bench=spacing, truth=spacing_t,
                   runs=LINE_RUNS, note="mean gap between neighbouring lines in the final scans"),
        common.Row("C_n: the calibration against the truth's", "nm/V", key="lines.cn", paper=23.1,
                   model=cal["sol"]["cn_nm_per_V"], truth=cn_t, runs=LINE_RUNS,
                   note=f"fw_calib_lines_cn; the beam's estimate is {show(estimate, 'nm/V')}. S_n' = dz / K_n counts the "
                        "trench's own depth as bending: the method's bias, about 1 % here"),
    ]
    figs = [("The four lines in their final scans (mean profile across the cut's middle)", plot_lines(exp_dir, cal)),
            ("Line offset against S_n' with the fitted C_n", plot_fit(exp_dir, cal))]
    if "push_estimate" in dirs and "push_calibrated" in dirs:
        cuts = {n: cut_apex(dirs[n]) for n in ("push_estimate", "push_calibrated")}
        sn = cuts["push_estimate"]["sn"]
        predicted = abs(cal["sol"]["cn_nm_per_V"] - estimate) * sn
        res.rows += [
            common.Row("apex error on a cut, C_n estimated", "nm", key="lines.apex_estimated", bench=cuts["push_estimate"]["bench"],
                       truth=cuts["push_estimate"]["truth"], runs=("push_estimate",),
                       note="bench: the line's x in the fresh scan against the card's apex (FW_STATE) along the cut's "
                            "middle; truth: the simulator's apex against the card's (SIM_TRUTH); 3 nm: the scan's "
                            "2 nm pixels"),
            common.Row("the same, predicted from the lines: |C_n(lines) - estimate| S_n", "nm", key="lines.apex_predicted",
                       bench=predicted, truth=cuts["push_estimate"]["truth"], runs=LINE_RUNS + ("push_estimate",),
                       note=f"C_n as the lines gave it, S_n = {show(sn, 'V')} the card's photodiode while cutting; 2 nm: "
                            "the lines' C_n is good to about 1 %, which is S_n x 0.3 nm/V here, and a scan pixel"),
            common.Row("apex error on a cut, C_n calibrated", "nm", key="lines.apex_calibrated",
                       bench=cuts["push_calibrated"]["bench"], truth=cuts["push_calibrated"]["truth"],
                       runs=("push_calibrated",),
                       note=f"the same cut with include: {INCLUDE} (written by afm_calc calib lines --write)"),
            common.Row("the calibration's gain: estimated less calibrated apex error", "nm", key="lines.calibration_gain",
                       bench=cuts["push_estimate"]["bench"] - cuts["push_calibrated"]["bench"],
                       truth=cuts["push_estimate"]["truth"] - cuts["push_calibrated"]["truth"],
                       runs=("push_estimate", "push_calibrated"),
                       note="both from the scans: the calibrated line lies where the card says the apex was"),
        ]
        figs.append(("The two cuts in their fresh scans against the card's apex (x = 0: where the operator cut)",
                     plot_cuts(exp_dir, cuts)))
    else:
        res.notes.append("the cuts with and without the calibration did not run (the lines' runs failed)")
    frame_rows, frame_fig = frames(dirs, exp_dir, cal, cn_t)
    res.rows += frame_rows
    if frame_fig:
        figs.append(("The lines at each scan angle in frame A: the profile across them, along the axis the lever "
                     "lies on (fig. 8 is the 0 deg run as the paper read it)", frame_fig))
        res.notes.append(FRAME_NOTE)
    res.notes.append(f"lines at x = {listed(cal['x'], 'nm')}; dz = {listed(cal['dz'], 'nm')}; "
                     f"fit residual {show(cal['sol']['residual_nm'], 'nm')}")
    res.figures = figs
    return res


FRAME_NOTE = (
    "Frame convention (physics.md 0 and 3): frames A and C coincide at scan angle 270 deg; at angle a frame A holds "
    "frame C turned by a - 270 about z (eq. 2). The lever's x_C runs from its base to its tip, and a deeper cut swings "
    "the apex forward along +x_C by C_n S_n', so the line shifts along +x_A at 270, +y_A at 0 and -x_A at 90 deg. "
    "The paper (section II-E) says that at scan angle 0 frame A is a half turn from frame C and that fig. 8's lines "
    "shift along -x_A (2.0 um leftmost); with its own 270 deg overlap (section II-B) a rotation by the scan angle makes "
    "0 deg a quarter turn, not a half: the two statements cannot both hold. Fig. 8's picture is the bench's at 90 deg; "
    "at 0 deg the bench's lines run across x_A and shift along +y_A.")


def frames(dirs, exp_dir, cal, cn_t):
    """The lines at the other scan angles (ANGLES): rows of their shift along
    the frame-A axis the lever lies on (signed, per 500 nm of dz), of C_n
    fitted from them, and of their place against the 270 deg lines turned
    by eq. 2; a figure. All from the runs' scans and z piezo."""
    rows, found = [], {270: (DEPTHS_UM, cal["x"], cal["profiles"])}
    angles = sorted({int(n.split("_")[0][1:]) for n in dirs if n.startswith("a") and "_dz_" in n})
    for angle in angles:
        depths = [d for d in DEPTHS_UM if angle_run(angle, d) in dirs]
        names = tuple(angle_run(angle, d) for d in depths)
        rd = [dirs[n] for n in names]
        hits = [line_at(r, angle) for r in rd]
        pos = np.array([h[0] for h in hits])
        dz = np.array([push_depth(r, angle)[0] for r in rd])
        u = lever_to_A(angle) @ np.array([1.0, 0.0])
        ax, sign = ("x", u[0]) if abs(u[0]) > 0.5 else ("y", u[1])
        slope = float(np.polyfit(dz, pos, 1)[0])
        sol = common.calc("calib", "lines", "--depths-nm", ",".join(f"{d:.3f}" for d in dz),
                          "--offsets-nm", ",".join(f"{sign * (p - pos[0]):.3f}" for p in pos),
                          "--deflection-nm-per-V", f"{cal['Kn']:.4f}")
        turned = [sign * cal["x"][DEPTHS_UM.index(d)] for d in depths]   # the 270 deg lines, turned
        rows += [
            common.Row(f"line shift per 500 nm of dz at scan angle {angle}, along +{ax}_A", "nm", key="lines.angle_shift",
                       bench=500 * slope, truth=sign * cn_t * 500 / cal["Kn"], runs=names,
                       note=f"signed: the lever's +x_C lies along {'+' if sign > 0 else '-'}{ax}_A here (eq. 2); "
                            "fitted over the lines' places in their final scans against dz from the z piezo"),
            common.Row(f"scan angle {angle}: C_n from these lines, the calibration against the truth's", "nm/V",
                       key="lines.angle_cn", paper=23.1, model=sol["cn_nm_per_V"], truth=cn_t, runs=names,
                       note="fw_calib_lines_cn on these lines' offsets along +x_C"),
            common.Row(f"lines at scan angle {angle} against the 270 deg lines turned by eq. 2", "nm", key="lines.angle_vs_270",
                       bench=float(np.abs(pos - np.array(turned)).max()), runs=names + LINE_RUNS,
                       note=f"a limit: the largest distance at the same depth, {ax}_A here against "
                            f"{'+' if sign > 0 else '-'}x_A at 270; 3 nm: the scan's 2 nm pixels"),
        ]
        found[angle] = (depths, list(pos), [(h[1], h[2]) for h in hits])
    return rows, (plot_frames(exp_dir, found) if angles else None)


def plot_frames(exp_dir, found):
    p = common.plt()
    fig, axes = p.subplots(1, len(found), figsize=(4.2 * len(found), 3.4), squeeze=False)
    for ax, (angle, (depths, pos, profs)) in zip(axes[0], sorted(found.items())):
        u = lever_to_A(angle) @ np.array([1.0, 0.0])
        axis = "x" if abs(u[0]) > 0.5 else "y"
        for d, x, (c, prof) in zip(depths, pos, profs):
            ax.plot(c, prof, lw=0.8, label=f"dz {d} um")
            ax.axvline(x, lw=0.4, ls=":", color="k")
        ax.set_xlim(min(pos) - 80, max(pos) + 80)
        ax.set_xlabel(f"{axis}_A (nm); the lever's +x_C: {'+' if (u[0] + u[1]) > 0 else '-'}{axis}_A")
        ax.set_title(f"scan angle {angle} deg", fontsize=9)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("height (nm)")
    return common.save(fig, exp_dir, "lines_frames.png")


def cut_apex(run_dir):
    """A cut with compensation on: the line's x in the fresh scan, the card's
    apex x (FW_STATE, median over the cut's middle) and the simulator's
    (SIM_TRUTH, the same blocks). bench: |line - card|; truth: |simulator -
    card|; sn: the card's median S_n (V) there."""
    from analysis import afmlog
    x_line, xs, prof = line_x(run_dir, min_depth_nm=0.2)   # a light cut: a flat substrate shows 0.2 nm clearly
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE", "SIM_TRUTH"})
    tip, truth = (afmlog.by_seq(log.get(c, [])) for c in ("FW_STATE", "SIM_TRUTH"))
    seqs = [s for s in sorted(tip) if s in truth and tip[s].force_nN[2] > 10.0 and abs(tip[s].tip_nm[1]) < CUT_HALF_NM]
    if len(seqs) < 20:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: {len(seqs)} blocks in the cut's middle (FW_STATE, SIM_TRUTH)")
    x_card = float(np.median([tip[s].tip_nm[0] for s in seqs]))
    x_true = float(np.median([truth[s].tip_nm[0] for s in seqs]))
    a, _ = common.analog(run_dir)
    on = (np.abs(a["y_nm"]) < CUT_HALF_NM) & (a["sn_v"] > 1.0)
    return {"bench": abs(x_line - x_card), "truth": abs(x_true - x_card), "line": x_line, "card": x_card,
            "sn": float(np.median(a["sn_v"][on])), "profile": (xs, prof)}


def plot_lines(exp_dir, cal):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 3.8))
    for d, x, (xs, prof) in zip(DEPTHS_UM, cal["x"], cal["profiles"]):
        ax.plot(xs, prof, lw=0.8, label=f"dz {d} um")
        ax.axvline(x, lw=0.4, ls=":", color="k")
    ax.set_xlabel("x (nm, frame A: along the lever)")
    ax.set_ylabel("height (nm)")
    ax.set_xlim(min(cal["x"]) - 60, max(cal["x"]) + 60)
    ax.legend(fontsize=8)
    ax.set_title("Lines cut along the same piezo path (fig. 8)")
    return common.save(fig, exp_dir, "lines.png")


def plot_fit(exp_dir, cal):
    p = common.plt()
    fig, ax = p.subplots(figsize=(5.4, 3.8))
    snp = np.array(cal["dz"]) / cal["Kn"]
    ax.plot(snp - snp[0], cal["offsets"], "o")
    s = np.linspace(0, (snp - snp[0]).max(), 5)
    ax.plot(s, cal["sol"]["cn_nm_per_V"] * s, "-", lw=0.8, label=f"C_n = {cal['sol']['cn_nm_per_V']:.2f} nm/V")
    ax.set_xlabel("S_n' - S_n'(first) (V)")
    ax.set_ylabel("line offset (nm)")
    ax.legend(fontsize=8)
    return common.save(fig, exp_dir, "cn_fit.png")


def plot_cuts(exp_dir, cuts):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 3.6))
    for i, (n, c) in enumerate(cuts.items()):
        xs, prof = c["profile"]
        label = n.replace("push_", "C_n ")
        ax.plot(xs, prof, lw=0.9, color=f"C{i}", label=f"{label}: line at {c['line']:.1f} nm")
        ax.axvline(c["card"], lw=0.8, ls="--", color=f"C{i}", label=f"{label}: card's apex {c['card']:.1f} nm")
    ax.set_xlim(min(c["card"] for c in cuts.values()) - 30, max(c["line"] for c in cuts.values()) + 30)
    ax.set_xlabel("x (nm, frame A: along the lever)")
    ax.set_ylabel("height (nm), mean across the cut's middle")
    ax.legend(fontsize=7)
    return common.save(fig, exp_dir, "apex_error.png")
