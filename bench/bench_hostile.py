"""./afm bench hostile: what a flood of fragment headers costs a run (issue 35,
"cheap floods stay cheap"). The scene runs ROUNDS times undisturbed and
ROUNDS times with faults/hostile.py sending fragment-0 headers that each
claim a 16 MiB message, at RATE datagrams a second from before the start to
the end, alternately, so that the machine's load falls on both alike. Each
run's wall time and its processes' peak memory come from its own run.json.

Goals: the flood adds under 10 % to the median wall time, and under 50 MB
to any process's peak memory (median over the rounds). A benchmark: it
prints figures and a verdict line, and exits 0 whatever they are (exit 2
only if a run fails)."""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile

from analysis import paths

sys.path.insert(0, paths.FAULTS_DIR)
import hostile  # noqa: E402  (faults/hostile.py: the sender and the one runner beside a run)

WALL_GOAL = 0.10     # the flood's share of the calm median wall time
RSS_GOAL_MB = 50.0   # the flood's addition to a process's peak memory


def peaks_mb(rj):
    """{process: peak resident MB} of a run, the launcher's included."""
    out = {p["name"]: p["max_rss_kb"] / 1024.0 for p in rj["processes"]}
    out["afm_launch"] = rj["launcher"]["max_rss_kb"] / 1024.0
    return out


def cpu_s(rj):
    """CPU seconds (user + system) of the run's four bus processes (run.json
    holds no CPU figure of the launcher's own: children_cpu_s covers it)."""
    return sum(p["cpu_user_s"] + p["cpu_system_s"] for p in rj["processes"])


def children_cpu_s():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def one(launch, scene, out, rate, flood):
    """(wall s, {process: peak MB}, headers sent, the run's CPU s, all CPU s under the command: the sender's too)."""
    c0 = children_cpu_s()
    if flood:
        code, err, rj, sent = hostile.run_beside(launch, scene, out, rate=rate, kinds="fragment_claim")
    else:
        code, err, rj, sent = run_calm(launch, scene, out)
    if code != 0:
        sys.exit(f"bench hostile: the {'flooded' if flood else 'calm'} run in {out} failed (exit {code}):\n{err[-1500:]}")
    return rj["wall_seconds"], peaks_mb(rj), (sent or {}).get("total", 0), cpu_s(rj), children_cpu_s() - c0


def run_calm(launch, scene, out):
    """The run alone in its namespace, as ./afm run makes it."""
    p = subprocess.run([paths.IN_NETNS, launch, "--scene", scene, "--out", out, "--quiet"],
                       capture_output=True, text=True, timeout=400)
    with open(os.path.join(out, "run.json")) as f:
        return p.returncode, p.stderr, json.load(f), None


def main(argv):
    ap = argparse.ArgumentParser(prog="./afm bench hostile", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--scene", default=os.path.join(paths.ROOT, "scenes", "default.yaml"))
    ap.add_argument("--rounds", type=int, default=3, help="calm and flooded runs each (default 3)")
    ap.add_argument("--rate", type=float, default=2000.0, help="fragment headers a wall second (default 2000)")
    a = ap.parse_args(argv)
    if a.rounds < 1:
        sys.exit(f"bench hostile: --rounds must be at least 1, not {a.rounds}")
    if not a.rate > 0:
        sys.exit(f"bench hostile: --rate must be above 0, not {a.rate}")
    launch = paths.LAUNCH
    tmp = tempfile.mkdtemp(prefix="afm-bench-hostile-")
    os.chmod(tmp, 0o755)   # started as root, the runs are the run's user (run/run_user.sh), who must reach it
    calm, flood = [], []
    try:
        print(f"bench hostile: {os.path.basename(a.scene)}, {a.rounds} calm and {a.rounds} flooded runs "
              f"({a.rate:.0f} headers/s claiming 16 MiB each), {os.cpu_count()} cores", file=sys.stderr)
        for i in range(a.rounds):
            calm.append(one(launch, a.scene, os.path.join(tmp, f"calm{i}"), a.rate, False))
            flood.append(one(launch, a.scene, os.path.join(tmp, f"flood{i}"), a.rate, True))
            print(f"  round {i + 1}/{a.rounds}: calm {calm[-1][0]:.2f} s, flooded {flood[-1][0]:.2f} s "
                  f"({flood[-1][2]} headers)", file=sys.stderr)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    report(calm, flood)
    return 0


def report(calm, flood):
    w0 = statistics.median(r[0] for r in calm)
    w1 = statistics.median(r[0] for r in flood)
    print(f"{'':>12} | {'wall s, median':>14} | {'min':>6} | {'max':>6}")
    for name, rows in (("calm", calm), ("flooded", flood)):
        ws = [r[0] for r in rows]
        print(f"{name:>12} | {statistics.median(ws):14.2f} | {min(ws):6.2f} | {max(ws):6.2f}")
    added = (w1 - w0) / w0
    c0, c1 = statistics.median(r[3] for r in calm), statistics.median(r[3] for r in flood)
    a0, a1 = statistics.median(r[4] for r in calm), statistics.median(r[4] for r in flood)
    print(f"CPU s of the run's processes, median: calm {c0:.2f}, flooded {c1:.2f} ({100 * (c1 - c0) / c0:+.1f} %); "
          f"all CPU under the command, the sender's included: {a0:.2f} and {a1:.2f}")
    print(f"the flood adds {100 * added:+.1f} % to the median wall time (goal: under {100 * WALL_GOAL:.0f} %)")
    worst_name, worst = None, -1e9
    print(f"{'process':>12} | {'peak MB calm':>12} | {'flooded':>8} | {'added':>6}")
    for name in sorted(calm[0][1]):
        m0 = statistics.median(r[1].get(name, 0.0) for r in calm)
        m1 = statistics.median(r[1].get(name, 0.0) for r in flood)
        print(f"{name:>12} | {m0:12.1f} | {m1:8.1f} | {m1 - m0:+6.1f}")
        if m1 - m0 > worst:
            worst_name, worst = name, m1 - m0
    ok = added < WALL_GOAL and worst < RSS_GOAL_MB
    print(f"verdict: {'goals met' if ok else 'GOAL MISSED'}: wall {100 * added:+.1f} % (under {100 * WALL_GOAL:.0f} %), "
          f"peak memory at most {worst:+.1f} MB ({worst_name}; under {RSS_GOAL_MB:.0f} MB)")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
