#!/usr/bin/env python3
"""The bench as a gymnasium environment, end to end (issue 51; docs/env.md).

gymnasium's own check_env passes on AssemblyEnv over a small generated
task (its resets with one seed give equal observations, its steps with
one action equal observations, rewards and info); an action the operator
refuses (a push of a particle the scene does not have) is said in info and
costs more than one it carries out. The built-in planner, acting only
through env.step (the C++ planner's jobs, each the planner's push),
assembles task p10-e0 of the task set: the fresh scan at the end finds
every one of its 10 sites filled within the tolerance, with one action a
site; the operator's report counts the program's actions.
"""
import json
import os
import unittest
import warnings

import e2e_support
from gymnasium.utils.env_checker import check_env

from analysis.env import AssemblyEnv
from analysis.env.assembly_env import KIND_PUSH
from analysis.env.policies import PlannerPolicy, run_episode, _action

SMALL = {"n": 2, "field_nm": 3000, "mean_travel_nm": 400, "spacing_nm": 300, "seed": 4}


class TestEnv(unittest.TestCase):
    def test_check_env_and_a_refused_action(self):
        env = AssemblyEnv(task=SMALL, max_steps=4, max_particles=8, work_dir=e2e_support.tmpdir("check_env"),
                          keep_runs=True)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")   # its advice (normalized Box bounds) is not a failure
                check_env(env, skip_render_check=True)
            obs, info = env.reset(seed=4)
            a = _action(env, KIND_PUSH, particle=7, to=env.to_unit((0.0, 0.0)))
            obs, r, term, trunc, info = env.step(a)
            self.assertEqual(info["refused"], "unknown particle", info)
            self.assertLess(r, -0.05)
            self.assertFalse(term or trunc)
        finally:
            env.close()

    def test_builtin_planner_ten_particles(self):
        env = AssemblyEnv(task="p10-e0", work_dir=e2e_support.tmpdir("builtin"), keep_runs=True)
        try:
            s = run_episode(env, PlannerPolicy(), seed=1, options={"task": "p10-e0"})
            self.assertIsNone(s["error"], s)
            self.assertEqual((s["placed"], s["sites"]), (10, 10), s)
            self.assertLessEqual(s["worst_nm"], 25.0, s)
            self.assertLessEqual(s["steps"], 11, s)   # a push a site, and the end
            with open(os.path.join(s["run_dir"], "run.json")) as f:
                rep = json.load(f)["operator"]
            # a push a job; the last either fills the last site by the card's models (the episode ends there) or END follows
            self.assertIn(rep["env"]["pushes"], (s["steps"], s["steps"] - 1), rep["env"])
            self.assertEqual(rep["env"]["ended_by"], "END")
            self.assertEqual(rep["env"]["refused"], 0)
        finally:
            env.close()


if __name__ == "__main__":
    e2e_support.main()
