"""A silver rod (1.3 um x 100 nm) pushed by a zigzag of end pushes into a
2.8 um trench the tip cut first (fig. 18). The planner cuts the trench
(operator.plan.cuts), then pushes the rod in closed loop on the card's
model, which knows the trench the card recorded (fw_wire_hold). From the
run's own data: the trench's width and path and the rod's thickness and
axis from the final fresh scan, the pushes and the time from the
operator's report, the card's rod against the simulator's at the end
(FW_STATE, SIM_TRUTH), the display against the fresh scan. The truth
column is the simulator's trench and rod (SIM_TRUTH). The simulator holds
a rod whose axis lies within (width - d) / 2 of the trench's path, at the
V's edge: it goes no deeper, so "in the trench" is that; one size (the
run takes about 8 simulated s)."""
import json
import os

import numpy as np

from analysis.units import show
from analysis.paper import common

NAME = "trench"
TITLE = "A rod pushed into a trench"
FIGURES = "fig. 18"

ROD_X = 700          # nm: the rod spans |x| < 650 (and moves a little along x); the trench alone beyond
EDGE_BELOW_NM = 2.0  # the trench's edge: where the profile falls this far below the substrate


def runs(size):
    return [common.Run(name="zigzag", scene="trench.yaml", timeout_s=600, cost_s=12)]


def _edges(y, prof, level):
    """The two crossings of level - EDGE_BELOW_NM around the profile's lowest
    point (linear interpolation), nm."""
    cut = level - EDGE_BELOW_NM
    i = int(np.argmin(prof))
    lo, hi = i, i
    while lo > 0 and prof[lo] < cut:
        lo -= 1
    while hi < len(prof) - 1 and prof[hi] < cut:
        hi += 1
    if prof[lo] < cut or prof[hi] < cut:
        raise common.PaperError("the trench reaches the scan's edge")
    y0 = y[lo] + (cut - prof[lo]) * (y[lo + 1] - y[lo]) / (prof[lo + 1] - prof[lo])
    y1 = y[hi - 1] + (cut - prof[hi - 1]) * (y[hi] - y[hi - 1]) / (prof[hi] - prof[hi - 1])
    return y0, y1


def from_scan(run_dir):
    """The trench's width and path (y, nm) beyond the rod's ends, the rod's
    thickness and axis (y of its ridge) over its middle, from the final
    fresh scan (the trench runs along x)."""
    h, xs, ys = common.scan(run_dir, "scan_final")
    order = np.argsort(ys)
    h, ys = h[order, :], ys[order]
    away = np.abs(xs) > ROD_X + 100
    trench_cols = away & (np.abs(xs) < 1300)
    if not trench_cols.any():
        raise common.PaperError(f"{run_dir}/scan_final.gsf: no columns beyond the rod")
    prof = np.median(h[:, trench_cols], axis=1)
    level = float(np.median(prof))
    y0, y1 = _edges(ys, prof, level)
    # The rod over its middle: the highest point of each column between the
    # trench's edges (a rod sunk into the groove shows there as its top,
    # below the substrate; one left on a rim, above it).
    rod_cols = np.abs(xs) < 400
    inside = (ys > y0) & (ys < y1)
    ridge = []
    for c in np.where(rod_cols)[0]:
        col = np.where(inside, h[:, c], -np.inf)
        peaks = [j for j in range(1, len(col) - 1) if np.isfinite(col[j]) and col[j] >= col[j - 1] and col[j] >= col[j + 1]
                 and np.isfinite(col[j - 1]) and np.isfinite(col[j + 1])]
        if not peaks:
            continue
        k = max(peaks, key=lambda j: col[j])   # a local top between the groove's edges
        if 0 < k < len(col) - 1 and np.isfinite(col[k - 1]) and np.isfinite(col[k + 1]):   # sub-pixel: the parabola through the top three
            a, b, cc = col[k - 1], col[k], col[k + 1]
            den = a - 2 * b + cc
            ridge.append((ys[k] + (0.5 * (a - cc) / den if den != 0 else 0) * (ys[1] - ys[0]), b - level))
    if not ridge:
        raise common.PaperError(f"{run_dir}/scan_final.gsf: no rod over its middle")
    ridge = np.array(ridge)
    return {"width": y1 - y0, "path_y": 0.5 * (y0 + y1), "rod_y": float(np.median(ridge[:, 0])),
            "rod_top": float(np.median(ridge[:, 1])), "profile": (ys, prof, level),
            "rod_profile": np.median(h[:, rod_cols], axis=1) - level}


def from_truth(run_dir, w):
    """The simulator's trench (median width, path y) and rod (ends) in its
    objects w (SIM_TRUTH) at the end."""
    if not w.trenches or not w.wires:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: no trench or rod in SIM_TRUTH")
    t = max(w.trenches, key=lambda t: t.n)
    r = w.wires[0]
    ends = np.array([[r.x_nm[0], r.y_nm[0]], [r.x_nm[-1], r.y_nm[-1]]])
    return {"width": float(np.median(t.width_nm)), "path_y": float(np.median(t.y_nm)), "ends": ends,
            "rod_y": float(ends[:, 1].mean()), "rod_d": float(r.diameter_nm),
            "angle": float(np.degrees(np.arctan2(*(ends[1] - ends[0])[::-1])))}


def rod_tracks(states):
    """Time (s), the card's rod ends and the simulator's, per block of
    common.model_states: (t, fw [n, 2, 2], truth [n, 2, 2])."""
    def ends(o):
        w = o.wires[0]
        return [[w.x_nm[0], w.y_nm[0]], [w.x_nm[-1], w.y_nm[-1]]]
    t = np.array([f.utime * 1e-6 for _, f, _ in states])
    return t, np.array([ends(f) for _, f, _ in states]), np.array([ends(tr) for _, _, tr in states])


def analyse(dirs, exp_dir, size):
    d = dirs["zigzag"]
    with open(os.path.join(d, "fidelity.json")) as f:
        fid = json.load(f)
    with open(os.path.join(d, "operator_report.json")) as f:
        plan = json.load(f)["plan"]
    states = common.model_states(d)   # the log read once: the card's objects and the simulator's per block
    sc, tr = from_scan(d), from_truth(d, states[-1][2])
    t, fw, truth = rod_tracks(states)
    model_err = float(np.max(np.hypot(*(fw[-1] - truth[-1]).T)))
    err = np.hypot(*(fw - truth).transpose(2, 0, 1)).max(axis=1)   # per block, the larger end distance
    # The settle into the groove is a jump within one sample: the card and
    # the simulator may take it one block apart, so each block is also held
    # against the simulator's neighbouring blocks.
    near = np.minimum(err, np.minimum(np.r_[np.hypot(*(fw[:-1] - truth[1:]).transpose(2, 0, 1)).max(axis=1), np.inf],
                                      np.r_[np.inf, np.hypot(*(fw[1:] - truth[:-1]).transpose(2, 0, 1)).max(axis=1)]))
    worst, apart = float(np.max(near)), int(np.sum(err > 40.0))
    card_top = states[-1][1].wires[0].axis_z_nm + states[-1][1].wires[0].diameter_nm / 2
    item = plan["items"][0]
    target_deg = float(item.get("target_angle_deg", 0.0))
    rods = fid.get("assembly", {}).get("rods", [{}])
    off_b, off_t = abs(sc["rod_y"] - sc["path_y"]), abs(tr["rod_y"] - tr["path_y"])
    axis_z = common.run_json(d)["sim"]["wire_axis_heights_nm"][0]   # the simulator's seat of the rod (truth)
    res = common.Result()
    res.rows = [
        common.Row("trench width at the surface", "nm", key="trench.width", bench=sc["width"], truth=tr["width"],
                   note=f"the scan's profile beyond the rod, {show(EDGE_BELOW_NM, 'nm')} below the substrate; truth: 2 depth tan gamma"),
        common.Row("the rod's top against the substrate (fig. 18f: below it, in its fixture)", "nm", key="trench.rod_top",
                   bench=sc["rod_top"], truth=axis_z + tr["rod_d"] / 2,
                   note="the fresh scan's highest point across the groove over the rod's middle; truth: the simulator's "
                        "seat, the rod on both walls of the V (axis at -D + R / sin gamma)"),
        common.Row("the rod lies below the substrate (1 yes, 0 no)", "", key="trench.rod_below",
                   bench=float(sc["rod_top"] < -EDGE_BELOW_NM), truth=float(axis_z + tr["rod_d"] / 2 < 0),
                   note="its top in the fresh scan below the substrate's level; truth: the simulator's seat"),
        common.Row("rod's axis from the trench's path", "nm", key="trench.axis_offset", bench=off_b, truth=off_t,
                   note="the scan's top over the rod's middle against the trench's centre beyond it: a rod in a V settles "
                        "on its centreline"),
        common.Row("rod's angle to its target (the trench's)", "deg", key="trench.angle", bench=rods[0].get("angle_error_deg"),
                   truth=(tr["angle"] - target_deg + 90.0) % 180.0 - 90.0,
                   note="bench: the renderer's assembly check on the fresh scan; truth: the simulator's rod"),
        common.Row("end pushes", "", key="trench.pushes", bench=item.get("pushes"), note=f"the planner's zigzag; {item.get('note') or item.get('why') or 'ended on its target'}"),
        common.Row("simulated time: cut, then pushed in", "s", key="trench.time", bench=plan["finished_sim_s"],
                   note=f"the cut ended at {show(plan['cuts_done_sim_s'], 's')}; wall {show(common.run_json(d)['wall_seconds'], 's')}"),
        common.Row("the card's rod against the simulator's, at the end", "nm", key="trench.model_end", bench=model_err,
                   note="largest end distance (FW_STATE, SIM_TRUTH): the card's model knows the trench (fw_wire_hold)"),
        common.Row("the same, worst over the run (within a block)", "nm", key="trench.model_worst", bench=worst,
                   note="each block against the simulator's same or neighbouring block: a lag while an end a trench "
                        "holds is pushed (the card moves a held rod only past its whole threshold, fw_wire.h)"),
        common.Row("blocks where they differ by more than 40 nm", "", key="trench.blocks_apart", bench=apart,
                   note="the settle into the groove is a jump: the card (fw_wire_settle) and the simulator "
                        "(World::settle_rods) may take it a block apart"),
        common.Row("the card's rod top against the fresh scan's", "nm", key="trench.card_top_scan", bench=card_top - sc["rod_top"],
                   note=f"the card's seated model (FW_STATE axis_z_nm + d/2: {show(card_top, 'nm')}) and the scan's "
                        f"{show(sc['rod_top'], 'nm')}"),
        common.Row("display against a fresh scan: worst object", "nm", key="trench.display", bench=fid["max_position_error_nm"],
                   scale=fid["target_nm"],
                   note=f"the renderer's check at the last frame (its target {show(fid['target_nm'], 'nm')})"),
        common.Row("the rod's seat (axis height): the card's model against the truth's", "nm", key="trench.model_seat",
                   model=states[-1][1].wires[0].axis_z_nm, truth=axis_z,
                   note="model: the card's seated rod (fw_wire_settle, FW_STATE axis_z_nm); truth: the simulator's "
                        "(sim_report wire_axis_heights_nm); both the rod on the V's walls, -D + R / sin gamma"),
    ]
    res.notes.append(f"assembly by the renderer's scan: {'placed' if rods[0].get('placed') else 'NOT placed'} "
                     f"within {show(rods[0].get('tolerance_nm'), 'nm')} of the trench's path")
    res.figures = [("The final fresh scan: the trench and the rod in it, with the rod's ends over time", plot(exp_dir, d, t, fw, truth)),
                   ("The fresh scan across the trench: beyond the rod, and over its middle (the rod seated below the surface)", plot_profile(exp_dir, sc))]
    return res


def plot(exp_dir, run_dir, t, fw, truth):
    p = common.plt()
    h, xs, ys = common.scan(run_dir, "scan_final")
    fig, (ax, bx) = p.subplots(1, 2, figsize=(11.0, 5.0))
    ax.imshow(h, extent=[xs[0], xs[-1], ys[-1], ys[0]], cmap="afmhot", origin="upper")
    ax.plot(truth[-1, :, 0], truth[-1, :, 1], "c-", lw=1, label="rod, simulator (end)")
    ax.plot(fw[-1, :, 0], fw[-1, :, 1], "b--", lw=1, label="rod, card's model (end)")
    ax.set_xlabel("x (nm)")
    ax.set_ylabel("y (nm)")
    ax.legend(fontsize=7, loc="lower right")
    for e, name in ((0, "A"), (1, "B")):
        bx.plot(t, truth[:, e, 1], lw=1, label=f"end {name}, simulator")
        bx.plot(t, fw[:, e, 1], "--", lw=1, label=f"end {name}, card")
    bx.set_xlabel("simulated time (s)")
    bx.set_ylabel("y of the rod's end (nm)")
    bx.legend(fontsize=7)
    return common.save(fig, exp_dir, "trench.png")


def plot_profile(exp_dir, sc):
    p = common.plt()
    ys, prof, level = sc["profile"]
    fig, ax = p.subplots(figsize=(6.0, 3.5))
    ax.plot(ys, prof - level, lw=1, label="beyond the rod: the groove")
    ax.plot(ys, sc["rod_profile"], lw=1.2, label="over the rod's middle: the rod in the groove")
    ax.axhline(sc["rod_top"], color="C1", lw=0.6, ls=":")
    ax.axvline(sc["path_y"] - sc["width"] / 2, color="gray", lw=0.6)
    ax.axvline(sc["path_y"] + sc["width"] / 2, color="gray", lw=0.6)
    ax.set_xlim(sc["path_y"] - 1.5 * sc["width"], sc["path_y"] + 1.5 * sc["width"])
    ax.set_xlabel("y (nm)")
    ax.set_ylabel("height (nm)")
    ax.legend(fontsize=8, loc="lower left")
    return common.save(fig, exp_dir, "trench_profile.png")
