"""Fits the run's wall-time estimate of ./afm check (host/launch/warnings.hpp:
estimate_wall) to measured runs, for a developer retuning it; no run needs it.

    .venv/bin/python tools/wall_fit.py RUN_DIR [RUN_DIR ...]

Each RUN_DIR is a run's folder (./afm run --out, or the e2e tests' kept
runs): its scene.yaml, as the run ran it, and run.json's wall_seconds. The
work each run counts comes from the launcher itself (afm_launch --estimate
--scene RUN_DIR/scene.yaml), so the features have one definition, in C++.
The coefficients are fitted by non-negative least squares on the relative
error (each run weighted by 1 / its wall time: a 1 s run and a 60 s run
count alike), and printed as warnings.cpp's kFit initializer, with each
run's measured and fitted time and the leave-one-out error (each run
predicted by the fit of the others). Runs that plan or run in realtime are
left out (the estimate does not warn of them). Exit 0, or 2 naming a folder
that is not a run's.
"""
import json
import os
import subprocess
import sys

import numpy as np
from scipy.optimize import nnls

HERE = os.path.dirname(os.path.abspath(__file__))
LAUNCH = os.path.join(os.environ.get("AFM_BUILD", os.path.join(HERE, "..", "build", "main")), "host", "afm_launch")
FEATURES = ["one", "blocks", "samples", "scan_px", "rough_scan_px", "frame_px", "wire_samples"]   # warnings.cpp's WallFit, in order


def measured(run_dir):
    """(features, wall s) of one run's folder, or None for a planned or realtime run."""
    scene, record = os.path.join(run_dir, "scene.yaml"), os.path.join(run_dir, "run.json")
    if not (os.path.isfile(scene) and os.path.isfile(record)):
        sys.exit(f"wall_fit: {run_dir}: not a run's folder (no scene.yaml and run.json)")
    p = subprocess.run([LAUNCH, "--estimate", "--quiet", "--scene", scene], capture_output=True, text=True, timeout=60)
    if p.returncode != 0:
        sys.exit(f"wall_fit: {scene}: afm_launch --estimate exited {p.returncode}: {p.stderr.strip()}")
    e = json.loads(p.stdout.strip().splitlines()[-1])
    if e["planned"] or e["realtime"]:
        return None
    with open(record) as f:
        wall = json.load(f)["wall_seconds"]
    return [1.0] + [e[k] for k in FEATURES[1:]], wall


def fit(rows, walls):
    a = np.array(rows) / np.array(walls)[:, None]
    coef, _ = nnls(a, np.ones(len(walls)))
    return coef


def main(argv):
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__.strip())
        return 0 if argv else 2
    names, rows, walls = [], [], []
    for d in argv:
        m = measured(d)
        if m is not None:
            names.append(os.path.basename(os.path.normpath(d)))
            rows.append(m[0])
            walls.append(m[1])
    if len(rows) < len(FEATURES):
        sys.exit(f"wall_fit: {len(rows)} scripted lockstep runs; the fit needs at least {len(FEATURES)}")
    coef = fit(rows, walls)
    print("constexpr WallFit kFit = {" + ", ".join(f"{c:.3g}" for c in coef) + "};   // " + ", ".join(FEATURES))
    errs, loo = [], []
    for i, (n, r, w) in enumerate(zip(names, rows, walls)):
        est = float(np.dot(coef, r))
        others = [j for j in range(len(rows)) if j != i]
        c_o = fit([rows[j] for j in others], [walls[j] for j in others])
        est_o = float(np.dot(c_o, r))
        errs.append(est / w - 1)
        loo.append(est_o / w - 1)
        print(f"{n:32s} measured {w:7.2f} s  fitted {est:7.2f} s ({100 * errs[-1]:+5.0f} %)  left out {est_o:7.2f} s ({100 * loo[-1]:+5.0f} %)")
    rms = lambda v: 100 * float(np.sqrt(np.mean(np.square(v))))
    print(f"{len(rows)} runs: rms error {rms(errs):.0f} %, worst {100 * max(map(abs, errs)):.0f} %; "
          f"left out: rms {rms(loo):.0f} %, worst {100 * max(map(abs, loo)):.0f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
