"""The sweep's outputs: sweep.csv, sweep.json, the table on stdout, the
Pareto plots and one self-contained report.html (Jinja2, the plots inline)."""
import concurrent.futures
import csv
import datetime
import json
import math
import os
import statistics

import jinja2

from analysis import pareto, units

HERE = os.path.dirname(os.path.abspath(__file__))


def columns(points, knob_keys):
    """The CSV's columns: every knob, the status, the run's own verdict,
    every error figure, every cost figure and the run's folder."""
    cost_keys = []
    for p in points:
        for k in p.get("costs", {}):
            if k not in cost_keys:
                cost_keys.append(k)
    err_keys = [e[0] for e in pareto.ERRORS] + ["force_rms_pct_fs", "force_worst_pct_fs", "display_rms_height_nm",
                                                 "blocks"]
    return ["point", "label"] + knob_keys + ["status", "verdict"] + err_keys + sorted(cost_keys) + [
        "errors_identical_over_repeats", "run_dir", "failure"]


def row(p, cols, knob_keys):
    r = {"point": p["id"], "label": p["label"], "status": p["status"], "run_dir": p.get("run_dir", ""),
         "verdict": verdict_words(p.get("verdict")),
         "errors_identical_over_repeats": p.get("errors_identical_over_repeats", "")}
    for k in knob_keys:
        r[k] = p["settings"].get(k)
    for k, v in (p.get("errors") or {}).items():
        if k in cols:
            r[k] = v
    for k, v in (p.get("costs") or {}).items():
        r[k] = v
    if p["status"] != "ok":
        f = p.get("failure", {})
        r["failure"] = f"{f.get('process', 'launcher')} exit {f.get('process_exit_code', f.get('exit_code'))}: {f.get('error') or f.get('stderr', '')}"
    return {c: r.get(c, "") for c in cols}


def verdict_words(v):
    """A point's verdict, as its run.json says it (the one owner,
    host/launch/verdict.hpp): "pass", or "fail: CHECK, ..." naming the
    checks it failed; "" for a point with no run."""
    if not isinstance(v, dict):
        return ""
    if v.get("pass"):
        return "pass"
    failed = [f.get("check", "?") if isinstance(f, dict) else str(f) for f in v.get("failed") or []]
    return "fail: " + ", ".join(failed) if failed else "fail"


def write_csv_json(out, points, knob_keys, meta):
    cols = columns(points, knob_keys)
    with open(os.path.join(out, "sweep.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        for p in points:
            w.writerow(row(p, cols, knob_keys))
    with open(os.path.join(out, "sweep.json"), "w") as f:
        json.dump(dict(meta, points=points), f, indent=2, sort_keys=True, default=str)
        f.write("\n")
    return cols


def fmt(v, digits=None):
    """A value as the tables show it: analysis/units.py's number (at most 4
    significant digits, yes/no), "-" for none; `digits` is not used (the
    one owner decides)."""
    if v is None or v == "":
        return "-"
    if isinstance(v, (int, float)):
        return units.number(v)
    return str(v)


TABLE = [("force_rms_pN", "F rms (pN)"), ("force_worst_pN", "F worst (pN)"), ("apex_rms_nm", "apex rms (nm)"),
         ("objects_worst_nm", "obj worst (nm)"), ("display_max_nm", "display (nm)")]
TABLE_COSTS = [("wall_s_per_sim_s", "wall (s/s)"), ("cpu_s_per_sim_s", "CPU (s/s)"), ("fw_instr_per_sample", "fw instr"),
               ("fw_text_bytes", "fw text (B)"), ("renderer_ms_per_frame", "render (ms)")]


def table(points):
    """The table on stdout: one line per point."""
    head = ["point"] + [h for _, h in TABLE] + [h for _, h in TABLE_COSTS]
    lines = []
    for p in points:
        if p["status"] != "ok":
            f = p.get("failure", {})
            lines.append([p["label"], f"FAILED: {f.get('process', 'launcher')} exit "
                                      f"{f.get('process_exit_code', f.get('exit_code'))}"])
            continue
        lines.append([p["label"]] + [fmt(p["errors"].get(k)) for k, _ in TABLE] +
                     [fmt(p["costs"].get(k)) for k, _ in TABLE_COSTS])
    widths = [max(len(str(l[i])) for l in [head] + [x for x in lines if len(x) == len(head)]) for i in range(len(head))]
    out = ["  ".join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in enumerate(zip(head, widths)))]
    for l in lines:
        if len(l) != len(head):
            out.append(f"{l[0].ljust(widths[0])}  {l[1]}")
        else:
            out.append("  ".join(str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in enumerate(zip(l, widths))))
    return "\n".join(out)


def knob_effects(points, knobs):
    """Per knob, from its first value to its last: the median factor by which
    each headline error and cost changes among points that differ in that
    knob only (so the other knobs are held)."""
    ok = [p for p in points if p["status"] == "ok"]
    rows = []
    for key, values in knobs:
        if len(values) < 2:
            continue
        lo, hi = values[0], values[-1]
        groups = {}
        for p in ok:
            rest = tuple(sorted((k, json.dumps(v)) for k, v in p["settings"].items() if k != key))
            groups.setdefault(rest, {})[json.dumps(p["settings"].get(key))] = p
        pairs = [(g[json.dumps(lo)], g[json.dumps(hi)]) for g in groups.values()
                 if json.dumps(lo) in g and json.dumps(hi) in g]
        if not pairs:
            continue
        eff = {"knob": key, "from": lo, "to": hi, "pairs": len(pairs), "unjudged": []}
        for k, _, _ in pareto.ERRORS + pareto.COSTS:
            group = "errors" if any(k == e[0] for e in pareto.ERRORS) else "costs"
            if k in pareto.TIMED:   # only over repeats, with the spread (pareto.effect_on_timed)
                eff[k], eff[f"{k}_range"] = pareto.effect_on_timed(pairs, k)
                if eff[k] is None and any(a[group].get(k) is not None for a, _ in pairs):
                    eff["unjudged"].append(k)
                continue
            ratios = [b[group].get(k) / a[group].get(k) for a, b in pairs
                      if a[group].get(k) and b[group].get(k) is not None and a[group].get(k) > 0]
            eff[k] = statistics.median(ratios) if ratios else None
        rows.append(eff)
    return rows


def unjudged_words(keys):
    """The sentence for clock-read costs that no knob's effect can be said of."""
    names = [l for k, l, _ in pareto.COSTS if k in keys]
    return (f"{'; '.join(names)}: each point was run once, on a shared machine, so what a knob does to "
            f"{'it' if len(names) == 1 else 'them'} cannot be judged (--repeat 3 measures the spread).")


def best_buy(effects):
    """The knob that buys the most accuracy per unit of cost: the largest
    drop of the tip force's RMS error (log ratio) per rise of CPU time per
    simulated second (log ratio), among knobs that lower the error."""
    best = None
    for e in effects:
        de, dc = e.get("force_rms_pN"), e.get("cpu_s_per_sim_s")
        if not de or not dc or de >= 1.0:
            continue
        gain = -math.log(de)
        price = max(math.log(dc), 0.01)   # a knob that costs nothing measurable: a floor, not a division by 0
        score = gain / price
        if best is None or score > best[1]:
            best = (e, score)
    return best


def conclusion(points, knobs, effects, best):
    """The sweep's finding in words, for the top of the report: which knob
    changes which figure beyond its noise, and by what factor; the figures
    that did not move; the points that failed."""
    ok = [p for p in points if p["status"] == "ok"]
    failed = len(points) - len(ok)
    out = []
    if not ok:
        return [f"No point was measured: all {len(points)} failed (the table says why)."]
    moving = [(k, l) for k, l, _ in pareto.ERRORS if pareto.varies(ok, "errors", k)]
    still = [l for k, l, _ in pareto.ERRORS if not pareto.varies(ok, "errors", k) and any(p["errors"].get(k) is not None for p in ok)]
    for e in effects:
        parts = []
        for k, label in moving:
            f = e.get(k)
            if f is not None and abs(math.log(f)) > math.log(1 + pareto.MIN_RELATIVE_SPREAD):
                parts.append(f"{label} x{fmt(f)}")
        costs = [f"{l} x{fmt(e.get(k))}" + (f" (x{fmt(e[k + '_range'][0])} to x{fmt(e[k + '_range'][1])} over the repeats)"
                                             if e.get(k + "_range") else "")
                 for k, l, _ in pareto.COSTS if pareto.varies(ok, "costs", k) and e.get(k) is not None]
        what = "; ".join(parts) if parts else "no error figure beyond its noise"
        out.append(f"{e['knob']} from {e['from']} to {e['to']}: {what}" + (f"; costs {', '.join(costs)}" if costs else "") +
                   f" (median over {e['pairs']} pair(s)).")
    unjudged = sorted({k for e in effects for k in e.get("unjudged", [])}, key=list(pareto.TIMED).index)
    if unjudged:
        out.append(unjudged_words(unjudged))
    if not moving:
        out.append("No error figure varies over this sweep beyond its repeat noise and "
                   f"{pareto.MIN_RELATIVE_SPREAD:.0%} of its value: within these knobs the accuracy does not depend on them.")
    if still:
        out.append("Unchanged beyond noise: " + ", ".join(still) + ".")
    if best:
        out.append(f"Best buy: {best[0]['knob']} (the most accuracy per unit of CPU time).")
    if failed:
        out.append(f"{failed} of {len(points)} points failed (the table says why).")
    return out


def _plot_one(args):
    ok, ek, ck, base = args
    return ek, ck, base, [p["label"] for p in pareto.plot(ok, ek, ck, base)]


def write_plots(out, points):
    """Every error figure against every cost figure that varies over the
    sweep, drawn on every core; returns [(error key, cost key, base path,
    front labels)] in a stable order."""
    ok = [p for p in points if p["status"] == "ok"]
    jobs = [(ok, ek, ck, os.path.join(out, "plots", f"{ek}__{ck}"))
            for ek, _, _ in pareto.ERRORS if pareto.varies(ok, "errors", ek)
            for ck, _, _ in pareto.COSTS if pareto.varies(ok, "costs", ck)]
    if not jobs:
        return []
    os.makedirs(os.path.join(out, "plots"), exist_ok=True)
    with concurrent.futures.ProcessPoolExecutor(max_workers=min(len(jobs), os.cpu_count() or 1)) as ex:
        return list(ex.map(_plot_one, jobs))


def write_html(out, meta, points, knobs, plots, effects, best):
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(os.path.join(HERE, "templates")), autoescape=True)
    env.filters["fmt"] = fmt
    svgs = {}
    for ek, ck, base, _ in plots:
        with open(base + ".svg") as f:
            svg = f.read()
        svgs[(ek, ck)] = svg[svg.index("<svg"):]
    env.filters["knob"] = lambda v: units.number(v) if isinstance(v, (int, float)) else str(v)
    html = env.get_template("sweep.html.j2").render(
        meta=meta, points=points, knobs=knobs, plots=plots, svgs=svgs, effects=effects, best=best,
        conclusion=conclusion(points, knobs, effects, best), min_spread=pareto.MIN_RELATIVE_SPREAD,
        errors=pareto.ERRORS, costs=pareto.COSTS, table_errors=TABLE, table_costs=TABLE_COSTS,
        now=datetime.datetime.now().isoformat(timespec="seconds"))
    with open(os.path.join(out, "report.html"), "w") as f:
        f.write(html)
