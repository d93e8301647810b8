"""./afm bench pattern --planner NAME: a planner over the versioned task set
(analysis/env/patterns.py), one row per task, so that two planners compare
on the same tasks (docs/env.md).

Each task is one episode of analysis.env.AssemblyEnv with the planner as
its policy (builtin: the C++ planner's jobs and pushes; random: random
strokes), judged by the fresh scan at the end (run.json
fidelity.assembly). A row: the task set's version, the commit, the
planner, the task and its parameters, sites, placed, missing, worst and
RMS error (nm) of the sites placed (empty when none is), steps, simulated and wall seconds, and the episode's
return. Rows are appended to --out (CSV, default
runs/bench_pattern.csv; a header when the file is new) and printed as a
table. Exit 0 when every task ran, 1 naming the first that did not.
"""
import argparse
import csv
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from analysis import paths  # noqa: E402
from analysis.env import AssemblyEnv, patterns  # noqa: E402
from analysis.env.policies import PlannerPolicy, RandomPolicy, run_episode  # noqa: E402

PLANNERS = {"builtin": lambda seed: PlannerPolicy(), "random": lambda seed: RandomPolicy(40, seed)}
COLUMNS = ["taskset", "commit", "planner", "task", "n", "field_nm", "spacing_nm", "mean_travel_nm", "error_level",
           "seed", "sites", "placed", "missing", "worst_nm", "rms_nm", "steps", "sim_s", "wall_s", "return"]


def commit():
    """HEAD's commit, '+dirty' when the tree has changes; 'unknown' outside git."""
    try:
        head = subprocess.run(["git", "-C", paths.ROOT, "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", paths.ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return (head or "unknown") + ("+dirty" if dirty else "")


def row_of(t, planner, score, rev):
    sites = score["sites"] or 0
    placed = score["placed"] or 0
    out = {"taskset": patterns.TASKSET_VERSION, "commit": rev, "planner": planner, "task": t["name"],
           **{k: t[k] for k in ("n", "field_nm", "spacing_nm", "mean_travel_nm", "error_level", "seed")},
           "sites": sites, "placed": placed, "missing": sites - placed,
           "worst_nm": round(score["worst_nm"], 2) if placed else "", "rms_nm": round(score["rms_nm"], 2) if placed else "",
           "steps": score["steps"], "sim_s": score["sim_s"], "wall_s": score["wall_s"], "return": score["return"]}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="./afm bench pattern", description=__doc__.split("\n\n")[0])
    ap.add_argument("--planner", default="builtin", help=f"one of {', '.join(PLANNERS)} (default builtin)")
    ap.add_argument("--tasks", default="", help="comma-separated task names (default: the whole set)")
    ap.add_argument("--out", default=os.path.join(paths.ROOT, "runs", "bench_pattern.csv"),
                    help="the CSV the rows are appended to (default runs/bench_pattern.csv)")
    a = ap.parse_args(argv)
    if a.planner not in PLANNERS:
        ap.error(f"--planner: {a.planner}: one of {', '.join(PLANNERS)}")
    try:
        tasks = [patterns.task(n) for n in a.tasks.split(",")] if a.tasks else [dict(t) for t in patterns.TASKS]
    except KeyError as e:
        ap.error(f"--tasks: {e.args[0]}")
    rev = commit()
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    new = not os.path.exists(a.out)
    env = AssemblyEnv(max_particles=max(64, max(t["n"] + 2 for t in tasks)), max_steps=10000)
    print(f"bench pattern: task set {patterns.TASKSET_VERSION}, planner {a.planner}, commit {rev}")
    print(f"{'task':8s} {'sites':>5s} {'placed':>6s} {'worst_nm':>8s} {'rms_nm':>6s} {'steps':>5s} {'sim_s':>7s} {'wall_s':>6s}")
    try:
        with open(a.out, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            if new:
                w.writeheader()
            for t in tasks:
                score = run_episode(env, PLANNERS[a.planner](t["seed"]), seed=t["seed"], options={"task": t["name"]})
                if score["error"] or score["sites"] is None:
                    print(f"bench pattern: task {t['name']}: no fresh scan ({score['error']})", file=sys.stderr)
                    return 1
                r = row_of(t, a.planner, score, rev)
                w.writerow(r)
                f.flush()
                print(f"{r['task']:8s} {r['sites']:5d} {r['placed']:6d} {str(r['worst_nm']):>8s} {str(r['rms_nm']):>6s} "
                      f"{r['steps']:5d} {r['sim_s']:7.1f} {r['wall_s']:6.1f}", flush=True)
    finally:
        env.close()
    print(f"bench pattern: rows appended to {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
