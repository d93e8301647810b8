"""./afm bench scanner: a reduced ablation of the scanner's errors against
the card's compensation (issue 48, item 3), measured from runs.

    ./afm bench scanner [--scene scenes/lab/default.yaml] [--out DIR] [--only NAME ...]

The lab scene (its include, the calibration's firmware.scanner, kept) is
run with its instrument's effects (piezo_hysteresis, piezo_creep,
scan_artefacts, z_drift) none, each alone and all together, against the
card's compensation off, each part on and both on (firmware.hyst_enable,
firmware.creep_enable); the scene's other effects stay. The sources, their
levels and the parts are analysis/ablation.py's, which ./afm paper's
compensation and ablation experiments share. Per run, from its
own log and run.json:
  push error   each particle's final place (SIM_TRUTH) against its place in
               the run with an ideal scanner and no compensation (the
               same pushes on a perfect instrument): the error the
               instrument put into each site's push, the worst over sites;
  card error   the card's model of each particle against the truth at the
               end, the worst (what the display shows against the sample);
  verdict      the run's own checks (fidelity: the display against the
               fresh scan), failed checks named.
Writes DIR/scanner_study.json and DIR/scanner_study.md (the table) and
prints the table. Exit 0 when every run completed, 2 otherwise."""
import argparse
import copy
import json
import os
import sys

import numpy as np
import yaml

from analysis import ablation, knobs, paths, point

INSTRUMENT = ("hysteresis", "creep", "artefacts", "z_drift")   # ablation.SOURCES' names
EFFECT = {"hysteresis": "piezo_hysteresis", "creep": "piezo_creep", "artefacts": "scan_artefacts", "z_drift": "z_drift"}
# (name, the instrument's sources on, the card's compensation parts on)
CASES = [("ideal", (), ())] + \
        [(f"{EFFECT[e]} alone", (e,), ()) for e in INSTRUMENT] + \
        [("piezo_hysteresis alone, hyst on", ("hysteresis",), ("hyst",)),
         ("piezo_creep alone, creep on", ("creep",), ("creep",)),
         ("all, compensation off", INSTRUMENT, ()),
         ("all, hyst on", INSTRUMENT, ("hyst",)),
         ("all, creep on", INSTRUMENT, ("creep",)),
         ("all, both on", INSTRUMENT, ("hyst", "creep"))]


def case_scene(scene, scene_dir, sources, parts):
    """The scene with its includes made absolute and the case's settings
    (analysis/ablation.py) applied."""
    s = copy.deepcopy(scene)
    s["include"] = [os.path.join(scene_dir, f) for f in (s.get("include") or [])]
    return knobs.apply(s, ablation.settings(s, sources, parts, among=INSTRUMENT), where="./afm bench scanner")


def run_case(name, scene, scene_dir, out, sources, parts):
    slug = name.replace(" ", "_").replace(",", "")
    path = os.path.join(out, slug + ".yaml")
    with open(path, "w") as f:
        f.write(f"# ./afm bench scanner: {name}\n")
        yaml.safe_dump(case_scene(scene, scene_dir, sources, parts), f, sort_keys=False)
    run_dir = os.path.join(out, slug)
    code, err, rj, wall = point.run_scene(path, run_dir, 900)
    if code != 0 or not rj or rj.get("status") != "ok":
        return {"case": name, "error": str(point.failure_of(code, err, rj, run_dir))[:300]}
    card, truth = ablation.particles_at(run_dir)
    v = rj.get("verdict", {})
    return {"case": name, "run": run_dir, "wall_s": wall, "pass": v.get("pass"),
            "failed": [f"{f['check']}: {f['detail']}" for f in v.get("failed", [])],
            "card_error_nm": max(float(np.linalg.norm(card[i] - truth[i])) for i in truth),
            "truth": {i: p.tolist() for i, p in truth.items()}}


def table(rows):
    ideal = next((r for r in rows if r["case"] == "ideal" and "truth" in r), None)
    lines = ["| case | push error, worst site (nm) | card error, worst (nm) | verdict |", "| --- | --- | --- | --- |"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['case']} | - | - | run failed: {r['error'][:80]} |")
            continue
        push = "-"
        if ideal:
            push = f"{max(float(np.linalg.norm(np.array(r['truth'][i]) - np.array(ideal['truth'][i]))) for i in ideal['truth']):.1f}"
            r["push_error_nm"] = float(push)
        verdict = "pass" if r["pass"] else "; ".join(f[:70] for f in r["failed"])
        lines.append(f"| {r['case']} | {push} | {r['card_error_nm']:.1f} | {verdict} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="./afm bench scanner", description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=os.path.join(paths.ROOT, "scenes", "lab", "default.yaml"))
    ap.add_argument("--out", default=os.path.join(paths.ROOT, "runs", "bench_scanner"))
    ap.add_argument("--only", nargs="*", help="cases by name (the ideal run always)")
    a = ap.parse_args(argv)
    with open(a.scene) as f:
        scene = yaml.safe_load(f)
    os.makedirs(a.out, exist_ok=True)
    cases = [c for c in CASES if not a.only or c[0] == "ideal" or c[0] in a.only]
    rows = []
    for name, sources, parts in cases:
        r = run_case(name, scene, os.path.dirname(os.path.abspath(a.scene)), a.out, sources, parts)
        print(f"bench scanner: {name}: " + (r["error"][:120] if "error" in r else
                                            f"card error {r['card_error_nm']:.1f} nm, {'pass' if r['pass'] else 'fails'}"),
              flush=True)
        rows.append(r)
    text = table(rows)
    print(text)
    with open(os.path.join(a.out, "scanner_study.md"), "w") as f:
        f.write(f"# ./afm bench scanner on {a.scene}\n\n{text}\n")
    with open(os.path.join(a.out, "scanner_study.json"), "w") as f:
        json.dump(rows, f, indent=1, default=str)
    return 0 if all("error" not in r for r in rows) else 2


if __name__ == "__main__":
    sys.exit(main())
