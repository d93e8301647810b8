"""Policies for AssemblyEnv (docs/env.md); each acts only through env.step.

Contract:
  - PlannerPolicy: the built-in planner. At reset it asks the C++ planner
    for its jobs (operator --scene SCENE --plan-jobs: each site's particle,
    assigned at least total travel, in assembly order; Planner::jobs, the
    one owner), then gives one action per job: the planner's push of that
    particle to its site moved by the card's drift estimate (kind 2,
    Planner::push_particle in the operator, which aims in frame A);
    the jobs whose site the card's model does not show filled afterwards are
    pushed once more, then it ends the episode (kind 3).
  - RandomPolicy: strokes (kind 0) between uniformly drawn points of the
    field at a drawn load, from the action space's own generator (seeded),
    then kind 3 after `steps` of them.
  - run_episode(env, policy, seed, options) plays one episode and returns
    its score: the return, steps, the fresh scan's placement, wall and
    simulated seconds, actions a wall second.
"""
import json
import subprocess
import time

import numpy as np

from analysis import paths
from analysis.env.assembly_env import KIND_END, KIND_PUSH, KIND_STROKE


def _action(env, kind, **kw):
    a = {"kind": kind, "from": np.zeros(2, np.float32), "to": np.zeros(2, np.float32),
         "load_nN": np.array([5.0], np.float32), "size": np.array([0.08], np.float32), "particle": 0}
    a.update(kw)
    return a


def plan_jobs(scene_path):
    """The C++ planner's jobs for the scene: [{"site", "site_nm", "particle"}]."""
    p = subprocess.run([paths.OPERATOR, "--scene", scene_path, "--plan-jobs"], capture_output=True, text=True, timeout=60)
    if p.returncode != 0:
        raise RuntimeError(f"operator --plan-jobs {scene_path}: exit {p.returncode}: {p.stderr.strip()[-300:]}")
    return json.loads(p.stdout)["jobs"]


class PlannerPolicy:
    name = "builtin"

    def reset(self, env, obs, info):
        self.env = env.unwrapped
        self.jobs = plan_jobs(self.env.scene_path)
        self.queue = list(self.jobs)
        self.retried = False

    def _unfilled(self, obs):
        tol = float(self.env.scene["operator"].get("plan", {}).get("tolerance_nm", 25))
        ids = self.env._particle_ids()
        out = []
        for j in self.jobs:
            k = ids.index(j["particle"])
            x, y, _ = obs["particles"][k]
            sx, sy = j["site_nm"][0] + obs["drift_nm"][0], j["site_nm"][1] + obs["drift_nm"][1]
            if not obs["particle_mask"][k] or np.hypot(x - sx, y - sy) > tol:
                out.append(j)
        return out

    def act(self, obs):
        if not self.queue and not self.retried:
            self.retried = True
            self.queue = self._unfilled(obs)
        if not self.queue:
            return _action(self.env, KIND_END)
        j = self.queue.pop(0)
        at = (j["site_nm"][0] + float(obs["drift_nm"][0]), j["site_nm"][1] + float(obs["drift_nm"][1]))   # frame A
        return _action(self.env, KIND_PUSH, particle=self.env._particle_ids().index(j["particle"]), to=self.env.to_unit(at))


class RandomPolicy:
    name = "random"

    def __init__(self, steps=50, seed=0):
        self.steps, self.seed = steps, seed

    def reset(self, env, obs, info):
        self.env = env.unwrapped
        self.rng = np.random.Generator(np.random.PCG64(self.seed))
        self.left = self.steps

    def act(self, obs):
        self.left -= 1
        if self.left < 0:
            return _action(self.env, KIND_END)
        u = self.rng.uniform(-0.9, 0.9, 4).astype(np.float32)
        return _action(self.env, KIND_STROKE, **{"from": u[:2], "to": u[2:],
                                                 "load_nN": np.array([self.rng.uniform(2, 10)], np.float32)})


def run_episode(env, policy, seed=None, options=None):
    t0 = time.monotonic()
    obs, info = env.reset(seed=seed, options=options)
    reset_s = time.monotonic() - t0
    policy.reset(env, obs, info)
    ret, steps, done = 0.0, 0, False
    t1 = time.monotonic()
    while not done:
        obs, r, term, trunc, info = env.step(policy.act(obs))
        ret += r
        steps += 1
        done = term or trunc
    wall = time.monotonic() - t1
    fresh = info.get("fresh_scan") or {}
    return {"policy": policy.name, "return": round(ret, 3), "steps": steps, "sites": fresh.get("sites"),
            "placed": fresh.get("placed"), "worst_nm": fresh.get("worst_nm"), "rms_nm": fresh.get("rms_nm"),
            "sim_s": round(info.get("sim_s", 0.0), 2), "wall_s": round(wall, 2), "reset_s": round(reset_s, 2),
            "steps_per_s": round(steps / wall, 1) if wall > 0 else None, "run_dir": env.unwrapped.run_dir,
            "error": info.get("error")}
