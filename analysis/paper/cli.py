"""./afm paper: the paper's experiments run on the bench and analysed from
the runs' own data, side by side with the paper's values and the
simulator's truth. See docs/paper.md."""
import argparse
import textwrap
import concurrent.futures
import os
import sys
import time

from analysis import paths, point, safefs
from analysis.paper import common, paper_report
from analysis import helptext
from analysis.paper import (exp_ablation, exp_compensation, exp_drift, exp_flex, exp_landmark, exp_lines, exp_pattern, exp_rod, exp_squeeze,
                            exp_tilted, exp_trench)

EXPERIMENTS = [exp_tilted, exp_lines, exp_rod, exp_squeeze, exp_trench, exp_flex, exp_drift, exp_landmark, exp_pattern,
               exp_compensation, exp_ablation]
BY_NAME = {e.NAME: e for e in EXPERIMENTS}

USAGE_EPILOG = "experiments: " + ", ".join(f"{e.NAME} ({e.FIGURES})" for e in EXPERIMENTS)


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="./afm paper", formatter_class=argparse.RawDescriptionHelpFormatter,
        description=helptext.text("paper") + "\n\n" + textwrap.fill("Runs each of the paper's experiments as scenes under scenes/paper/, analyses the runs' own "
                    "signals, scans and firmware outputs with the firmware's own solvers, and writes report.html, "
                    "report.md and paper.json into --out, one folder per experiment with its runs and figures. "
                    "Two tables on stdout: the figures, and the paper's models against the truth, each row held to "
                    "its entry in analysis/paper/tolerances.yaml; exit 1 if any row is not ok (outside its tolerance, "
                    "or measured from a run whose own verdict failed), 2 on bad arguments or a run that failed.", 79),
        epilog=USAGE_EPILOG)
    p.add_argument("--only", nargs="+", metavar="NAME", help="run these experiments only")
    p.add_argument("--out", default=os.path.join(paths.ROOT, "runs", "paper"), help="output folder (default runs/paper)")
    p.add_argument("--size", choices=["full", "reduced"], default="full",
                   help="reduced: the smaller versions ./afm test runs (same figures, looser statistics)")
    p.add_argument("--workers", type=int, default=2, help="runs at once (default 2)")
    p.add_argument("--list", action="store_true", help="list the experiments and exit")
    p.add_argument("--truth", choices=["paper", "seeded"], default="paper",
                   help="paper (default): the simulated lever and surface have the paper's constants; seeded: the "
                        "calibrations' hidden truth is drawn from --seed (tip-substrate mu, k_theta K_l / h, C_n), "
                        "told only to the simulator; the card keeps the paper's values")
    p.add_argument("--seed", type=int, default=1, help="the seeded truth's seed (default 1)")
    a = p.parse_args(argv)
    if a.only:
        bad = [n for n in a.only if n not in BY_NAME]
        if bad:
            p.error(f"--only {' '.join(bad)}: no such experiment ({', '.join(BY_NAME)})")
    if a.workers < 1:
        p.error(f"--workers {a.workers}: at least 1")
    return a


class Progress:
    def __init__(self, total):
        self.total, self.done, self.t0 = total, 0, time.monotonic()

    def tick(self, what):
        self.done += 1
        sys.stderr.write(f"\rpaper: {self.done} / {self.total} runs ({what})   {time.monotonic() - self.t0:5.0f} s   ")
        sys.stderr.flush()


# The seeded truth's ranges: realistic levers and surfaces (mu from 0.05 keeps
# the friction loops' rho = r_u / r_d away from 1, where the calibration
# carries no information).
SEEDED_RANGES = {"mu": (0.05, 0.30), "lateral_nN_per_V": (20.0, 60.0), "cn_nm_per_V": (15.0, 40.0)}


def seeded_truth(seed):
    """{experiment: settings} of a drawn truth: the simulator's lever and
    surface for the calibrations (tilted: mu and k_theta K_l / h; lines:
    C_n). The card is told the paper's values, never the drawn ones."""
    import random
    rng = random.Random(seed)
    d = {k: round(rng.uniform(*r), 4) for k, r in SEEDED_RANGES.items()}
    paper = common.paper_probe()
    return d, {"tilted": {"sample.tip_substrate.mu": d["mu"], "probe.lateral_nN_per_V": d["lateral_nN_per_V"],
                          "firmware.lateral_nN_per_V": paper["lateral_nN_per_V"], "firmware.mu": paper["mu"]},
               "lines": {"probe.cn_nm_per_V": d["cn_nm_per_V"]}}


def _seed_jobs(jobs, by_exp):
    for e, _, r in jobs:
        if e.NAME in by_exp:
            r.settings = {**(r.settings or {}), **by_exp[e.NAME]}


def _one_run(job):
    exp_dir, run = job
    run_dir = os.path.join(exp_dir, "runs", run.name)
    os.makedirs(run_dir, exist_ok=True)
    import yaml
    scene_path = os.path.join(exp_dir, "runs", run.name + ".yaml")
    scene = common.scene_for(run)
    safefs.write_path(scene_path, f"# {run.scene} with {run.settings} (./afm paper)\n" + yaml.safe_dump(scene, sort_keys=False))
    code, err, rj, wall = point.run_scene(scene_path, run_dir, run.timeout_s,
                                          env={**os.environ, **run.env} if run.env else None)
    ok = code == 0 and rj is not None and rj.get("status") == "ok"
    return run.name, run_dir, ok, (None if ok else point.failure_of(code, err, rj, run_dir)), wall


def analyse(exp, exp_dir, size, outcomes):
    """An experiment's analysis from its runs' outcomes: its Result, each row
    judged against its entry in tolerances.yaml, and any row measured from a
    run whose own verdict failed marked so (never ok)."""
    failures = [(name, fail) for name, (_, ok, fail) in outcomes.items() if not ok]
    if failures:
        name, fail = failures[0]
        res = common.Result(notes=[f"run {name} failed: {failure_text(fail)}"])
        res.rows.append(common.Row(quantity=f"run {name}", unit="", bench=None, note="the run failed"))
    else:
        try:
            res = exp.analyse({name: d for name, (d, _, _) in outcomes.items()}, exp_dir, size)
        except common.PaperError as e:
            res = common.Result(notes=[str(e)])
            res.rows.append(common.Row(quantity="analysis", unit="", bench=None, note=str(e)))
    failed = failed_verdicts(outcomes)
    if failed:
        res.notes.append("runs whose own verdict failed (their rows say so and are not ok; docs: README 'The verdict'): "
                         + "; ".join(f"{n} ({', '.join(c)})" for n, c in sorted(failed.items())))
    for r in res.rows:
        mark_failed_runs(r, failed)
        try:
            r.judge(size)
        except common.PaperError as e:
            r.ok, r.note = False, f"{e}; {r.note}"
    return res


def failure_text(fail):
    """A failed run's record (point.failure_of, or a sentence) in words, whole:
    the process and its exit code, the error, the tail of its log."""
    if not isinstance(fail, dict):
        return str(fail)
    parts = [f"exit code {fail.get('exit_code')}"]
    if fail.get("process"):
        parts.append(f"{fail['process']} exited {fail.get('process_exit_code')}")
    parts += [f"{what}: {fail[k].strip()}" for k, what in (("error", "error"), ("stderr", "stderr"), ("log_tail", "its log ends"))
              if str(fail.get(k) or "").strip()]
    return "; ".join(parts)


def failed_verdicts(outcomes):
    """{run: [check, ...]} for each run whose own verdict (run.json
    "verdict") failed: a check it failed that its scene did not expect, or
    an expected one it met."""
    failed = {}
    for name, (run_dir, _, _) in sorted(outcomes.items()):
        if run_dir is None:
            continue
        try:
            v = common.run_json(run_dir).get("verdict") or {}
        except (OSError, ValueError):
            continue
        if v and not v.get("pass", True):
            failed[name] = [f["check"] for f in v.get("failed", [])] or ["verdict"]
    return failed


def mark_failed_runs(row, failed):
    """The row's run_failed, "run failed: CHECK (RUN)", when a run it is
    measured from (row.runs; none named: every run of its experiment)
    failed its own verdict."""
    hit = [(n, failed[n]) for n in (row.runs or sorted(failed)) if n in failed]
    if hit:
        checks = sorted({c for _, cs in hit for c in cs})
        row.run_failed = f"run failed: {', '.join(checks)} ({', '.join(n for n, _ in hit)})"


def run_all(jobs, workers, prog, outcomes, walls):
    """Every run at once (workers at a time), longest first."""
    with concurrent.futures.ThreadPoolExecutor(max_workers=workers) as pool:
        futs = {pool.submit(_one_run, (d, r)): e for e, d, r in sorted(jobs, key=lambda j: -j[2].cost_s)}
        for f in concurrent.futures.as_completed(futs):
            e = futs[f]
            name, run_dir, ok, fail, wall = f.result()
            prog.tick(f"{e.NAME} {name}")
            outcomes[e.NAME][name] = (run_dir, ok, fail)
            walls[e.NAME] += wall


def main(argv):
    a = parse_args(argv)
    exps = [BY_NAME[n] for n in a.only] if a.only else EXPERIMENTS
    if a.list:
        for e in EXPERIMENTS:
            print(f"{e.NAME:10s} {e.FIGURES:14s} {e.TITLE}")
        return 0
    for prog_path in (paths.LAUNCH, common.CALC):
        if not os.path.exists(prog_path):
            sys.stderr.write(f"paper: {prog_path} is missing: build first (./afm build)\n")
            return 2
    os.makedirs(a.out, exist_ok=True)
    jobs = []
    for e in exps:
        exp_dir = os.path.join(a.out, e.NAME)
        os.makedirs(exp_dir, exist_ok=True)
        jobs += [(e, exp_dir, r) for r in e.runs(a.size)]
    seeded = None
    if a.truth == "seeded":
        drawn, seeded = seeded_truth(a.seed)
        _seed_jobs(jobs, seeded)
        sys.stderr.write(f"paper: seeded truth, seed {a.seed}: " + ", ".join(f"{k} {v}" for k, v in drawn.items()) + "\n")
    prog = Progress(len(jobs))
    t0 = time.monotonic()
    sys.stderr.write(f"paper: {len(exps)} experiments, {len(jobs)} runs, {a.size} size, {a.workers} at once, into {a.out}\n")
    outcomes = {e.NAME: {} for e in exps}
    walls = {e.NAME: 0.0 for e in exps}
    run_all(jobs, a.workers, prog, outcomes, walls)
    # A second round for experiments whose runs stand on the first's
    # (the lines' calibration, then pushes with it).
    later = []
    for e in exps:
        if hasattr(e, "more_runs") and all(ok for _, ok, _ in outcomes[e.NAME].values()):
            exp_dir = os.path.join(a.out, e.NAME)
            try:
                later += [(e, exp_dir, r) for r in e.more_runs(a.size, {n: d for n, (d, _, _) in outcomes[e.NAME].items()}, exp_dir)]
            except common.PaperError as err:
                outcomes[e.NAME]["(second round)"] = (None, False, str(err))
    if later and seeded:
        _seed_jobs(later, seeded)
    if later:
        prog.total += len(later)
        run_all(later, a.workers, prog, outcomes, walls)
    results = {}
    for e in exps:
        results[e.NAME] = (e, analyse(e, os.path.join(a.out, e.NAME), a.size, outcomes[e.NAME]), walls[e.NAME])
    sys.stderr.write("\n")
    wall = time.monotonic() - t0
    paper_report.write(a.out, results, a.size, wall)
    print(paper_report.table(results))
    print(f"paper: {wall:.0f} s; report in {os.path.join(a.out, 'report.html')} (and report.md, paper.json)")
    failed = [f"{n} {run}" for n, runs_ in outcomes.items() for run, (_, ok, _) in runs_.items() if not ok]
    if failed:
        print(f"paper: runs that failed (see the notes in report.md): {', '.join(failed)}")
        return 2
    bad = [n for n, (_, r, _) in results.items() if not r.ok]
    if bad:
        print(f"paper: rows not ok (outside their tolerance, or their run failed its verdict): {', '.join(bad)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
