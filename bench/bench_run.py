"""./afm bench run: what a user waits for, over the demo (scenes/default.yaml),
the pattern (scenes/pattern.yaml) and a long run (scenes/lab/pattern.yaml
with firmware.drift_filter: kalman, written beside the runs: about 736
simulated seconds, its sample drifting, so every particle moves every
block on both sides). Each scene is run as a user runs it
(./afm run SCENE --out DIR, AFM_TIMES set: the afm script marks the end of
its parts) and its prompt-to-prompt wall time split into

  build check  ./afm's setup and build check (tools/setup.sh, the build's stamp)
  start        from there to the loop's first recorded block (the scene's
               check, the namespace, the processes' start, the first scan)
  loop         the first to the last block the log recorded (run.json
               timing.loop_seconds beside it)
  end          the last block to the launcher's exit (the final scan, the
               video's end, run.json)
  report       the digests and report.html (analysis/run_report.py)

Beside them the launcher's own wall time (run.json wall_seconds) and what
start and end spend outside it (run/in_netns.sh: the namespace, the run's
user, the folder handed back).
(the log's recording times: analysis/report_series.py). The report is then
run again alone, its peak memory the sum of RSS over its process tree,
sampled every 5 ms.

Goals (issue 49): the report at most 10 % of the run's wall time
(run.json wall_seconds) or 1 s, whichever is larger, and at most 300 MB,
on every scene; the demo prompt to prompt in at most 3 s; the pattern's
whole command within 2x its loop's wall time. Each line prints its figure
(the median over --repeat, with its range), its goal, and met or not. Exit 1
only when a run fails."""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

from analysis import paths

SCENES = {"demo": "scenes/default.yaml", "pattern": "scenes/pattern.yaml", "long": "scenes/lab/pattern.yaml"}
REPORT_MB, REPORT_S, REPORT_FRACTION, DEMO_S, PATTERN_LOOPS = 300, 1.0, 0.10, 3.0, 2.0
PARTS = ["build check", "start", "loop", "end", "report"]


def tree_rss_kb(root):
    """The RSS (kB) of `root` and every process under it (each found through
    its parent's /proc/PID/task/TID/children: no walk of all of /proc,
    whose cost the sampled process would pay on a 2-core machine)."""
    page_kb = os.sysconf("SC_PAGE_SIZE") // 1024
    total, todo = 0, [root]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/statm") as f:
                total += int(f.read().split()[1]) * page_kb
            for tid in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{tid}/children") as f:
                    todo.extend(int(c) for c in f.read().split())
        except (OSError, ValueError, IndexError):
            continue
    return total


def long_scene(folder):
    """The long run's scene, written into `folder`: scenes/lab/pattern.yaml
    with firmware.drift_filter: kalman, its includes copied beside it."""
    src = os.path.join(paths.ROOT, SCENES["long"])
    with open(src) as f:
        text = f.read()
    if re.search(r"^  drift_filter:.*$", text, re.M):
        text = re.sub(r"^  drift_filter:.*$", "  drift_filter: kalman", text, flags=re.M)
    elif re.search(r"^firmware:\s*$", text, re.M):
        text = re.sub(r"^firmware:\s*$", "firmware:\n  drift_filter: kalman", text, count=1, flags=re.M)
    else:
        text += "\nfirmware:\n  drift_filter: kalman\n"
    for name in os.listdir(os.path.dirname(src)):   # calibration/: the scene's include
        if os.path.isdir(os.path.join(os.path.dirname(src), name)):
            shutil.copytree(os.path.join(os.path.dirname(src), name), os.path.join(folder, name), dirs_exist_ok=True)
    path = os.path.join(folder, "long.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def report_alone(out):
    """(wall s, peak MB over the process tree) of analysis.run_report on `out`."""
    t0 = time.monotonic()
    p = subprocess.Popen([sys.executable, "-m", "analysis.run_report", out, "--out", os.path.join(out, "report.bench.html")],
                         cwd=paths.ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    peak = 0
    while p.poll() is None:
        peak = max(peak, tree_rss_kb(p.pid))
        time.sleep(0.005)
    wall = time.monotonic() - t0
    if p.returncode != 0:
        raise RuntimeError(f"run_report {out}: exit {p.returncode}: {p.stderr.read().decode()[-300:]}")
    return wall, peak / 1024


def recorded_span(out, duration_s):
    """(first, last) recording time of the log's blocks, s since the epoch."""
    from analysis import report_series
    s = report_series.read(os.path.join(out, "bus.lcmlog"), duration_s)
    return s.recorded[0] * 1e-6, s.recorded[1] * 1e-6


def one_run(scene, out):
    """The figures of one ./afm run of `scene` into `out`."""
    times = out + ".times"
    if os.path.exists(times):
        os.remove(times)
    env = dict(os.environ, AFM_TIMES=times)
    t0 = time.time()
    p = subprocess.run([os.path.join(paths.ROOT, "afm"), "run", scene, "--out", out, "--no-verdict"], env=env,
                       cwd=paths.ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    whole = time.time() - t0
    if p.returncode != 0:
        raise RuntimeError(f"./afm run {scene}: exit {p.returncode}: {p.stderr[-500:]}")
    with open(times) as f:
        mark = {k: float(v) for k, v in (line.split() for line in f)}
    with open(os.path.join(out, "run.json")) as f:
        info = json.load(f)
    first, last = recorded_span(out, info.get("sim_seconds"))
    parts = {"build check": mark["built"] - mark["begin"], "start": first - mark["built"], "loop": last - first,
             "end": mark["launched"] - last, "report": mark["reported"] - mark["launched"]}
    r_wall, r_mb = report_alone(out)
    parts["outside the launcher"] = mark["launched"] - mark["built"] - info["wall_seconds"]
    return {"prompt to prompt": whole, **parts, "launcher loop_seconds": info["timing"]["loop_seconds"],
            "run wall_seconds": info["wall_seconds"], "report alone": r_wall, "report peak MB": r_mb}


def show(name, values, unit, goal=None, met=None):
    med = statistics.median(values)
    spread = f" (range {min(values):.2f}-{max(values):.2f})" if len(values) > 1 else ""
    tail = "" if goal is None else f"   goal {goal}: {'met' if met(med) else 'NOT met'}"
    print(f"  {name:24s} {med:9.2f} {unit}{spread}{tail}")


def show_scene(name, col):
    """The lines of one scene: its parts, and the goals it has."""
    loop = statistics.median(col["loop"])
    goal = {"demo": (f"<= {DEMO_S:g} s", lambda v: v <= DEMO_S),
            "pattern": (f"<= {PATTERN_LOOPS:g} x loop ({PATTERN_LOOPS * loop:.1f} s)", lambda v: v <= PATTERN_LOOPS * loop)}
    show("prompt to prompt", col["prompt to prompt"], "s", *goal.get(name, ()))
    for part in PARTS[:-1]:
        show("  " + part, col[part], "s")
    show("    (loop_seconds)", col["launcher loop_seconds"], "s")
    show("    (launcher's own)", col["run wall_seconds"], "s")
    show("    (start+end outside it)", col["outside the launcher"], "s")
    wall = statistics.median(col["run wall_seconds"])
    limit = max(REPORT_S, REPORT_FRACTION * wall)
    show("  report", col["report"], "s", f"<= {limit:.2f} s (10 % of the run's {wall:.1f} s, or 1 s)", lambda v: v <= limit)
    show("report alone", col["report alone"], "s")   # its imports too, which ./afm run's --wait hides
    show("report peak (tree RSS)", col["report peak MB"], "MB", f"<= {REPORT_MB} MB", lambda v: v <= REPORT_MB)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="./afm bench run", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--repeat", type=int, default=1, help="runs of each scene (the figures' median and range)")
    ap.add_argument("--only", choices=sorted(SCENES), action="append", help="this scene only (repeatable)")
    ap.add_argument("--out", help="keep the runs in this folder (default: a temporary one, removed)")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error(f"--repeat: {a.repeat}: give 1 or more")
    folder, kept = paths.bench_folder(a.out, "afm-bench-run-")
    for name in a.only or list(SCENES):
        scene = long_scene(folder) if name == "long" else os.path.join(paths.ROOT, SCENES[name])
        runs = [one_run(scene, os.path.join(folder, f"{name}-{k}")) for k in range(a.repeat)]
        print(f"{name} ({SCENES[name]}{', firmware.drift_filter: kalman' if name == 'long' else ''}), {a.repeat} run(s):")
        show_scene(name, {k: [r[k] for r in runs] for k in runs[0]})
    if not kept:
        subprocess.run(["rm", "-rf", "--", folder], check=False)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except RuntimeError as e:
        print(f"bench run: {e}", file=sys.stderr)
        sys.exit(1)
