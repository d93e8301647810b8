"""./afm bench sweep: the sweep engine's parallel efficiency. The same 8
points (the short scene at ADC widths 9 to 16) run on one Dask worker and
on two, into fresh folders; efficiency = T(1 worker) / (2 T(2 workers)).
A benchmark: it prints figures and asserts nothing."""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from analysis import paths


def run(workers, out, scene, callgrind):
    args = [sys.executable, "-m", "analysis.sweep", scene, "--vary", "firmware.adc_bits=9,10,11,12,13,14,15,16",
            "--out", out, "--workers", str(workers)]
    if not callgrind:
        args.append("--no-callgrind")
    t0 = time.monotonic()
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"bench sweep: the sweep with {workers} worker(s) failed:\n{p.stderr[-2000:]}")
    total = time.monotonic() - t0
    with open(os.path.join(out, "sweep.json")) as f:
        points = json.load(f)["points_wall_s"]
    return total, points


def main(argv):
    ap = argparse.ArgumentParser(prog="./afm bench sweep",
                                 description="Parallel efficiency of ./afm sweep: 8 points on 1 worker and on 2.")
    ap.add_argument("--scene", default=os.path.join(paths.ROOT, "scenes", "short.yaml"))
    ap.add_argument("--callgrind", action="store_true", help="also count the firmware's instructions per point")
    a = ap.parse_args(argv)
    tmp = tempfile.mkdtemp(prefix="afm-bench-sweep-")
    os.chmod(tmp, 0o755)   # started as root, the runs are the run's user (run/run_user.sh), who must reach it
    try:
        print(f"bench sweep: 8 points of {os.path.basename(a.scene)} (firmware.adc_bits 9..16), "
              f"{'with' if a.callgrind else 'without'} callgrind, {os.cpu_count()} cores", file=sys.stderr)
        t1 = run(1, os.path.join(tmp, "one"), a.scene, a.callgrind)
        t2 = run(2, os.path.join(tmp, "two"), a.scene, a.callgrind)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{'workers':>8} | {'points s':>9} | {'s per point':>11} | {'whole sweep s':>13}")
    print(f"{1:>8} | {t1[1]:9.1f} | {t1[1] / 8:11.2f} | {t1[0]:13.1f}")
    print(f"{2:>8} | {t2[1]:9.1f} | {t2[1] / 8:11.2f} | {t2[0]:13.1f}")
    print(f"parallel efficiency of the points, T1 / (2 T2) = {t1[1] / (2.0 * t2[1]):.2f} (goal: at least 0.75 on 2 cores)")
    print(f"the whole command, T1 / (2 T2) = {t1[0] / (2.0 * t2[0]):.2f} (adds the serial parts: starting the local "
          "cluster, checking every point, writing the plots and the report)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
