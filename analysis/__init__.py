"""The project's analysis in Python: a run's errors against the simulator's
truth (runlog), the sweep of fidelity knobs on Dask (sweep, knobs, point)
and its report (pareto, sweep_report), a run's data as pandas frames (open_run,
runs) and its export to CSV and MCAP (export). Run through ./afm (the project's
.venv, where tools/setup.sh installs this package editable)."""


def __getattr__(name):
    # open_run on first use: importing the package does not import pandas
    if name == "open_run":
        from analysis.runs import open_run
        return open_run
    raise AttributeError(f"module 'analysis' has no attribute {name!r}")
