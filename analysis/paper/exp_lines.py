"""Lines inscribed on polycarbonate along the same piezo path at four push
depths, without compensation; S_n saturates, so the virtual S_n' = dz / K_n
stands in (dz read from the run's z piezo against the surface in its
initial scan); each line is found in its run's final scan (the
depth-weighted centre of its groove); the firmware's fw_calib_lines_cn
(afm_calc calib lines) fits C_n. The simulated lever's true C_n differs from
the beam's estimate. Then afm_calc calib lines --write makes the include
file a scene takes, and a push with the estimate and one with the
calibrated value show the apex error (the card's FW_STATE against SIM_TRUTH)."""
import os

import numpy as np

from analysis.paper import common

NAME = "lines"
TITLE = "C_n from inscribed lines"
FIGURES = "fig. 8"

DEPTHS_UM = [0.5, 1.0, 1.5, 2.0]      # the paper's dz
CUT_HALF_NM = 200                     # the middle of the 600 nm line
INCLUDE = "calibrated_lever.yaml"


def runs(size):
    kn = common.paper_probe()["spring_N_per_m"]   # the scene's lever: the paper's k_n
    return [common.Run(name=f"dz_{d:.1f}um", scene="lines.yaml", settings={"operator.load_nN": round(kn * d * 1000, 3)}, cost_s=4)
            for d in DEPTHS_UM]


def more_runs(size, dirs, exp_dir):
    cal = calibrate(dirs, exp_dir)
    return [common.Run(name="push_estimate", scene="lines_push.yaml", cost_s=3),
            common.Run(name="push_calibrated", scene="lines_push.yaml", settings={"include": cal["include"]}, cost_s=3)]


def line_x(run_dir):
    """The line's x (nm, frame A) in the run's final scan: the depth-weighted
    centre of the groove in the mean profile across the cut's middle."""
    h, xs, ys = common.scan(run_dir, "scan_final")
    prof = h[np.abs(ys) < CUT_HALF_NM].mean(axis=0)
    i = int(prof.argmin())
    if prof[i] > -0.5:
        raise common.PaperError(f"{run_dir}/scan_final.gsf: no groove deeper than 0.5 nm")
    near = (np.abs(xs - xs[i]) < 40) & (prof < 0)
    w = -prof[near]
    return float((xs[near] * w).sum() / w.sum()), xs, prof


def push_depth(run_dir):
    """dz (nm): the surface (initial scan, mean) above the z piezo, mid-cut."""
    a, fs = common.analog(run_dir)
    h0, _, _ = common.scan(run_dir, "scan_initial")
    v = np.gradient(a["y_nm"]) * fs
    mid = (np.abs(a["y_nm"]) < CUT_HALF_NM) & (v > 1000)
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
        common.Row("line spacing per 0.5 um of dz", "nm", paper=130, bench=spacing, truth=spacing_t, tolerance=0.03,
                   relative=True, note="mean gap between neighbouring lines in the final scans"),
        common.Row("C_n", "nm/V", paper=23.1, bench=cal["sol"]["cn_nm_per_V"], truth=cn_t, tolerance=0.01, relative=True,
                   note=f"fw_calib_lines_cn; the beam's estimate is {estimate:.1f} nm/V. S_n' = dz / K_n counts the "
                        "trench's own depth as bending: the method's bias, about 1 % here"),
    ]
    figs = [("The four lines in their final scans (mean profile across the cut's middle)", plot_lines(exp_dir, cal)),
            ("Line offset against S_n' with the fitted C_n", plot_fit(exp_dir, cal))]
    if "push_estimate" in dirs and "push_calibrated" in dirs:
        errs = {}
        for n in ("push_estimate", "push_calibrated"):
            e, t = common.apex_error(dirs[n], min_load_nN=10.0)
            errs[n] = (e, t)
        rms = {n: float(np.sqrt((e ** 2).sum(axis=1).mean())) for n, (e, _) in errs.items()}
        sn = push_depth_sn(dirs["push_estimate"])
        res.rows += [
            common.Row("apex error on a push, C_n estimated", "nm", bench=rms["push_estimate"],
                       truth=abs(cn_t - estimate) * sn, tolerance=0.15, relative=True,
                       note=f"RMS of FW_STATE - SIM_TRUTH while pushing at 30 nN; truth: |C_n - estimate| S_n (an RMS is a size), S_n = {sn:.2f} V"),
            common.Row("apex error on a push, C_n calibrated", "nm", bench=rms["push_calibrated"], tolerance=2.0,
                       note=f"the same push with include: {INCLUDE} (written by afm_calc calib lines --write); "
                            "held below the tolerance"),
        ]
        figs.append(("Apex error during the push (card against simulator), estimate and calibrated",
                     plot_push(exp_dir, errs)))
    else:
        res.notes.append("the pushes with and without the calibration did not run (the lines' runs failed)")
    res.notes.append("lines at x = " + ", ".join(f"{x:.1f}" for x in cal["x"]) + " nm; dz = " +
                     ", ".join(f"{d:.1f}" for d in cal["dz"]) + f" nm; fit residual {cal['sol']['residual_nm']:.2f} nm")
    res.figures = figs
    return res


def push_depth_sn(run_dir):
    """The mean S_n (V) while the tip is loaded (the push)."""
    a, _ = common.analog(run_dir)
    on = a["sn_v"] > 1.0
    return float(np.median(a["sn_v"][on]))


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


def plot_push(exp_dir, errs):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 3.6))
    for n, (e, t) in errs.items():
        ax.plot(t, np.hypot(e[:, 0], e[:, 1]), ".", ms=2, label=n.replace("push_", "C_n "))
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("|apex error| (nm)")
    ax.legend(fontsize=8)
    return common.save(fig, exp_dir, "apex_error.png")
