"""The card's ride-over judgement near eq. 30's dF (issue 47, item 7;
physics.md section 7, fw_wire.h "The ride-over judgement"), measured on
lift-off scenes: ./afm bench rideover.

The generator: the paper's rod of the squeeze experiment
(scenes/paper/squeeze.yaml: 1.3 um x 100 nm, f L = 26 nN, wire mu 0.5, F_a,ts
1 nN) pushed across its axis at l / L by a cone of half angle gamma, at a
load of x times eq. 30's least load dF for that push (the firmware's solver,
afm_calc model squeeze, no twist): x from 0.8 to 1.2, several l / L and
gamma. Full: 48 scenes; reduced (the suite's test): 6.

The measurement, per scene from the run's own bus.lcmlog: whether the
truth rode over (sim_report's wire_ridden_samples, in run.json), the blocks
the card flagged RIDE-OVER (FW_STATE), the rod's true movement during them
(SIM_TRUTH: the larger of its ends' moves, block to block, summed over the
flagged blocks) and during the whole run. The goals: RIDE-OVER flagged in at
least 95 % of the scenes where the truth rides over, and no scene whose
flagged blocks saw the rod move more than 2 nm (summed, so no single block
either)."""
import argparse
import concurrent.futures
import json
import os
import sys
import tempfile

import numpy as np
import yaml

from analysis import paths, point

LOADS = {"full": [0.8, 0.9, 0.95, 0.98, 1.02, 1.05, 1.1, 1.2]}
CONES = {"full": [20, 35, 50]}
POINTS = {"full": [0.03, 0.3]}
# the reduced set: (gamma, l / L, x)
REDUCED = [(20, 0.03, 0.9), (20, 0.03, 0.98), (20, 0.03, 1.02), (20, 0.03, 1.1), (35, 0.3, 0.95), (35, 0.3, 1.05)]
RECALL_GOAL = 0.95
MOVE_GOAL_NM = 2.0
TIMEOUT_S = 180


def plan(size):
    """The scenes' (gamma deg, l / L, x of dF), in order."""
    if size == "reduced":
        return list(REDUCED)
    return [(g, q, x) for g in CONES[size] for q in POINTS[size] for x in LOADS[size]]


def _base():
    with open(os.path.join(paths.ROOT, "scenes", "paper", "squeeze.yaml")) as f:
        return yaml.safe_load(f)


def _rod(sc):
    w = sc["objects"]["wires"][0]
    L = float(w["x1_nm"] - w["x0_nm"])
    wire = sc["sample"]["wire"]
    return w, L, float(wire["friction_nN_per_um"]) * L * 1e-3, float(wire["mu"]), float(sc["sample"]["tip_substrate"]["adhesion_nN"])


def dF_nN(sc, gamma, q):
    """Eq. 30's least load for the push at l = q L (the firmware's solver)."""
    from analysis.paper import common
    _, L, fl, mu, fats = _rod(sc)
    return float(common.squeeze_model(L, q * L, gamma, mu, fl, fats)["df_nN"])


def scene(gamma, q, x):
    """One lift-off scene: the squeeze scene's rod, pushed across at l = q L
    by a cone of gamma at x dF; its dict and dF (nN)."""
    sc = _base()
    w, L, _, _, _ = _rod(sc)
    dF = dF_nN(sc, gamma, q)
    sc["name"] = f"rideover-g{gamma}-q{q}-x{x}"
    sc["probe"]["tip_half_angle_deg"] = gamma
    sc["operator"]["load_nN"] = round(x * dF, 4)
    px = w["x0_nm"] + q * L
    sc["operator"]["path_nm"] = [[px, p[1]] for p in sc["operator"]["path_nm"]]
    return sc, dF


def write_scenes(size, out):
    """The scenes as files under out; [(name, path, gamma, q, x, dF)]."""
    os.makedirs(out, exist_ok=True)
    rows = []
    for g, q, x in plan(size):
        sc, dF = scene(g, q, x)
        name = f"g{g}_q{q}_x{x}"
        path = os.path.join(out, name + ".yaml")
        with open(path, "w") as f:
            f.write(f"# ./afm bench rideover: the squeeze scene's rod at l = {q} L, gamma {g} deg, {x} dF = {x * dF:.3f} nN\n")
            yaml.safe_dump(sc, f, sort_keys=False)
        rows.append((name, path, g, q, x, dF))
    return rows


def _ends(whole):
    w = whole.wires[0]
    return np.array([[w.x_nm[0], w.y_nm[0]], [w.x_nm[-1], w.y_nm[-1]]])


def measure(run_dir):
    """(truth rode over, blocks flagged, the rod's true move in flagged blocks
    nm, its whole true move nm) of one run."""
    from analysis import afmlog
    with open(os.path.join(run_dir, "run.json")) as f:
        rj = json.load(f)
    rode = rj.get("sim", {}).get("wire_ridden_samples", 0) > 0
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE", "SIM_TRUTH"})
    flag = afmlog.afm.fw_state_t.FLAG_RIDEOVER
    flagged = {m.seq for m in log.get("FW_STATE", []) if m.flags & flag}
    whole = afmlog.whole_objects(log.get("SIM_TRUTH", []), objects=lambda m: m.objects)
    if not whole:
        raise RuntimeError(f"{run_dir}/bus.lcmlog: no SIM_TRUTH objects")
    moved_flagged, prev = 0.0, None
    for m, w in whole:
        e = _ends(w)
        if prev is not None and m.seq in flagged:
            moved_flagged += float(np.max(np.linalg.norm(e - prev, axis=1)))
        prev = e
    total = float(np.max(np.linalg.norm(_ends(whole[-1][1]) - _ends(whole[0][1]), axis=1)))
    return rode, len(flagged), moved_flagged, total


def _run(job):
    name, path, out = job
    run_dir = os.path.join(out, name)
    code, err, rj, _ = point.run_scene(path, run_dir, TIMEOUT_S)
    if code != 0 or not rj or rj.get("status") != "ok":
        return name, None, f"the run failed (exit {code}): {err.strip()[-300:]}"
    return name, measure(run_dir), None


def run_all(size, out, workers=2):
    """Runs every scene; [(name, gamma, q, x, dF, (rode, flagged, moved, total))]."""
    rows = write_scenes(size, os.path.join(out, "scenes"))
    os.chmod(out, 0o755)
    jobs = [(name, path, out) for name, path, *_ in rows]
    got = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=workers) as ex:
        for name, m, why in ex.map(_run, jobs):
            if why:
                raise RuntimeError(f"rideover: {name}: {why}")
            got[name] = m
    return [(name, g, q, x, dF, got[name]) for name, _, g, q, x, dF in rows]


def goals(results):
    """(recall, scenes ridden, scenes ridden and flagged, the worst move in
    flagged blocks nm, pass)."""
    ridden = [r for r in results if r[5][0]]
    caught = [r for r in ridden if r[5][1] > 0]
    recall = len(caught) / len(ridden) if ridden else 1.0
    worst = max((r[5][2] for r in results), default=0.0)
    return recall, len(ridden), len(caught), worst, recall >= RECALL_GOAL and worst <= MOVE_GOAL_NM


def report(results):
    lines = [f"{'scene':18s} {'gamma':>5s} {'l/L':>5s} {'x dF':>5s} {'load nN':>8s} {'truth rode':>10s} "
             f"{'flagged':>7s} {'moved in flagged nm':>19s} {'moved nm':>8s}"]
    for name, g, q, x, dF, (rode, n, mf, tot) in results:
        lines.append(f"{name:18s} {g:5d} {q:5.2f} {x:5.2f} {x * dF:8.3f} {'yes' if rode else 'no':>10s} {n:7d} {mf:19.2f} {tot:8.1f}")
    recall, nr, nc, worst, ok = goals(results)
    lines.append(f"goal 1: RIDE-OVER flagged in {nc} of the {nr} scenes where the truth rode over "
                 f"({100 * recall:.1f} %, goal >= {100 * RECALL_GOAL:.0f} %): {'met' if recall >= RECALL_GOAL else 'MISSED'}")
    lines.append(f"goal 2: the rod's largest true move during a scene's flagged blocks {worst:.2f} nm "
                 f"(goal <= {MOVE_GOAL_NM:.0f} nm): {'met' if worst <= MOVE_GOAL_NM else 'MISSED'}")
    lines.append(f"rideover: verdict: {'pass' if ok else 'FAILED'}")
    return "\n".join(lines), ok


def main(argv):
    ap = argparse.ArgumentParser(prog="./afm bench rideover", description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", choices=["full", "reduced"], default="full", help="full: 48 scenes; reduced: 6")
    ap.add_argument("--out", help="folder for the scenes and runs (default: a new temporary one, kept)")
    ap.add_argument("--workers", type=int, default=2, help="runs at once (default 2)")
    a = ap.parse_args(argv)
    if a.workers < 1:
        ap.error(f"--workers {a.workers}: at least 1")
    out = a.out or tempfile.mkdtemp(prefix="afm-rideover-")
    os.makedirs(out, exist_ok=True)
    try:
        results = run_all(a.size, out, a.workers)
    except RuntimeError as e:
        print(e, file=sys.stderr)
        return 2
    text, ok = report(results)
    print(text)
    print(f"rideover: the scenes and runs are in {out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
