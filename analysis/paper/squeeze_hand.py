"""The ride-over through the haptic device (part of the squeeze experiment,
issue 34's operator's third axis): a hand on the stylus pushes the rod of
scenes/paper/ride.yaml across, pressing the stylus down to set the load
(operator.haptic.load_span_nN: the stylus's depth sets the load the pose
asks for, and the hand feels F_z back). At 0.8 of eq. 30's least load the
tip rides over the rod, at 1.25 of it the tip pushes it. What the hand
feels says which: the force the device renders along the stroke
(HAPTIC_FORCE, g F_y) climbs as the tip meets the rod; over a ride-over it
falls back to the tip's own friction before the stroke ends, over a push it
stays up to the end. The rod's share is what the stroke feels above the
tip's own friction (its level before the tip meets the rod): a push keeps
at least half of its peak share to the stroke's end, a ride-over none. A
ride-over's peak is brief: the lever's spring loads to the lift-off force
H_ride = (F_z + F_a,ts) / tan psi within the piezo's first nanometres
against the rod (the paper's lever: about 1.65 nN per nm), so a block's mean
(what the device renders) holds it for a sample or two and may rise barely
above the friction (physics.md section 7, "What a ride-over feels like").
Everything here is read from the device's side of the bus (HAPTIC_FORCE,
HAPTIC_POSE); nothing from SIM_TRUTH."""
import os

import numpy as np

from analysis.units import show
from analysis.paper import common, squeeze_figs

GAMMA, Q, RATIO = 40, 0.25, 20      # fig. 16's first point: the paper's lever
LOADS = (("hand_low", 0.8), ("hand_high", 1.25))
CROSSINGS = 4
SPAN_NN = 20.0                      # the stylus's full press


def runs(size):
    df, _ = squeeze_figs.model_df(GAMMA, Q, RATIO)
    x = -squeeze_figs.ROD_L / 2 + Q * squeeze_figs.ROD_L
    path = [[x, -squeeze_figs.STROKE if i % 2 == 0 else squeeze_figs.STROKE] for i in range(CROSSINGS + 1)]
    out = []
    for name, frac in LOADS:
        adh = round(RATIO * squeeze_figs.F_A_TS / squeeze_figs.ROD_L * 1e3, 5)
        settings = {"probe.tip_half_angle_deg": GAMMA, "sample.wire.adhesion_nN_per_um": adh,
                    "firmware.tip_half_angle_deg": GAMMA, "firmware.wire_friction_nN_per_um": round(squeeze_figs.WIRE_MU * adh, 4),
                    "operator.load_nN": round(frac * df, 4), "operator.load_ramp_to_nN": None,
                    "operator.path_nm": path, "operator.speed_nm_per_s": squeeze_figs.SPEED,
                    "operator.haptic": {"load_span_nN": SPAN_NN},
                    "duration_s": round(CROSSINGS * 2 * squeeze_figs.STROKE / squeeze_figs.SPEED + 0.3, 2)}
        out.append(common.Run(name=name, scene=squeeze_figs.SCENE, cost_s=2, settings=settings))
    return out


def felt(run_dir):
    """The hand's first stroke across the rod, from the device's side: the
    rendered lateral force (N) over time, its peak, its median over the
    stroke's first fifth (the tip's own friction: the rod lies at the
    stroke's middle) and over its last fifth, the load
    the stylus asked for (HAPTIC_POSE, nN, median) and the rendered F_z (N,
    median)."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"HAPTIC_FORCE", "HAPTIC_POSE"})
    force = sorted(afmlog.by_seq(log.get("HAPTIC_FORCE", [])).values(), key=lambda m: m.seq)
    pose = sorted(afmlog.by_seq(log.get("HAPTIC_POSE", [])).values(), key=lambda m: m.seq)
    if len(force) < 50 or len(pose) < 50:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: {len(force)} HAPTIC_FORCE and {len(pose)} HAPTIC_POSE messages")
    jy = np.array([p.joy[1] for p in pose])
    v = np.sign(np.diff(jy))
    turn = next((i + 1 for i in range(1, len(v)) if v[i] != 0 and v[i - 1] != 0 and v[i] != v[i - 1]), len(pose))
    first = {p.seq for p in pose[:turn]}
    fy = np.array([abs(f.force_N[1]) for f in force if f.seq in first])
    t = np.array([f.utime * 1e-6 for f in force])
    return {"t": t, "fy": np.array([f.force_N[1] for f in force]), "fz": np.array([f.force_N[2] for f in force]),
            "peak": float(fy.max()), "base": float(np.median(fy[:max(1, int(0.2 * len(fy)))])),
            "tail": float(np.median(fy[int(0.8 * len(fy)):])),
            "load": float(np.median([p.load_nN for p in pose])), "fz_med": float(np.median([f.force_N[2] for f in force]))}


def rows(res, dirs, exp_dir):
    df, _ = squeeze_figs.model_df(GAMMA, Q, RATIO)
    got = {name: felt(dirs[name]) for name, _ in LOADS}
    for name, frac in LOADS:
        g = got[name]
        pushed = g["tail"] - g["base"] > 0.5 * (g["peak"] - g["base"])   # the rod's share kept to the end
        want = frac > 1
        res.rows.append(common.Row(
            f"by hand, load {frac} x eq. 30's dF: the hand felt the rod {'carried to the stroke end' if want else 'ridden over'} (1 yes)",
            "", key="squeeze.hand_felt", bench=float(pushed == want), truth=1.0, runs=(name,),
            note=f"the device's rendered |F_y| in the first stroke: the tip's own friction (first fifth) {show(g['base'], 'N')}, "
                 f"peak {show(g['peak'], 'N')}, last fifth {show(g['tail'], 'N')} (a push keeps over half its peak's "
                 f"excess over the friction); gamma {GAMMA} deg, l = {Q} L"))
        res.rows.append(common.Row(
            f"by hand, load {frac} x dF: the load the stylus's press asked for", "nN", key="squeeze.hand_load",
            bench=g["load"], truth=frac * df, runs=(name,),
            note=f"HAPTIC_POSE's load from the stylus's depth (span {show(SPAN_NN, 'nN')}); the hand aims for {show(frac * df, 'nN')} and "
                 f"F_z pushes the stylus back up by g F_z / K_hand (rendered F_z {show(g['fz_med'], 'N')})"))
    return plot(exp_dir, got)


def plot(exp_dir, got):
    p = common.plt()
    fig, axs = p.subplots(2, 1, figsize=(6.8, 4.6), sharex=True)
    for name, frac in LOADS:
        g = got[name]
        axs[0].plot(g["t"], g["fy"] * 1e3, lw=0.8, label=f"{frac} x dF")
        axs[1].plot(g["t"], g["fz"] * 1e3, lw=0.8, label=f"{frac} x dF")
    axs[0].set_ylabel("hand's F_y (mN)")
    axs[1].set_ylabel("hand's F_z (mN)")
    axs[1].set_xlabel("simulated time (s)")
    axs[0].legend(fontsize=7)
    axs[0].set_title("What the hand feels pushing the rod across (HAPTIC_FORCE)", fontsize=9)
    fig.tight_layout()
    return common.save(fig, exp_dir, "hand_ride_over.png")
