"""A rod 1.3 um x 100 nm pushed once across its axis at nine points along
it. The static point is the point of the rod that did not move between the
run's initial and final scans (the rod's axis and centre fitted to the
pixels above half its height, in each scan; the point of least
displacement between the two poses), measured from end A of the rod as the
first scan shows it; the push that moved it is the card's force (FW_STATE)
across the rod while it flags contact, less the tip's own sliding friction
(measured in the same run before contact). Both against the closed form
(physics.md section 6, as corrected: s = l +- sqrt((l - L/2)^2 + L^2/4),
F_min = f |L - 2 s|), the firmware's fw_wire (afm_calc model wire) and the
simulator's truth (SIM_TRUTH: poses and force). The simulator moves the rod
by its own numeric solver (sample.wire.solver: numeric: the friction lumped
on 64 points and the least-dissipation balance iterated), not by eq. 20, so
the card's closed-form model is judged against a truth that is not itself."""
import math
import os

import numpy as np

from analysis.units import show
from analysis.paper import common

NAME = "rod"
TITLE = "Static point and minimum push along a rod"
FIGURES = "figs. 13-14"

POINTS = {"full": [0.03, 0.1, 0.2, 0.3, 0.4, 0.45, 0.55, 0.7, 0.9], "reduced": [0.03, 0.3, 0.45, 0.7]}


def runs(size):
    out = []
    for q in POINTS[size]:
        sc = common.load_scene("rod.yaml")
        w = sc["objects"]["wires"][0]
        x = w["x0_nm"] + q * (w["x1_nm"] - w["x0_nm"])
        path = [[x, p[1]] for p in sc["operator"]["path_nm"]]
        out.append(common.Run(name=f"l_{q:.2f}L", scene="rod.yaml", settings={"operator.path_nm": path}, cost_s=4))
    return out


def closed_form(l, L):
    """physics.md section 6: the static point s from end A and F_min / (f L)."""
    if abs(l - L / 2) < 1e-9:
        return None, 1.0
    r = math.sqrt((l - L / 2) ** 2 + L * L / 4)
    s = l + r if l < L / 2 else l - r
    return s, abs(L - 2 * s) / L


def rod_pose(run_dir, scan_name):
    """The rod in a scan: centre, unit axis (pointing +x) and length (nm),
    from the pixels above half its height."""
    h, xs, ys = common.scan(run_dir, scan_name)
    X, Y = np.meshgrid(xs, ys)
    on = h > 0.5 * h.max()
    if on.sum() < 20:
        raise common.PaperError(f"{run_dir}/{scan_name}.gsf: no rod found (fewer than 20 pixels above half height)")
    P = np.column_stack([X[on], Y[on]])
    c = P.mean(axis=0)
    _, _, vt = np.linalg.svd(P - c, full_matrices=False)
    e = vt[0] if vt[0][0] > 0 else -vt[0]
    u = (P - c) @ e
    return c, e, float(u.max() - u.min())


def static_offset(c0, e0, c1, e1):
    """The point of the rod (distance from its centre along it) that moved
    least between two poses."""
    dc, de = c1 - c0, e1 - e0
    return float(-(dc @ de) / (de @ de))


def truth_poses(run_dir):
    """The rod's first and last poses in the simulator (SIM_TRUTH): two
    (centre, unit axis) pairs, nm."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"SIM_TRUTH"})
    whole = afmlog.whole_objects(log.get("SIM_TRUTH", []), objects=lambda m: m.objects)
    if not whole:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: no SIM_TRUTH objects")
    poses = []
    for _, w in (whole[0], whole[-1]):
        a = np.array([w.wires[0].x_nm[0], w.wires[0].y_nm[0]])
        b = np.array([w.wires[0].x_nm[-1], w.wires[0].y_nm[-1]])
        poses.append(((a + b) / 2, (b - a) / np.linalg.norm(b - a)))
    return poses


def truth_offset(run_dir):
    """The static offset from the simulator's poses (SIM_TRUTH), first and last."""
    (c0, e0), (c1, e1) = truth_poses(run_dir)
    return static_offset(c0, e0, c1, e1)


def analyse(dirs, exp_dir, size):
    sc = common.truth(next(iter(dirs.values())))
    w = sc["objects"]["wires"][0]
    L = float(w["x1_nm"] - w["x0_nm"])
    # f: the card's configured friction per length (run.json card), which a
    # scene gives directly or through eq. 23-24 (mu_os F_a,os + tau_os A)
    f = float(common.run_json(next(iter(dirs.values())))["card"]["wire_friction_pn_per_um"]) * 1e-6   # nN/nm
    pts = []
    for q in POINTS[size]:
        d = dirs[f"l_{q:.2f}L"]
        c0, e0, len0 = rod_pose(d, "scan_initial")
        c1, e1, _ = rod_pose(d, "scan_final")
        l = q * L
        s_cf, k_cf = closed_form(l, L)
        fw = common.calc("model", "wire", "--length-nm", f"{L:.1f}", "--diameter-nm", f"{w['diameter_nm']}",
                         "--push-at-nm", f"{l:.1f}", "--f-nN-per-um", f"{f * 1e3:.4f}")
        fb, ft, _ = common.push_excess(d)
        if fb is None:
            raise common.PaperError(f"{d}: the card never flagged contact with the rod")
        # the static point from the rod's centre: the scans locate the centre
        # and the axis, and need no length (the scanned one is the tip's
        # dilation longer; the scene's is not the bench's to take)
        centre = lambda s: None if s is None else s - L / 2
        pts.append(dict(q=q, l=l, s_scan=static_offset(c0, e0, c1, e1), s_truth=truth_offset(d), s_cf=centre(s_cf),
                        s_fw=centre(fw.get("static_point_nm")), F_card=fb, F_truth=ft, F_cf=k_cf * f * L,
                        F_fw=fw["min_force_nN"], L_scan=len0))
    res = common.Result()
    end, mid = pts[0], min(pts, key=lambda p: abs(p["q"] - 0.45))
    rms = lambda k, ref: float(np.sqrt(np.mean([(p[k] - p[ref]) ** 2 for p in pts])))
    run = lambda p: (f"l_{p['q']:.2f}L",)
    res.rows = [
        common.Row(f"static point at an end push (l = {end['q']:.2f} L), from the rod's centre", "nm",
                   key="rod.end_static_point", paper=L / math.sqrt(2) - L / 2, bench=end["s_scan"], truth=end["s_truth"],
                   runs=run(end), note="paper: L/sqrt2 from end A at the very end; the rod as scanned is "
                                       f"{show(end['L_scan'], 'nm')} long (the tip's dilation), so the centre is the reference"),
        common.Row(f"push that moves the rod at l = {end['q']:.2f} L", "nN", key="rod.end_push", paper=0.586 * f * L,
                   bench=end["F_card"], truth=end["F_truth"], runs=run(end),
                   note="the paper's (2 - sqrt2) f L is wrong: torque balance gives (sqrt2 - 1) f L at the end (physics.md 6)"),
        common.Row(f"push that moves the rod at l = {mid['q']:.2f} L", "nN", key="rod.mid_push", paper=f * L,
                   bench=mid["F_card"], truth=mid["F_truth"], runs=run(mid), note="paper: f L at the middle"),
        common.Row(f"static point, scans against the closed form (RMS over {len(pts)})", "nm", key="rod.static_scan_rms",
                   bench=rms("s_scan", "s_cf"), note="the closed form of physics.md 6 (its middle expression for F_min "
                                                     "has a sign slip; f |L - 2 s| is right)"),
        common.Row(f"push, card against the closed form (RMS over {len(pts)})", "nN", key="rod.push_card_rms",
                   bench=rms("F_card", "F_cf"), scale=f * L,
                   note="the simulator's rod carries its friction at 64 points and is pushed on its flank, not its axis"),
        common.Row("firmware fw_wire against the closed form: static point (RMS)", "nm", key="rod.fw_static_rms",
                   bench=rms("s_fw", "s_cf"), note="afm_calc model wire (fixed point) at the same push points: eq. 20 "
                                                   "against eq. 20"),
        common.Row("firmware fw_wire against the closed form: F_min (RMS)", "nN", key="rod.fw_push_rms",
                   bench=rms("F_fw", "F_cf")),
    ]
    for p in pts:
        res.rows += [
            common.Row(f"static point at l = {p['q']:.2f} L, from the rod's centre: the card's fw_wire against the "
                       "numeric rod", "nm", key="rod.model_static_point", model=p["s_fw"], truth=p["s_truth"], scale=L,
                       runs=run(p), note="model: afm_calc model wire (eq. 20); truth: the simulator's first and last "
                                         "poses (SIM_TRUTH), its rod moved by the friction lumped on 64 points and the "
                                         "balance iterated (sample.wire.solver: numeric)"),
            common.Row(f"least push at l = {p['q']:.2f} L: the card's fw_wire against the numeric rod", "nN",
                       key="rod.model_least_push", model=p["F_fw"], truth=p["F_truth"], scale=f * L, runs=run(p),
                       note="truth: the simulator's force (SIM_TRUTH) across the push less the tip's own sliding "
                            "friction before contact"),
        ]
    res.notes.append("per push: " + "; ".join(
        f"at l = {show(p['q'])} L the static point {show(p['s_scan'], 'nm')} in the scans, {show(p['s_truth'], 'nm')} by "
        f"the simulator, {show(p['s_cf'], 'nm')} by the closed form; the push {show(p['F_card'], 'nN')} by the card, "
        f"{show(p['F_cf'], 'nN')} by the closed form" for p in pts))
    res.figures = [("Static point against push point: scans, simulator, closed form, firmware (fig. 13)",
                    plot(exp_dir, pts, L, "s", "static point s from end A (nm)", "static_point.png")),
                   ("Push that moves the rod against push point: card, simulator, closed form, firmware (fig. 14)",
                    plot(exp_dir, pts, L, "F", "push (nN)", "min_push.png", f * L))]
    return res


def plot(exp_dir, pts, L, key, ylabel, fname, fL=None):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 4.0))
    ls = np.linspace(0, L, 401)
    cf = [closed_form(l, L) for l in ls]
    if key == "s":   # drawn from end A: every series moved by the same L/2
        a = lambda v: np.nan if v is None else v + L / 2
        ax.plot(ls, [c[0] if c[0] is not None else np.nan for c in cf], "-", lw=0.8, label="closed form")
        ax.plot([q["l"] for q in pts], [a(q["s_scan"]) for q in pts], "o", label="bench (scans)")
        ax.plot([q["l"] for q in pts], [a(q["s_truth"]) for q in pts], "x", label="simulator (truth)")
        ax.plot([q["l"] for q in pts], [a(q["s_fw"]) for q in pts], "+", ms=9, label="firmware fw_wire")
    else:
        ax.plot(ls, [c[1] * fL for c in cf], "-", lw=0.8, label="closed form f |L - 2s|")
        ax.plot([q["l"] for q in pts], [q["F_card"] for q in pts], "o", label="bench (card's force)")
        ax.plot([q["l"] for q in pts], [q["F_truth"] for q in pts], "x", label="simulator (truth)")
        ax.plot([q["l"] for q in pts], [q["F_fw"] for q in pts], "+", ms=9, label="firmware fw_wire")
        ax.axhline(0.586 * fL, ls=":", lw=0.6, color="grey", label="paper's end value (2-sqrt2) f L (wrong)")
    ax.set_xlabel("push point l from end A (nm)")
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=7)
    return common.save(fig, exp_dir, fname)
