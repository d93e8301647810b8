"""Friction loops to the tilted-surface calibration (physics.md section 2,
eq. 16-17), from a researcher's own files or from the bench's runs.

    ./afm calib tilted --loops LOOP.csv LOOP.csv LOOP.csv ... \\
        --angle-deg PHI --spring-N-per-m K_N --deflection-nm-per-V K_N_V [--write FILE] [--json]

A loop file is one friction loop at one set point, as CSV with a header
line and these columns (others are ignored):
  s_n_V      the normal photodiode signal S_n, volts
  s_l_V      the lateral photodiode signal S_l, volts
  direction  up or down: the pass going up or down the tilted facet
Each row is a sample from the middle of a pass (leave the turnarounds out).
Per file the mean S_n and S_l of each direction make one point of each
line; at least 3 files (set points) are needed. The slopes r_u = dS_l/dS_n
(up) and r_d (down) are fitted by least squares with their standard errors,
and the firmware's own solver (afm_calc calib tilted) turns them into mu and
k_theta K_l / h; their uncertainty is propagated from the slopes' (first
order, the solver's derivatives by central differences). --write FILE
writes the scene include as afm_calc does."""
import argparse
import csv
import json
import math
import os
import subprocess
import sys

import numpy as np

MIN_LOOPS = 3


class LoopError(Exception):
    pass


def read_loop(path):
    """(mean S_n up, mean S_l up, mean S_n down, mean S_l down) of one loop file."""
    if not os.path.isfile(path):
        raise LoopError(f"{path}: not a file")
    acc = {"up": [], "down": []}
    with open(path, newline="") as f:
        rows = csv.DictReader(f)
        missing = [c for c in ("s_n_V", "s_l_V", "direction") if c not in (rows.fieldnames or [])]
        if missing:
            raise LoopError(f"{path}: line 1: missing column(s) {', '.join(missing)} (have: {', '.join(rows.fieldnames or [])})")
        for i, r in enumerate(rows, start=2):
            d = (r["direction"] or "").strip()
            if d not in acc:
                raise LoopError(f"{path}: line {i}: direction must be up or down, got {d[:20]!r}")
            try:
                sn, sl = float(r["s_n_V"]), float(r["s_l_V"])
            except (TypeError, ValueError):
                raise LoopError(f"{path}: line {i}: s_n_V and s_l_V must be numbers, got {str(r['s_n_V'])[:20]!r}, "
                                f"{str(r['s_l_V'])[:20]!r}") from None
            if not (math.isfinite(sn) and math.isfinite(sl)):
                raise LoopError(f"{path}: line {i}: not finite: s_n_V {sn}, s_l_V {sl}")
            acc[d].append((sn, sl))
    for d, v in acc.items():
        if len(v) < 2:
            raise LoopError(f"{path}: {len(v)} sample(s) going {d}: a loop needs both passes")
    up, down = np.array(acc["up"]), np.array(acc["down"])
    return up[:, 0].mean(), up[:, 1].mean(), down[:, 0].mean(), down[:, 1].mean()


def fit_line(x, y):
    """Least squares y = r x + b: (r, b, the standard error of r; None with
    only two points)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    (r, b) = np.polyfit(x, y, 1)
    if len(x) < 3:
        return float(r), float(b), None
    resid = y - (r * x + b)
    sxx = float(np.sum((x - x.mean()) ** 2))
    se = math.sqrt(float(np.sum(resid ** 2)) / (len(x) - 2) / sxx) if sxx > 0 else float("inf")
    return float(r), float(b), se


def fit_slopes(means):
    """The loops' means (one 4-tuple per set point) to r_u and r_d with
    their intercepts and standard errors: {'up': (r, b, se), 'down': ...}."""
    m = np.array(means, float)
    if len(m) >= 2 and np.ptp(m[:, 0]) <= 0:
        raise LoopError("every loop has the same S_n: the slopes need loops at different set points")
    return {"up": fit_line(m[:, 0], m[:, 1]), "down": fit_line(m[:, 2], m[:, 3])}


def solve(calc, ru, rd, phi, kn, Kn, write=None):
    args = [calc, "calib", "tilted", "--up", f"{ru:.8f}", "--down", f"{rd:.8f}", "--angle-deg", f"{phi:.6f}",
            "--spring-N-per-m", f"{kn:.8f}", "--deflection-nm-per-V", f"{Kn:.6f}", "--json"]
    if write:
        args += ["--write", write]
    p = subprocess.run(args, capture_output=True, text=True, timeout=60)
    if p.returncode != 0:
        raise LoopError(f"afm_calc calib tilted (r_u {ru:.6f}, r_d {rd:.6f}): {p.stderr.strip()}")
    return json.loads(p.stdout)


def calibrate(calc, files, phi, kn, Kn, write=None):
    if len(files) < MIN_LOOPS:
        raise LoopError(f"--loops: {len(files)} file(s); at least {MIN_LOOPS} set points are needed for the slopes and their errors")
    means = [read_loop(f) for f in files]
    fit = fit_slopes(means)
    (ru, bu, su), (rd, bd, sd) = fit["up"], fit["down"]
    sol = solve(calc, ru, rd, phi, kn, Kn, write)
    # first-order propagation: the solver's derivatives by central differences
    sigma = {}
    for key in ("mu", "lateral_nN_per_V"):
        var = 0.0
        for i, (r, s) in enumerate(((ru, su), (rd, sd))):
            h = max(abs(r) * 1e-3, 1e-6)
            a = solve(calc, ru + h if i == 0 else ru, rd + h if i == 1 else rd, phi, kn, Kn)[key]
            b = solve(calc, ru - h if i == 0 else ru, rd - h if i == 1 else rd, phi, kn, Kn)[key]
            var += ((a - b) / (2 * h) * s) ** 2
        sigma[key] = math.sqrt(var)
    return {"loops": len(files), "r_u": ru, "r_u_se": su, "r_d": rd, "r_d_se": sd, "intercept_up_V": bu,
            "intercept_down_V": bd, "mu": sol["mu"], "mu_se": sigma["mu"], "lateral_nN_per_V": sol["lateral_nN_per_V"],
            "lateral_nN_per_V_se": sigma["lateral_nN_per_V"], "solver": sol}


def main(argv=None):
    from analysis import helptext
    ap = argparse.ArgumentParser(prog="./afm calib tilted --loops", formatter_class=argparse.RawDescriptionHelpFormatter,
                                 description=helptext.text("calib") + "\n\n" + __doc__.split("\n\n")[0],
                                 epilog="the file format: docs/data.md, 'Friction loops in'")
    ap.add_argument("--loops", nargs="+", required=True, metavar="FILE", help="one CSV friction loop per set point")
    ap.add_argument("--angle-deg", type=float, required=True, help="the facet's slope phi, degrees")
    ap.add_argument("--spring-N-per-m", type=float, required=True, help="k_n, N/m")
    ap.add_argument("--deflection-nm-per-V", type=float, required=True, help="K_n, nm/V")
    ap.add_argument("--write", help="write the scene include (firmware.lateral_nN_per_V, firmware.mu)")
    ap.add_argument("--json", action="store_true", help="the answer as JSON")
    ap.add_argument("--calc", default=os.environ.get("AFM_CALC", ""), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if not a.calc or not os.path.exists(a.calc):
        print(f"calib tilted --loops: the calculator is not built ({a.calc or 'AFM_CALC unset'}); run ./afm build", file=sys.stderr)
        return 2
    try:
        r = calibrate(a.calc, a.loops, a.angle_deg, a.spring_N_per_m, a.deflection_nm_per_V, a.write)
    except LoopError as e:
        print(f"calib tilted --loops: {e}", file=sys.stderr)
        return 2
    if a.json:
        print(json.dumps(r, indent=1))
        return 0
    se = lambda v: "-" if v is None else f"{v:.6f}"
    print(f"calib tilted: {r['loops']} loops; r_u = {r['r_u']:.6f} +- {se(r['r_u_se'])}, r_d = {r['r_d']:.6f} +- {se(r['r_d_se'])}")
    print(f"calib tilted: mu = {r['mu']:.5f} +- {r['mu_se']:.5f}; k_theta K_l / h = {r['lateral_nN_per_V']:.3f} +- "
          f"{r['lateral_nN_per_V_se']:.3f} nN/V (one standard error, from the slopes' fit)")
    if a.write:
        print(f"calib tilted: wrote {a.write}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
