"""./afm bench sweep: points per minute of ./afm sweep on 2 workers, and
where a point's time goes. N points of the short scene (default 48; the
grid of KNOBS below, cut at N) run as one sweep into a fresh folder,
without callgrind unless asked; the whole command is timed, and its
sweep.json says the rest:

  the sweep's serial parts  the points' scenes checked (once, on every core),
                            the build check (its programs hashed, once), the
                            local cluster's start, and the rest of the
                            command (Python's start, root's lease of the
                            sweep's uids, the plots and report.html)
  a point, on its worker    the namespace and the drop around the launcher,
                            the launcher's start and end (its processes'
                            start, the scans, the fidelity check, run.json),
                            its loop, the errors read from the log, the
                            callgrind replay (analysis/point.py, TIMING)
  the engine                what the workers' time holds beyond their points:
                            Dask's task overhead and the workers idle at the
                            end, in % of the points' time
  process starts            each of the run's programs started alone
                            (PROGRAM --help), CPU s: what a point pays five
                            times over before its loop

Goal (issue 49): 100 points a minute on 2 workers (a 1,000-point sweep
within 10 minutes), the engine's overhead under 1 %. A benchmark: it
prints figures, the goal and met or not, and asserts nothing."""
import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import time

from analysis import paths

GOAL_PER_MIN, GOAL_ENGINE_PCT = 100.0, 1.0
# The grid, cut at N points: each knob adds its values until the grid holds N.
KNOBS = [("firmware.adc_bits", [10, 12, 14, 16]), ("firmware.word_bits", [16, 32]), ("firmware.compensate", [True, False]),
         ("operator.load_nN", [4, 5, 6, 7]), ("operator.speed_nm_per_s", [1500, 2000, 2500, 3000]),
         ("seed", [7, 8, 9, 10, 11, 12, 13, 14])]


def grid_for(n):
    """[(knob, values)] whose grid holds at least n points (the last knob's
    values cut to the fewest that do)."""
    out, size = [], 1
    for key, values in KNOBS:
        if size >= n:
            break
        take = min(len(values), -(-n // size))
        out.append((key, values[:take]))
        size *= take
    if size < n:
        sys.exit(f"bench sweep: --points {n}: the bench's grid holds at most {size}")
    return out, size


def vary_args(knobs):
    return [a for k, vs in knobs for a in ("--vary", f"{k}={','.join(str(v).lower() for v in vs)}")]


def run_sweep(a, knobs, out):
    args = [sys.executable, "-m", "analysis.sweep", a.scene, *vary_args(knobs), "--out", out, "--workers", str(a.workers)]
    if not a.callgrind:
        args.append("--no-callgrind")
    t0 = time.monotonic()
    p = subprocess.run(args, capture_output=True, text=True)
    total = time.monotonic() - t0
    if p.returncode != 0:
        sys.exit(f"bench sweep: the sweep failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    with open(os.path.join(out, "sweep.json")) as f:
        return total, json.load(f)


def process_starts():
    """{program: CPU s of PROGRAM --help}: what loading each program costs."""
    out = {}
    for prog in paths.RUN_PROGRAMS[:5]:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([prog, "--help"], capture_output=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        out[os.path.basename(prog)] = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return out


def mean(v):
    v = list(v)
    return sum(v) / len(v) if v else 0.0


def report(a, n, total, sweep):
    pts = [p for p in sweep["points"] if p["status"] == "ok"]
    serial = sweep.get("serial_s") or {}
    points_s = sweep["points_wall_s"] or 0.0
    known = sum(v for v in serial.values() if v) + points_s
    print(f"{n} points on {a.workers} workers: {total:.1f} s the whole command, {points_s:.1f} s the points")
    print("\nthe sweep's serial parts, s")
    for k, label in (("validate_s", "every point's scene checked"), ("build_check_s", "the build check"),
                     ("engine_start_s", "the local cluster's start")):
        print(f"  {label:<44} {serial.get(k) or 0.0:7.2f}")
    print(f"  {'the rest (Python, the lease, plots, report)':<44} {max(0.0, total - known):7.2f}")
    print(f"\na point on its worker, s (mean of {len(pts)})")
    timing = {k: mean(p["timing"][k] for p in pts if "timing" in p) for k in pts[0].get("timing", {})} if pts else {}
    for k, v in timing.items():
        print(f"  {k[:-2].replace('_', ' '):<44} {v:7.3f}")
    per_point = mean(p["point_wall_s"] for p in pts)
    print(f"  {'the whole point':<44} {per_point:7.3f}")
    cpu = mean((p["costs"].get("cpu_s_per_sim_s") or 0.0) for p in pts) * duration_of(a.scene)
    print(f"  {'CPU of its processes (the kernel accounting)':<44} {cpu:7.3f}")
    starts = process_starts()
    print("\nprocess starts, CPU s (PROGRAM --help, alone)")
    for k, v in starts.items():
        print(f"  {k:<44} {v:7.3f}")
    busy = sum(p["point_wall_s"] for p in pts)
    engine_pct = 100.0 * (a.workers * points_s - busy) / busy if busy else float("nan")
    per_min = 60.0 * n / total
    print(f"\nthe engine: {engine_pct:.1f} % of the points' time beyond them (task overhead and the workers idle at "
          f"the end; goal under {GOAL_ENGINE_PCT:.0f} %: {'met' if engine_pct < GOAL_ENGINE_PCT else 'not met'})")
    print(f"points per minute on {a.workers} workers: {per_min:.1f} over the whole command, "
          f"{60.0 * n / points_s if points_s else 0.0:.1f} over the points alone "
          f"(goal {GOAL_PER_MIN:.0f}: {'met' if per_min >= GOAL_PER_MIN else 'not met'})")
    return per_min


def duration_of(scene):
    import yaml
    with open(scene) as f:
        return float((yaml.safe_load(f) or {}).get("duration_s", 1.0))


def main(argv):
    ap = argparse.ArgumentParser(prog="./afm bench sweep",
                                 description="Points per minute of ./afm sweep on 2 workers, and where a point's time goes.")
    ap.add_argument("--scene", default=os.path.join(paths.ROOT, "scenes", "short.yaml"))
    ap.add_argument("--points", type=int, default=48, help="points in the sweep (default 48; 1000 for the goal's sweep)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--callgrind", action="store_true", help="also count the firmware's instructions per point")
    ap.add_argument("--out", help="the sweep's folder (default: a temporary one, removed after)")
    a = ap.parse_args(argv)
    if a.points < 2:
        sys.exit(f"bench sweep: --points {a.points}: at least 2")
    knobs, n = grid_for(a.points)
    out, kept = paths.bench_folder(a.out, "afm-bench-sweep-")
    try:
        print(f"bench sweep: {n} points of {os.path.basename(a.scene)} ({', '.join(k for k, _ in knobs)}), "
              f"{'with' if a.callgrind else 'without'} callgrind, {a.workers} workers, {os.cpu_count()} cores",
              file=sys.stderr)
        total, sweep = run_sweep(a, knobs, os.path.join(out, "sweep"))
        report(a, n, total, sweep)
    finally:
        if not kept:
            shutil.rmtree(out, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
