"""The bench's analysis in Python: a run's errors against the simulator's
truth (runlog), the sweep of fidelity knobs on Dask (sweep, knobs, point)
and its report (pareto, report). Run through ./afm (it puts the checkout
and tools/ on PYTHONPATH and uses the project's .venv)."""
