"""./afm paper's outputs: paper.json (for scripts), report.md and a
self-contained report.html (figures inline), and the tables on stdout: the
figures (paper, bench, truth) and the paper's models against the truth
(model, truth), each row with the error, its tolerance from
analysis/paper/tolerances.yaml and its verdict. Numbers through
analysis/units.py (at most 4 significant digits; an absolute error and
tolerance with the row's unit); each figure inline, with links to its PNG
and, where the experiment wrote one beside it, its SVG. Each file is
written whole or not at all, no link followed (analysis/safefs.py's atomic
writer)."""
import base64
import datetime
import json
import os
from dataclasses import asdict

import jinja2

from analysis import paths, safefs, units

TEMPLATES = os.path.join(paths.ROOT, "analysis", "templates")


def fmt(v, digits=None):
    """A number as a person reads it (None: a dash): analysis/units.py's
    (at most 4 significant digits, no exponent, yes/no)."""
    if v is None or v == "":
        return "-"
    return units.number(v) if isinstance(v, (int, float)) else str(v)


def _with_unit(v, r, sign=False):
    """An absolute error or tolerance with the row's unit."""
    text = units.number(v, sign)
    return f"{text} {r.unit}" if r.unit else text


def _err(r):
    if r.error is None:
        return "-"
    return f"{units.number(100 * r.error, sign=True)} %" if r.relative else _with_unit(r.error, r, sign=True)


def _tol(r):
    if r.tolerance is None:
        return "-"
    return f"{units.number(100 * r.tolerance)} %" if r.relative else _with_unit(r.tolerance, r)


def model_rows(res):
    return [r for r in res.rows if r.model is not None]


def figure_rows(res):
    return [r for r in res.rows if r.model is None]


def table(results):
    """The stdout tables: one line per figure, then one per model row."""
    head = f"{'experiment':10s} {'quantity':44s} {'paper':>10s} {'bench':>11s} {'truth':>11s} {'error':>10s} {'tol':>8s}  verdict"
    lines = [head, "-" * len(head)]
    for name, (_, res, _) in results.items():
        for r in figure_rows(res):
            q = f"{r.quantity} ({r.unit})" if r.unit else r.quantity
            lines.append(f"{name:10s} {q[:44]:44s} {fmt(r.paper):>10s} {fmt(r.bench):>11s} {fmt(r.truth):>11s} {_err(r):>10s} "
                         f"{_tol(r):>8s}  {r.verdict}")
    what = "the paper's model against the truth"
    head = f"{'experiment':10s} {what:56s} {'model':>11s} {'truth':>11s} {'error':>10s} {'tol':>8s}  verdict"
    lines += ["", head, "-" * len(head)]
    for name, (_, res, _) in results.items():
        for r in model_rows(res):
            q = f"{r.quantity} ({r.unit})" if r.unit else r.quantity
            lines.append(f"{name:10s} {q[:56]:56s} {fmt(r.model):>11s} {fmt(r.truth):>11s} {_err(r):>10s} {_tol(r):>8s}  "
                         f"{r.verdict}")
    return "\n".join(lines)


def _inline(path):
    with open(path, "rb") as f:
        return "data:image/png;base64," + base64.b64encode(f.read()).decode()


def write(out, results, size, wall_s):
    now = datetime.datetime.now().isoformat(timespec="seconds")
    data = {"size": size, "wall_s": wall_s, "written": now,
            "experiments": {n: dict(res.as_dict(), title=e.TITLE, figures_of_the_paper=e.FIGURES, wall_s=w, folder=n)
                            for n, (e, res, w) in results.items()}}
    safefs.write_path(os.path.join(out, "paper.json"), json.dumps(data, indent=2) + "\n")

    md = [f"# The paper, reproduced on the bench ({size} size)", "",
          f"Written {now}; {wall_s:.0f} s. Each value under *bench* is measured from the runs' own signals, scans and "
          "firmware outputs by the firmware's own solvers; *model* is the paper's model as the card or the firmware's solver "
          "computes it; *truth* is the simulator's; *error* is bench (or model) - truth. Tolerances: "
          "analysis/paper/tolerances.yaml, fixed before running. *unit check*: the truth is the model's own formula; "
          "*run failed*: a run the row is measured from failed its own verdict.", ""]
    for n, (e, res, w) in results.items():
        md += [f"## {e.TITLE} ({e.FIGURES}): {'within tolerance' if res.ok else 'OUTSIDE tolerance'}", "",
               "| quantity | paper | bench | truth | error | tolerance | verdict | note |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        for r in figure_rows(res):
            q = f"{r.quantity} ({r.unit})" if r.unit else r.quantity
            md.append(f"| {q} | {fmt(r.paper)} | {fmt(r.bench)} | {fmt(r.truth)} | {_err(r)} | {_tol(r)} | "
                      f"{r.verdict} | {r.note} |")
        if model_rows(res):
            md += ["", "The paper's models against the truth:", "",
                   "| quantity | model | truth | error | tolerance | verdict | note |", "| --- | --- | --- | --- | --- | --- | --- |"]
        for r in model_rows(res):
            q = f"{r.quantity} ({r.unit})" if r.unit else r.quantity
            md.append(f"| {q} | {fmt(r.model)} | {fmt(r.truth)} | {_err(r)} | {_tol(r)} | {r.verdict} | {r.note} |")
        md += [""] + [f"- {t}" for t in res.notes] + [""]
        md += [f"![{cap}]({n}/{fn})" for cap, fn in res.figures] + [""]
    safefs.write_path(os.path.join(out, "report.md"), "\n".join(md) + "\n")

    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), autoescape=True)
    env.filters["fmt"] = fmt
    exps = []
    for n, (e, res, w) in results.items():
        figs = [(cap, _inline(os.path.join(out, n, fn)), f"{n}/{fn}",
                 f"{n}/{os.path.splitext(fn)[0]}.svg" if os.path.exists(os.path.join(out, n, os.path.splitext(fn)[0] + ".svg")) else None)
                for cap, fn in res.figures if os.path.exists(os.path.join(out, n, fn))]
        row = lambda r: dict(asdict(r), err=_err(r), tol=_tol(r), verdict=r.verdict)
        rows, models = [row(r) for r in figure_rows(res)], [row(r) for r in model_rows(res)]
        exps.append({"name": n, "title": e.TITLE, "figs": e.FIGURES, "ok": res.ok, "rows": rows, "models": models,
                     "notes": res.notes,
                     "figures": figs, "wall_s": w, "what": e.__doc__ or ""})
    html = env.get_template("paper.html.j2").render(exps=exps, size=size, now=now, wall_s=wall_s,
                                                     all_ok=all(x["ok"] for x in exps))
    safefs.write_path(os.path.join(out, "report.html"), html)
