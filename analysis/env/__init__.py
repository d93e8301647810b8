"""The bench as a gymnasium environment, its policies and its generated
tasks (docs/env.md): AssemblyEnv (assembly_env.py), the run underneath
(session.py), the pattern generator and the task set (patterns.py), the
built-in planner and a random policy (policies.py), and the demo (run.py)."""
from analysis.env.assembly_env import AssemblyEnv

__all__ = ["AssemblyEnv"]
