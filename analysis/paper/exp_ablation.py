"""Issue 48's ablation (item 3): each error source of a lab's instrument on
alone and all together, at the issue's lab levels, against the card's
compensation off, each part on and all on, measured from planner runs (the
ten-site cross of scenes/pattern_ten.yaml on the lab scene's scanner, the
card's hysteresis model the one ./afm calib scanner fitted on it:
scenes/lab/calibration/scanner.yml). The sources, their levels and the
parts are analysis/ablation.py's (./afm bench scanner shares them): the
sample's drift 50 nm/min with a random walk of 10 nm/sqrt(min), the
scanner's hysteresis 10 % of the scanned range, its creep 1.5 % a decade,
scan lines offset by 0.5 nm rms (with the servo's lag and the bow); the
parts the inverse hysteresis (firmware.hyst_enable), the creep feed-forward
(firmware.creep_enable) and the drift's Kalman filter
(firmware.drift_filter kalman; off is the card's step estimate). Sources
and parts no switch turns on are named in the notes (ablation.MISSING_*).

Per run, the card's side from the run's own outputs: the first push's
error at each site, the planner's own check after the first stroke of its
particle's job, before any re-push (its local scan's finding against where
the stroke left the card's model: the stroke's stray, which for a stroke
onto the site is the error against the site and the card's drift then,
FW_STATE; a particle the planner never gets onto its site in the run's
time still has its first push measured; the planner traces each check into
logs/operator.log with AFM_PLAN_TRACE, as operator_report.json keeps only
the last); the pushes (strokes) per site (operator_report.json) and the
time per site (the planner's, from its particle's first local scan to its
last check); the final placement against the fresh scan (fidelity.json's
assembly check). Against the truth, labelled so: the same first push and
final placement from SIM_TRUTH (the true particle, the sample's drift taken
off and the card's put on, against the card's model). Per site: over the sites the planner finished with in
the run's simulated time (RATES), the final placement over all.

Full size: every source case (none, each alone, every source) against every
compensation case (off, each part, all on): 30 runs of 40 s. Reduced:
every source, off and all on: 2 runs of 40 s."""
import json
import os
import re

import numpy as np

from analysis import ablation, paths, safefs
from analysis.units import show
from analysis.paper import common

NAME = "ablation"
TITLE = "Each error source against each part of the card's compensation"
FIGURES = "issue 48"

SCENE = "../pattern_ten.yaml"
INCLUDE = os.path.join(paths.ROOT, "scenes", "lab", "calibration", "scanner.yml")
SOURCES = ("drift", "hysteresis", "creep", "artefacts")   # issue 48 item 3's, those a scene key turns on
PARTS = ("hyst", "creep", "kalman")
SOURCE_CASES = [("none", ())] + [(s, (s,)) for s in SOURCES] + [("every", SOURCES)]
PART_CASES = [("off", ())] + [(p, (p,)) for p in PARTS] + [("all_on", PARTS)]
REDUCED = [("every", "off"), ("every", "all_on")]
# The scene's own duration (40 s: its ten sites take 27 s on an ideal
# instrument; operator_report.json lists a site once the planner is done
# with it), at the paper pattern's rates (10 kHz, blocks of 2 ms: the creep
# feed-forward's rule wants at most t0 / 16).
RATES = {"duration_s": 40, "sample_rate_hz": 10000, "block_hz": 500}
COST_S = 8


def source_text(src):
    return {"none": "no source", "every": "every source"}.get(src, f"{src} alone")


def part_text(part):
    return {"off": "compensation off", "all_on": "all compensation on"}.get(part, f"{part} on")


def case_name(src, part):
    return f"{src}__{part}"


def cases(size):
    """[(source case, part case)] of a size."""
    if size == "reduced":
        return list(REDUCED)
    return [(s, p) for s, _ in SOURCE_CASES for p, _ in PART_CASES]


def runs(size):
    scene = common.load_scene(SCENE)
    src, part = dict(SOURCE_CASES), dict(PART_CASES)
    return [common.Run(name=case_name(s, p), scene=SCENE, cost_s=COST_S, env={"AFM_PLAN_TRACE": "1"},
                       settings={"include": [INCLUDE], "outputs.video": "none", **RATES,
                                 **ablation.settings(scene, src[s], part[p], among=SOURCES)})
            for s, p in cases(size)]


def _read_json(run_dir, name):
    path = os.path.join(run_dir, name)
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise common.PaperError(f"{path}: cannot read: {e}")


_CHECK = re.compile(r"^plan: t (\S+) particle (\d+) stroke .* at_site (\d) model \((\S+), (\S+)\) at \((\S+), (\S+)\)")
# a check's fields: t, particle, at_site, the card's model after the stroke, the scan's finding
_SCAN = re.compile(r"^plan: scan t (\S+) particle (\d+) ")


def trace(run_dir):
    """The planner's account of its strokes and scans (AFM_PLAN_TRACE's
    lines in logs/operator.log): ([(t, id, at_site, found (x, y), model (x, y))] of each
    stroke's check, [(t, id)] of each local scan that found its particle)."""
    path = os.path.join(run_dir, "logs", "operator.log")
    checks, scans = [], []
    try:
        with open(path, errors="replace") as f:
            for line in f:
                c, s = _CHECK.match(line), _SCAN.match(line)
                if c:
                    checks.append((float(c[1]), int(c[2]), c[3] == "1", np.array([float(c[6]), float(c[7])]),
                                   np.array([float(c[4]), float(c[5])])))
                elif s:
                    scans.append((float(s[1]), int(s[2])))
    except OSError as e:
        raise common.PaperError(f"{path}: cannot read the planner's trace: {e.strerror}")
    return checks, scans


def _log(run_dir):
    """(times s, the card's drift (x, y) per block) from FW_STATE (a drift is
    always whole: objects_t.lcm); [(t s, objects)] of SIM_TRUTH's complete
    messages (every object; at least every objects_t.KEYFRAME_BLOCKS)."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE", "SIM_TRUTH"})
    fw = log.get("FW_STATE", [])
    truth = [(m.utime * 1e-6, m.objects) for m in log.get("SIM_TRUTH", []) if m.objects.complete]
    if not fw or not truth:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: no FW_STATE, or no complete SIM_TRUTH objects")
    return (np.array([m.utime * 1e-6 for m in fw]), np.array([m.objects.drift_nm for m in fw])), truth


def _nearest(times, t):
    k = int(np.searchsorted(times, t))
    return k if k == 0 or (k < len(times) and times[k] - t < t - times[k - 1]) else k - 1


def _true_error(truth, t, pid, aim, card_drift):
    """The true particle against the aim (nm), both in the card's frame: the
    true position with the sample's drift taken off and the card's drift
    put on, from the complete SIM_TRUTH message nearest t (the tip lifted
    for a scan: the particle stays)."""
    _, o = truth[_nearest(np.array([u for u, _ in truth]), t)]
    at = [np.array([p.x_nm, p.y_nm]) for p in o.particles if p.id == pid]
    return float(np.linalg.norm(at[0] - np.asarray(o.drift_nm) + card_drift - aim)) if at else None


def first_pushes(checks, log, sites):
    """{particle id: (card's error, true error)} of each site's first push:
    the planner's check after the first stroke of its particle's job, the
    scan's finding against where the stroke left the card's model (the
    planner's own stray), and SIM_TRUTH's beside it."""
    (times, drift), truth = log
    out = {}
    for t, pid, _, at, model in checks:
        if pid in out or pid not in sites:
            continue
        card_drift = drift[_nearest(times, t)]
        out[pid] = (float(np.linalg.norm(at - model)), _true_error(truth, t, pid, model, card_drift))
    return out


def site_times(checks, scans, ids):
    """The planner's time on each site (s): its particle's first local scan
    to its last check."""
    out = []
    for pid in ids:
        ts = [t for t, i in scans if i == pid] + [c[0] for c in checks if c[1] == pid]
        last = [c[0] for c in checks if c[1] == pid]
        if ts and last:
            out.append(max(last) - min(ts))
    return out


def final_truth(log, sites):
    """Each site's distance (nm) to the nearest true particle at the end,
    the sample's drift taken off (SIM_TRUTH's last complete message)."""
    _, o = log[1][-1]
    P = np.array([[p.x_nm, p.y_nm] for p in o.particles]) - np.asarray(o.drift_nm)
    return [float(np.min(np.hypot(*(P - s).T))) for s in sites]


def measure(run_dir):
    """One run's figures (module docstring): a dict."""
    plan = _read_json(run_dir, "operator_report.json").get("plan") or {}
    items = [i for i in plan.get("items", []) if i.get("kind") == "particle"]
    if not items:
        raise common.PaperError(f"{run_dir}/operator_report.json: the planner reports no particle")
    sites = {i["id"]: np.array(i["target_nm"], dtype=float) for i in items}
    checks, scans = trace(run_dir)
    if not checks and any(i.get("pushes") for i in items):
        raise common.PaperError(f"{run_dir}/logs/operator.log: the planner pushed but traced no check (AFM_PLAN_TRACE)")
    log = _log(run_dir)
    first = first_pushes(checks, log, sites)
    assembly = (_read_json(run_dir, "fidelity.json").get("assembly") or {}).get("particles") or {}
    found = [s for s in assembly.get("per_site", []) if s.get("found")]
    # fidelity.json's sites are moved by the card's drift at the end (the renderer's check): the sites themselves
    true_final = final_truth(log, [np.array(s["site_nm"]) - log[0][1][-1] for s in found])
    times = site_times(checks, scans, sites)
    n = len(items)
    card_first = [c for c, _ in first.values()]
    true_first = [t for _, t in first.values() if t is not None]
    rms = lambda v: float(np.sqrt(np.mean(np.square(v)))) if len(v) else None   # noqa: E731
    return {"sites_worked": n, "sites": int(assembly.get("sites", n)), "first_pushed": len(first),
            "first_card_nm": float(np.median(card_first)) if card_first else None,
            "first_true_nm": float(np.median(true_first)) if true_first else None,
            "first_per_site": {str(k): v for k, v in sorted(first.items())},
            "pushes_per_site": sum(int(i.get("pushes", 0)) for i in items) / n,
            "finished": plan.get("finished_sim_s") is not None,
            "time_per_site_s": float(np.mean(times)) if times else None,
            "placed_scan": int(assembly.get("placed", 0)), "found": len(found),
            "placed_truth": int(sum(e <= float(assembly.get("tolerance_nm", 25)) for e in true_final)),
            "final_scan_nm": rms([s["error_nm"] for s in found]), "final_true_nm": rms(true_final)}


def analyse(dirs, exp_dir, size):
    import concurrent.futures
    keys = cases(size)
    with concurrent.futures.ProcessPoolExecutor(max_workers=2) as pool:   # the runs are done: both cores are free
        m = dict(zip(keys, pool.map(measure, [dirs[case_name(s, p)] for s, p in keys])))
    res = common.Result()
    for (s, p), v in m.items():
        res.rows += case_rows(s, p, v)
    off, on = m[("every", "off")], m[("every", "all_on")]
    cut = None if off["first_card_nm"] is None or on["first_card_nm"] is None else \
        on["first_card_nm"] / max(off["first_card_nm"], 1e-9)
    res.rows.append(common.Row("every source: first push's error, all compensation on / off", "", key="ablation.cut",
                               bench=cut, runs=(case_name("every", "off"), case_name("every", "all_on")),
                               note="issue 48's target: cut by 10x or more (the medians over sites, the card's side)"))
    res.notes += [f"not in any run, no switch: {k}: {why}" for k, why in ablation.MISSING_SOURCES.items()]
    res.notes += [f"not in any run, no switch: the compensation's {k}: {why}" for k, why in ablation.MISSING_PARTS.items()]
    res.notes.append("first push: the planner's check after the first stroke of each particle's job, the scan's finding "
                     "against where the stroke left the card's model; per site: over the sites the "
                     f"planner finished with in the run's {RATES['duration_s']} s (simulated), the final placement over all")
    safefs.write_path(os.path.join(exp_dir, "ablation.json"),
                      json.dumps({case_name(s, p): v for (s, p), v in m.items()}, indent=1) + "\n")
    safefs.write_path(os.path.join(exp_dir, "ablation_table.md"), table(m) + "\n")
    res.figures = [("The first push's error, pushes and time per site, and the final placement, per case",
                    plot(exp_dir, m))]
    return res


def table(m):
    """The ablation as one Markdown table, a case a line (ablation_table.md)."""
    f = lambda v, unit="": "-" if v is None else show(v, unit)   # noqa: E731
    lines = ["| sources | compensation | first push's error, median (nm) | against the truth (SIM_TRUTH, nm) | "
             "pushes per site | time per site (s) | sites finished | final placement, RMS (nm) | "
             "against the truth (SIM_TRUTH, nm) | within tolerance, scan / truth |", "| --- " * 10 + "|"]
    for (s, p), v in m.items():
        lines.append(f"| {source_text(s)} | {part_text(p)} | {f(v['first_card_nm'])} | {f(v['first_true_nm'])} | "
                     f"{f(v['pushes_per_site'])} | {f(v['time_per_site_s'])} | {v['sites_worked']} of {v['sites']} | "
                     f"{f(v['final_scan_nm'])} | {f(v['final_true_nm'])} | {v['placed_scan']} / {v['placed_truth']} |")
    return "\n".join(lines)


def case_rows(s, p, v):
    """The four rows of one case."""
    case, run = f"{source_text(s)}, {part_text(p)}", (case_name(s, p),)
    pushed = f"{v['first_pushed']} of the {v['sites_worked']} sites' particles pushed"
    return [
        common.Row(f"{case}: first push's error, median over sites", "nm", key="ablation.first_push",
                   bench=v["first_card_nm"], truth=v["first_true_nm"], runs=run,
                   note=f"bench: the planner's scan (the card's side); truth: SIM_TRUTH at that block; {pushed}"),
        common.Row(f"{case}: pushes per site", "", key="ablation.pushes", bench=v["pushes_per_site"], runs=run,
                   note=f"the planner's strokes (operator_report.json) over the {v['sites_worked']} sites it finished with"
                        + ("" if v["finished"] else " before the run's end")),
        common.Row(f"{case}: time per site", "s", key="ablation.time", bench=v["time_per_site_s"], runs=run,
                   note="simulated, the planner's trace: its particle's first local scan to its last check"),
        common.Row(f"{case}: final placement, RMS over the sites found", "nm", key="ablation.placement",
                   bench=v["final_scan_nm"], truth=v["final_true_nm"], runs=run,
                   note=f"bench: the fresh scan, {v['placed_scan']} of {v['sites']} within tolerance, {v['found']} found; "
                        f"truth: SIM_TRUTH over the same sites, {v['placed_truth']} within tolerance"),
    ]


def plot(exp_dir, m):
    p = common.plt()
    srcs = [s for s, _ in SOURCE_CASES if any(k[0] == s for k in m)]
    parts = [q for q, _ in PART_CASES if any(k[1] == q for k in m)]
    fig, axes = p.subplots(2, 2, figsize=(10.0, 6.8))
    width = 0.8 / len(parts)
    panels = [("first_card_nm", "first_true_nm", "first push's error (nm)", True),
              ("pushes_per_site", None, "pushes per site", False),
              ("time_per_site_s", None, "time per site (s, simulated)", False),
              ("final_scan_nm", "final_true_nm", "final placement, RMS (nm)", True)]
    for ax, (key, true_key, label, log) in zip(axes.flat, panels):
        for j, q in enumerate(parts):
            x = np.arange(len(srcs)) + (j - (len(parts) - 1) / 2) * width
            val = [m.get((s, q), {}).get(key) for s in srcs]
            ax.bar(x, [np.nan if v is None else max(v, 0.05) for v in val], width, label=part_text(q))
            if true_key:
                tv = [m.get((s, q), {}).get(true_key) for s in srcs]
                ax.plot(x, [np.nan if v is None else max(v, 0.05) for v in tv], "k_", ms=7,
                        label="against the truth (SIM_TRUTH)" if j == 0 else None)
        if log:
            ax.set_yscale("log")
        ax.set_xticks(range(len(srcs)), [s if s in ("none", "every") else f"{s}\nalone" for s in srcs], fontsize=7)
        ax.set_ylabel(label, fontsize=8)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    top = axes.flat[1].get_ylim()[1]
    axes.flat[1].set_ylim(0, 1.4 * top)   # room for the legend above the bars
    axes.flat[1].legend(handles, labels, loc="upper center", ncol=3, fontsize=6, frameon=False)
    return common.save(fig, exp_dir, "ablation.png")
