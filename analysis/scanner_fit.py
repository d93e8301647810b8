"""The scanner's compensation fitted on the host (issue 48, item 2): the
direct Prandtl-Ishlinskii (PI) model of a scanner axis from a measured
loop, in the form the card takes (firmware/include/fw_hyst.h), and the
table of first-order terms fw_creep.c approximates the log creep law with.

    python -m analysis.scanner_fit LOOP.csv [--plays N] [--json]

A loop file is CSV with a header line and the columns
  commanded_pm  the piezo's command along the axis, pm (frame A)
  measured_pm   the position a grating's scan registers at that command, pm
in the order the loop was driven (a PI model has memory: the order is the
data). The fit:

  thresholds  r_i = i R / N, i = 0 .. N-1, R the largest |command - origin|,
              origin the middle of the commanded range (the card's model is
              about its origin, every play 0 there);
  weights     non-negative least squares (scipy.optimize.nnls) of the
              measured position on the N plays' outputs and an offset (two
              non-negative columns, +1 and -1), the plays started at 0 at the
              origin as the card's are.

The card forms the inverse itself (fw_hyst_init, Kuhnen's formulas) and
checks the model's domain there (fw_hyst_check: every partial sum of the
weights in [1/2, 2]); card_params gives the integers it takes, and the fit's
partial sums, so that a caller can say why the card would refuse a fit.
"""
import argparse
import csv
import json
import sys

import numpy as np
from scipy.optimize import linprog, minimize, nnls

Q24 = 1 << 24


def play(x, r, z0=0.0):
    """The play operator of threshold r on the sequence x, from state z0."""
    z = float(z0)
    out = np.empty(len(x))
    for k, xk in enumerate(x):
        z = min(max(z, xk - r), xk + r)
        out[k] = z
    return out


def plays(x, r):
    """Every play's output (len(x) x len(r)), each started at 0."""
    x = np.asarray(x, dtype=float)
    return np.column_stack([play(x, ri) for ri in r])


def pi_model(x, r, w):
    """The direct PI model's output for the sequence x."""
    return plays(x, r) @ np.asarray(w, dtype=float)


def fit_pi(commanded_pm, measured_pm, n_plays=8, origin_pm=None):
    """The direct PI model of a loop: a dict with origin_pm, range_pm,
    r_pm (thresholds), w (weights), offset_pm (measured - model at the
    origin), rms_pm and worst_pm (the fit's residual)."""
    x = np.asarray(commanded_pm, dtype=float)
    y = np.asarray(measured_pm, dtype=float)
    if x.shape != y.shape or x.ndim != 1 or len(x) < 2 * n_plays:
        raise ValueError(f"fit_pi: need two equal 1-d series of at least {2 * n_plays} samples, got {x.shape} and {y.shape}")
    if n_plays < 1:
        raise ValueError(f"fit_pi: n_plays must be >= 1, got {n_plays}")
    origin = 0.5 * (x.min() + x.max()) if origin_pm is None else float(origin_pm)
    R = float(np.max(np.abs(x - origin)))
    if R <= 0:
        raise ValueError("fit_pi: the command does not move")
    r = np.arange(n_plays) * R / n_plays
    F = plays(x - origin, r)
    A = np.column_stack([F, np.ones(len(x)), -np.ones(len(x))])
    sol, _ = nnls(A, y - origin)
    w = sol[:n_plays]
    offset = sol[n_plays] - sol[n_plays + 1]
    res = F @ w + offset - (y - origin)
    return {"origin_pm": origin, "range_pm": R, "r_pm": r.tolist(), "w": w.tolist(), "offset_pm": float(offset),
            "rms_pm": float(np.sqrt(np.mean(res ** 2))), "worst_pm": float(np.max(np.abs(res)))}


def loop_from_branch(commanded_pm, measured_pm, origin_pm, half_range_pm=None, points=400):
    """The whole loop of a PI scanner from one ascending branch of its full
    cycle about origin_pm (commanded rising from origin - R to origin + R
    after a fall from origin + R, as a scan's trace line is): (commanded,
    measured) in the order a virgin scanner at the origin would be driven,
    up to origin + R, down to origin - R, up again. A PI model's loop is
    point-symmetric and its branches follow from its first loading curve v:
    ascending a(u) = -v(R) + 2 v((u + R) / 2), descending d(u) = -a(-u),
    first loading v(s) = (a(2 s - R) + v(R)) / 2, v(R) = (a(R) - a(-R)) / 2,
    u about the origin, a centred by (a(R) + a(-R)) / 2 (the offset the fit
    takes back). The branch is interpolated linearly between its points
    (increasing commanded) and extended by its end segments to +-R, R the
    cycle's half range (half_range_pm: the command's turning points, which
    the registered points need not reach; None: the largest |commanded -
    origin|)."""
    x = np.asarray(commanded_pm, dtype=float) - origin_pm
    y = np.asarray(measured_pm, dtype=float)
    if x.shape != y.shape or x.ndim != 1 or len(x) < 4 or np.any(np.diff(x) <= 0):
        raise ValueError(f"loop_from_branch: need at least 4 points of increasing command, got {x.shape} and {y.shape}")
    R = float(np.max(np.abs(x))) if half_range_pm is None else float(half_range_pm)

    def branch(u):   # linear inside, the end segments' lines outside
        u = np.asarray(u, dtype=float)
        out = np.interp(u, x, y)
        lo, hi = u < x[0], u > x[-1]
        out[lo] = y[0] + (u[lo] - x[0]) * (y[1] - y[0]) / (x[1] - x[0])
        out[hi] = y[-1] + (u[hi] - x[-1]) * (y[-1] - y[-2]) / (x[-1] - x[-2])
        return out
    mid = 0.5 * (branch([R])[0] + branch([-R])[0])
    vR = 0.5 * (branch([R])[0] - branch([-R])[0])
    s = np.linspace(0.0, R, points)
    virgin = 0.5 * (branch(2 * s - R) - mid + vR)
    u = np.linspace(R, -R, 2 * points)
    down = -(branch(-u) - mid)
    up = branch(u[::-1]) - mid
    cmd = np.concatenate([s, u, u[::-1]]) + origin_pm
    meas = np.concatenate([virgin, down, up]) + mid
    return cmd, meas


def ascending(n):
    """The slice of loop_from_branch's sequence of n points that is its
    last ascending branch (its last 2/5)."""
    return slice(n - 2 * n // 5, n)


def fit_branch(commanded_pm, measured_pm, origin_pm, n_plays=16, half_range_pm=None):
    """fit_pi on the loop loop_from_branch makes of an ascending branch, its
    thresholds over the branch's half range; the fit's residual is taken
    again on the branch's own points (rms_pm, worst_pm)."""
    cmd, meas = loop_from_branch(commanded_pm, measured_pm, origin_pm, half_range_pm)
    fit = fit_pi(cmd, meas, n_plays, origin_pm=origin_pm)
    model = pi_model(cmd - origin_pm, fit["r_pm"], fit["w"]) + fit["offset_pm"] + origin_pm
    up = ascending(len(cmd))
    at = np.interp(np.asarray(commanded_pm, dtype=float), cmd[up], model[up])
    res = at - np.asarray(measured_pm, dtype=float)
    fit.update(rms_pm=float(np.sqrt(np.mean(res ** 2))), worst_pm=float(np.max(np.abs(res))), points=len(res))
    return fit


def card_params(fit):
    """The card's fw_hyst_params_t fields (integers) and the partial sums of
    the weights fw_hyst_check tests."""
    return {"n": len(fit["r_pm"]), "r_pm": [int(round(v)) for v in fit["r_pm"]],
            "w_q24": [int(round(v * Q24)) for v in fit["w"]], "range_pm": int(round(fit["range_pm"])),
            "origin_pm": int(round(fit["origin_pm"])), "partial_sums": np.cumsum(fit["w"]).tolist()}


def inverse_pi(r, w):
    """Kuhnen's inverse of a PI model (thresholds r, weights w): (r', w')."""
    r = np.asarray(r, dtype=float)
    w = np.asarray(w, dtype=float)
    W = np.cumsum(w)
    ri = np.array([np.sum(w[:i + 1] * (r[i] - r[:i + 1])) for i in range(len(r))])
    wi = np.empty(len(w))
    wi[0] = 1.0 / w[0]
    wi[1:] = 1.0 / W[1:] - 1.0 / W[:-1]
    return ri, wi


def _creep_minimax(tau, t, L):
    """The weights minimising max |sum_k c_k (1 - exp(-t / tau_k)) - L| (a
    linear programme) and that maximum."""
    A = 1.0 - np.exp(-t[:, None] / tau[None, :])
    K = len(tau)
    cost = np.r_[np.zeros(K), 1.0]
    A_ub = np.r_[np.c_[A, -np.ones(len(t))], np.c_[-A, -np.ones(len(t))]]
    res = linprog(cost, A_ub=A_ub, b_ub=np.r_[L, -L], bounds=[(-5, 5)] * K + [(0, None)])
    return res.x[-1], res.x[:K]


def creep_terms(k=4, decades=3.0, points=1500):
    """fw_creep.c's table: time constants rho_k (in t0) and weights c_k whose
    sum of first-order terms is the minimax fit of log10(t / t0) over
    [t0, 10^decades t0]; returns (rho, c, max error)."""
    t = np.logspace(0.0, decades, points)
    L = np.log10(t)
    start = np.log(np.logspace(-1.0, decades - 0.5, k))
    res = minimize(lambda p: _creep_minimax(np.exp(p), t, L)[0], start, method="Nelder-Mead",
                   options={"maxiter": 4000, "xatol": 1e-7, "fatol": 1e-10})
    rho = np.exp(res.x)
    err, c = _creep_minimax(rho, t, L)
    return rho, c, err


def read_loop(path):
    """(commanded_pm, measured_pm) of a loop file (the module's docstring)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for col in ("commanded_pm", "measured_pm"):
        if not rows or col not in rows[0]:
            raise ValueError(f"{path}: no column {col} (the columns are commanded_pm, measured_pm)")
    out = []
    for i, row in enumerate(rows, start=2):
        try:
            out.append((float(row["commanded_pm"]), float(row["measured_pm"])))
        except ValueError:
            raise ValueError(f"{path}: line {i}: not a number: {row}") from None
    a = np.array(out)
    return a[:, 0], a[:, 1]


def main(argv=None):
    ap = argparse.ArgumentParser(prog="scanner_fit", description="The direct PI model of a scanner axis from a loop.")
    ap.add_argument("loop", help="CSV with commanded_pm, measured_pm")
    ap.add_argument("--plays", type=int, default=8, help="play operators (1..16, fw_hyst.h)")
    ap.add_argument("--json", action="store_true", help="print the fit and the card's integers as JSON")
    a = ap.parse_args(argv)
    try:
        x, y = read_loop(a.loop)
        fit = fit_pi(x, y, a.plays)
    except (OSError, ValueError) as e:
        print(f"scanner_fit: {e}", file=sys.stderr)
        return 2
    card = card_params(fit)
    if a.json:
        print(json.dumps({"fit": fit, "card": card}, indent=1))
    else:
        print(f"origin {fit['origin_pm']:.0f} pm, range +-{fit['range_pm']:.0f} pm, {card['n']} plays; "
              f"residual rms {fit['rms_pm']:.0f} pm, worst {fit['worst_pm']:.0f} pm")
        for ri, wi in zip(fit["r_pm"], fit["w"]):
            print(f"  r {ri:12.0f} pm  w {wi:.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
