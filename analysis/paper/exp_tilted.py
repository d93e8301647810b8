"""Friction loops at scan angle 270 on glass tilted by 9 degrees, at several
set points, up and down the slope. The slopes dS_l/dS_n are fitted from the
simulated photodiode signals (the mid part of every pass, away from the
turnarounds), the slope angle from a plane fitted to the run's own initial
scan, k_n K_n from the card's configuration; the firmware's
fw_calib_tilted_solve (afm_calc calib tilted) gives mu and k_theta K_l / h."""
import math

import numpy as np

from analysis import loops
from analysis.units import show
from analysis.paper import common

NAME = "tilted"
TITLE = "Lateral calibration on tilted glass"
FIGURES = "figs. 5-6"

LOADS_NN = {"full": [5, 10, 15, 20, 25], "reduced": [5, 15, 25]}
MID_NM = 200          # |y| below this: the middle of a 600 nm pass
MOVING_NM_PER_S = 1500


def runs(size):
    return [common.Run(name=f"load_{L}nN", scene="tilted.yaml", settings={"operator.load_nN": L}, cost_s=6)
            for L in LOADS_NN[size]]


def loop_means(run_dir):
    """Mean S_n, S_l (V) uphill (moving -y) and downhill, mid-pass; and the
    signals for the figure."""
    a, fs = common.analog(run_dir)
    v = np.gradient(a["y_nm"]) * fs
    mid = np.abs(a["y_nm"]) < MID_NM
    up, down = (v < -MOVING_NM_PER_S) & mid, (v > MOVING_NM_PER_S) & mid
    if up.sum() < 100 or down.sum() < 100:
        raise common.PaperError(f"{run_dir}: too few mid-pass samples ({up.sum()} up, {down.sum()} down)")
    return (a["sn_v"][up].mean(), a["sl_v"][up].mean(), a["sn_v"][down].mean(), a["sl_v"][down].mean()), a


def slope_deg(run_dir):
    """The surface's slope from a plane fitted to the initial scan."""
    h, xs, ys = common.scan(run_dir, "scan_initial")
    X, Y = np.meshgrid(xs, ys)
    A = np.column_stack([X.ravel(), Y.ravel(), np.ones(X.size)])
    (gx, gy, _), *_ = np.linalg.lstsq(A, h.ravel(), rcond=None)
    return math.degrees(math.atan(math.hypot(gx, gy)))


def analyse(dirs, exp_dir, size):
    loads = LOADS_NN[size]
    means, signals = {}, {}
    for L in loads:
        means[L], signals[L] = loop_means(dirs[f"load_{L}nN"])
    snu, slu, snd, sld = (np.array([means[L][i] for L in loads]) for i in range(4))
    fit = loops.fit_slopes([means[L][:4] for L in loads])   # the one slope fit (./afm calib tilted --loops)
    (ru, bu, _), (rd, bd, _) = fit["up"], fit["down"]
    first = dirs[f"load_{loads[0]}nN"]
    phi = slope_deg(first)
    card = common.run_json(first)["card"]
    kn_Kn = card["normal_gain_pn_per_v"] * 1e-3                     # nN/V
    kn = card["normal_gain_pn_per_v"] / card["deflection_pm_per_v"]   # N/m
    Kn = card["deflection_pm_per_v"] * 1e-3                         # nm/V
    sol = common.calc("calib", "tilted", "--up", f"{ru:.6f}", "--down", f"{rd:.6f}", "--angle-deg", f"{phi:.4f}",
                      "--spring-N-per-m", f"{kn:.6f}", "--deflection-nm-per-V", f"{Kn:.4f}")

    truth = common.truth(first)
    mu_t = truth["sample"]["tip_substrate"]["mu"]
    lat_t = common.probe_value(truth, "lateral_nN_per_V")
    phi_t = truth["sample"]["slope_deg"]
    a_t = kn_Kn / lat_t
    b_t = math.atan(mu_t)
    ru_t = a_t * math.tan(math.radians(phi_t) + b_t)
    rd_t = a_t * math.tan(math.radians(phi_t) - b_t)

    res = common.Result()
    res.rows = [
        common.Row("uphill slope r_u = dS_l/dS_n", "", key="tilted.r_u", paper=0.07, bench=ru, truth=ru_t,
                   note=f"fitted over {len(loads)} set points; truth: eq. 16 with the simulator's mu and lever"),
        common.Row("downhill slope r_d", "", key="tilted.r_d", paper=0.02, bench=rd, truth=rd_t,
                   note="eq. 17; small, so its relative error is the larger"),
        common.Row("slope of the glass phi", "deg", key="tilted.phi", paper=9.0, bench=phi, truth=phi_t,
                   note="plane fitted to the run's initial scan (the paper's 8.98 matches its 0.086 and 37.8)"),
        common.Row("mu (tip-substrate): the calibration against the truth's", "", key="tilted.mu", paper=0.086,
                   model=sol["mu"], truth=mu_t,
                   note="fw_calib_tilted_solve on the measured slopes; the simulator's friction is Amontons with a "
                        "constant adhesion offset, the law the calibration inverts (./afm paper --truth seeded draws it "
                        "hidden)"),
        common.Row("k_theta K_l / h: the calibration against the truth's", "nN/V", key="tilted.lateral", paper=37.8,
                   model=sol["lateral_nN_per_V"], truth=lat_t, note="fw_calib_tilted_solve; the same law"),
    ]
    res.notes.append(f"k_n K_n = {show(kn_Kn, 'nN/V')} from the card's configuration (run.json); intercepts {show(bu, 'V')} up, "
                     f"{show(bd, 'V')} down (adhesion shifts the loops, not the slopes)")
    res.figures = [("Friction loops: S_l against the piezo's y at each set point", plot_loops(exp_dir, signals, loads)),
                   ("Mid-pass S_l against S_n, up and down the slope, with the fitted lines",
                    plot_fit(exp_dir, snu, slu, snd, sld, (ru, bu), (rd, bd)))]
    return res


def plot_loops(exp_dir, signals, loads):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 4.2))
    for L in loads:
        a = signals[L]
        k = slice(len(a["y_nm"]) // 6, None, 5)   # past the first approach
        ax.plot(a["y_nm"][k], a["sl_v"][k], lw=0.6, label=f"{L} nN")
    ax.set_xlabel("piezo y (nm, frame A; the glass rises towards -y)")
    ax.set_ylabel("S_l (V)")
    ax.legend(title="set point", fontsize=8)
    ax.set_title("Friction loops on 9-degree glass (fig. 5)")
    return common.save(fig, exp_dir, "loops.png")


def plot_fit(exp_dir, snu, slu, snd, sld, up, down):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 4.2))
    x = np.linspace(min(snu.min(), snd.min()), max(snu.max(), snd.max()), 10)
    ax.plot(snu, slu, "o", label="uphill")
    ax.plot(x, np.polyval(up, x), "-", lw=0.8, label=f"r_u = {up[0]:.4f}")
    ax.plot(snd, sld, "s", label="downhill")
    ax.plot(x, np.polyval(down, x), "-", lw=0.8, label=f"r_d = {down[0]:.4f}")
    ax.set_xlabel("S_n (V)")
    ax.set_ylabel("S_l (V)")
    ax.legend(fontsize=8)
    ax.set_title("dS_l/dS_n up and down the slope (fig. 6)")
    return common.save(fig, exp_dir, "slopes.png")
