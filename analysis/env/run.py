"""The environment's demo (./afm env demo, python -m analysis.env.run;
docs/env.md): the built-in planner and a random policy on one task of the
task set, their scores, and the environment's speed.

Contract: prints one line per policy (its score: return, sites placed in
the fresh scan, worst and RMS error, steps, simulated and wall seconds),
then the speed: reset()'s wall time (mean of the episodes') and strokes
of 200 nm a wall second through env.step (--strokes of them on the same
task, each 200 nm engaged with the tip's travel between them). Exit 0
when every episode ran, 1 naming the one that did not.
"""
import argparse
import sys
import time

import numpy as np

from analysis.env import AssemblyEnv, patterns
from analysis.env.assembly_env import KIND_STROKE
from analysis.env.policies import PlannerPolicy, RandomPolicy, run_episode


def stroke_rate(env, task, strokes, seed):
    """Strokes of 200 nm a wall second through env.step, and the reset's seconds."""
    t0 = time.monotonic()
    env.reset(seed=seed, options={"task": task})
    reset_s = time.monotonic() - t0
    half = env._field()[2]
    step = 200.0 / half
    t1 = time.monotonic()
    for k in range(strokes):
        x = -0.8 + (k % 8) * 0.2
        y = -0.9 if (k // 8) % 2 == 0 else 0.85
        a = {"kind": KIND_STROKE, "from": np.array([x, y], np.float32), "to": np.array([x, y + step], np.float32),
             "load_nN": np.array([5.0], np.float32), "size": np.array([0.1], np.float32), "particle": 0}
        env.step(a)
    return strokes / (time.monotonic() - t1), reset_s


def main(argv=None):
    ap = argparse.ArgumentParser(prog="./afm env demo", description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", default="p10-e0", help=f"a task of task set {patterns.TASKSET_VERSION} "
                    f"({', '.join(t['name'] for t in patterns.TASKS)}); default p10-e0")
    ap.add_argument("--seed", type=int, default=None, help="the task's seed (default: the task set's)")
    ap.add_argument("--random-steps", type=int, default=40, help="the random policy's strokes (default 40)")
    ap.add_argument("--strokes", type=int, default=40, help="strokes timed for the speed (default 40)")
    a = ap.parse_args(argv)
    seed = a.seed if a.seed is not None else patterns.task(a.task)["seed"]
    env = AssemblyEnv(task=a.task)
    rows, resets = [], []
    try:
        for policy in (PlannerPolicy(), RandomPolicy(a.random_steps, seed)):
            s = run_episode(env, policy, seed=seed, options={"task": a.task})
            resets.append(s["reset_s"])
            rows.append(s)
            print(f"env: {s['policy']:8s} task {a.task} (set {patterns.TASKSET_VERSION}, seed {seed}): return {s['return']:.2f}, "
                  f"placed {s['placed']}/{s['sites']} (fresh scan), worst {s['worst_nm']:.1f} nm, RMS {s['rms_nm']:.1f} nm, "
                  f"{s['steps']} steps, {s['sim_s']:.1f} s simulated, {s['wall_s']:.1f} s wall", flush=True)
            if s["error"]:
                print(f"env: {s['policy']}: {s['error']}", file=sys.stderr)
                return 1
        rate, reset_s = stroke_rate(env, a.task, a.strokes, seed)
        resets.append(reset_s)
        print(f"env: speed: {rate:.1f} strokes of 200 nm a wall second ({a.strokes} through env.step); "
              f"reset() {sum(resets) / len(resets):.2f} s (mean of {len(resets)})")
    finally:
        env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
