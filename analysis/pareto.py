"""Pareto fronts of a sweep: for an error figure and a cost figure, the
points no other point beats on both (lower is better for each), and their
plots (matplotlib: PNG and SVG)."""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# Figures of a point: error figures, then cost figures; (key, label, unit).
ERRORS = [
    ("force_rms_pN", "tip force, RMS error", "pN"),
    ("force_worst_pN", "tip force, worst error", "pN"),
    ("apex_rms_nm", "apex, RMS error", "nm"),
    ("apex_worst_nm", "apex, worst error", "nm"),
    ("objects_worst_nm", "objects, worst error", "nm"),
    ("objects_final_nm", "objects, final error", "nm"),
    ("display_max_nm", "display vs fresh scan, worst object", "nm"),
]
COSTS = [
    ("wall_s_per_sim_s", "wall time per simulated second", "s/s"),
    ("cpu_s_per_sim_s", "CPU time per simulated second (all processes)", "s/s"),
    ("fw_instr_per_sample", "firmware instructions per sample", "instr"),
    ("fw_text_bytes", "firmware flash (Cortex-M4 text)", "bytes"),
    ("renderer_ms_per_frame", "renderer time per frame", "ms"),
    ("log_bytes", "bus log size", "bytes"),
]

# Costs read from the clock (wall and CPU time): on a shared machine one run
# of each of two points says nothing of a knob's effect on them (a 1.35 CPU
# ratio was noise); a knob's effect on them is judged only over repeats,
# with its spread (effect_on_timed).
TIMED = ("wall_s_per_sim_s", "cpu_s_per_sim_s", "renderer_ms_per_frame")


def effect_on_timed(pairs, key):
    """(median ratio, [lowest, highest] ratio) of a clock-read cost over
    pairs (a, b) of points that differ in one knob, each ratio's range from
    the extremes of their repeats; (None, None) when a point of a pair was
    run once (it cannot be judged)."""
    ratios, lows, highs = [], [], []
    for a, b in pairs:
        va, vb = repeat_values(a, "costs", key), repeat_values(b, "costs", key)
        if len(va) < 2 or len(vb) < 2 or min(va) <= 0:
            return None, None
        ratios.append(b["costs"][key] / a["costs"][key])
        lows.append(min(vb) / max(va))
        highs.append(max(vb) / min(va))
    if not ratios:
        return None, None
    ratios.sort()
    n = len(ratios)
    mid = ratios[n // 2] if n % 2 else 0.5 * (ratios[n // 2 - 1] + ratios[n // 2])
    return mid, [min(lows), max(highs)]


def front(points, ek, ck):
    """The non-dominated points for error ek and cost ck (both defined),
    sorted by cost."""
    pts = [p for p in points if p["errors"].get(ek) is not None and p["costs"].get(ck) is not None]
    out = []
    for p in pts:
        e, c = p["errors"][ek], p["costs"][ck]
        dominated = any(q is not p and q["errors"][ek] <= e and q["costs"][ck] <= c and
                        (q["errors"][ek] < e or q["costs"][ck] < c) for q in pts)
        if not dominated:
            out.append(p)
    return sorted(out, key=lambda p: p["costs"][ck])


# A figure varies over a sweep when its spread over the points (largest less
# smallest) exceeds both twice its repeat noise (the largest spread of one
# point's repeats) and this fraction of its median: 539 against 543 pN is
# not a result.
MIN_RELATIVE_SPREAD = 0.05


def repeat_values(p, group, key):
    """The figure's value in each of the point's runs (one with no repeats)."""
    runs = p.get("runs") or []
    vals = [r.get(group, {}).get(key) for r in runs]
    vals = [v for v in vals if v is not None]
    return vals or ([p[group][key]] if p[group].get(key) is not None else [])


def noise(points, group, key):
    """The figure's repeat noise: the largest spread among one point's runs (0 without repeats)."""
    return max((max(v) - min(v) for v in (repeat_values(p, group, key) for p in points) if len(v) > 1), default=0.0)


def varies(points, group, key):
    """True when the figure's spread over the points is beyond its noise (above)."""
    vals = sorted(p[group][key] for p in points if p[group].get(key) is not None)
    if len(vals) < 2:
        return False
    spread, mid = vals[-1] - vals[0], abs(vals[len(vals) // 2])
    return spread > 2 * noise(points, group, key) and spread > MIN_RELATIVE_SPREAD * mid


def plot(points, ek, ck, out_base):
    """One error against one cost: every point, the front marked and
    labelled. Writes out_base.png and out_base.svg; returns the front."""
    fig, _, fr = figure(points, ek, ck)
    os.makedirs(os.path.dirname(out_base), exist_ok=True)
    fig.savefig(out_base + ".png", dpi=110)
    fig.savefig(out_base + ".svg")
    plt.close(fig)
    return fr


def _from_zero(ax, axis, values):
    """The axis from 0 (a small difference looks small), with a margin below
    0 as above the largest value, so that a point at 0 is drawn whole."""
    top = max(values)
    pad = 0.06 * top if top > 0 else 1.0
    (ax.set_ylim if axis == "y" else ax.set_xlim)(-pad, top + pad)


def figure(points, ek, ck):
    """(figure, axes, front) of plot(): every point inside the axes with a
    margin (none half clipped at an edge or corner), the legend outside
    them, on the right, so that it covers no point."""
    el = next(e for e in ERRORS if e[0] == ek)
    cl = next(c for c in COSTS if c[0] == ck)
    pts = [p for p in points if p["errors"].get(ek) is not None and p["costs"].get(ck) is not None]
    fr = front(pts, ek, ck)
    fig, ax = plt.subplots(figsize=(7.6, 4.4))
    ax.scatter([p["costs"][ck] for p in pts], [p["errors"][ek] for p in pts], s=28, color="#9aa7b5", label="points",
               zorder=2)
    # repeated points: their runs' range on each axis
    for p in pts:
        xs, ys = repeat_values(p, "costs", ck), repeat_values(p, "errors", ek)
        if len(xs) > 1 or len(ys) > 1:
            x, y = p["costs"][ck], p["errors"][ek]
            ax.errorbar([x], [y], xerr=[[x - min(xs)], [max(xs) - x]], yerr=[[y - min(ys)], [max(ys) - y]],
                        fmt="none", ecolor="#6b7785", elinewidth=0.8, capsize=2, zorder=2)
    if fr:
        ax.step([p["costs"][ck] for p in fr], [p["errors"][ek] for p in fr], where="post", color="#c0392b", lw=1.2,
                zorder=3)
        ax.scatter([p["costs"][ck] for p in fr], [p["errors"][ek] for p in fr], s=46, color="#c0392b",
                   label="Pareto front", zorder=4)
        for p in fr:
            ax.annotate(p["label"], (p["costs"][ck], p["errors"][ek]), textcoords="offset points", xytext=(5, 5),
                        fontsize=7, color="#5b1a12")
    ax.set_xlabel(f"{cl[1]} ({cl[2]})")
    ax.set_ylabel(f"{el[1]} ({el[2]})")
    ys, xs = [p["errors"][ek] for p in pts], [p["costs"][ck] for p in pts]
    ax.margins(0.06)
    if all(y > 0 for y in ys) and max(ys) > 20 * min(ys):
        ax.set_yscale("log")
    elif all(y >= 0 for y in ys):
        _from_zero(ax, "y", ys)
    if all(x >= 0 for x in xs) and max(xs) <= 20 * max(min(xs), 1e-300):
        _from_zero(ax, "x", xs)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.set_title(f"{el[1]} against {cl[1]}", fontsize=9)
    fig.tight_layout()
    return fig, ax, fr
