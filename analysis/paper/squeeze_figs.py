"""Figs. 16-17 from runs (part of the squeeze experiment): the least load dF
that keeps the tip on the substrate while it pushes a rod (eq. 30), measured
by a load ramp within one run (scenes/paper/ride.yaml).

The tip crosses the rod near the push point again and again while the load
rises linearly over the run. Below dF a crossing rides over the rod: the
card flags RIDE-OVER from its own signals and the rod stays. The first
crossing above dF pushes it: the card flags contact. The measured dF is the
mean of the card's normal force (FW_STATE F_z) at the last ridden crossing
and at the first pushed one; half their difference is the ramp's step, the
measurement's resolution. Nothing here reads SIM_TRUTH: the simulator lifts
the tip by its own contact balance (sim_afm World::ride_push_nN), never by
eq. 30, which is the model under test.

- Fig. 16: dF against the cone's half angle gamma and the lever's twist
  theta, with F_a,os = 20 F_a,ts and mu_os = 0.2: the paper's stiff lever
  (theta about 0.01 deg) and a soft, short one (theta of degrees).
- Fig. 17: dF against gamma and the push point l, with F_a,os = 50 F_a,ts.

The wire's friction is load-dependent (eq. 23-24, sample.wire.adhesion_nN_per_um,
contact none: tau_os A = 0, as the figures take it): f L = mu_os F_a,os. The
model curve is eq. 29-30 by the firmware's own solver (afm_calc model
squeeze), at psi = gamma + theta with theta = K_l H / (k_theta K_l / h), the
card's twist estimate (fw_card.c card_twist_rad: theta = K_l S_l, S_l = F_y
over the lateral gain) at the model's push H."""
import math
import os

import numpy as np

from analysis.paper import common

SCENE = "ride.yaml"
ROD_L = 1300.0            # nm, the scene's rod
F_A_TS = 2.0              # nN, the scene's tip-substrate adhesion
MU_OS = 0.2
STROKE, SPEED = 300, 3000  # nm either side of the rod's axis, nm/s: 0.2 s a crossing, clear of the soft lever's lag
CROSSINGS = 24            # the zigzag's crossings of the rod (the path has CROSSINGS + 1 points)
RAMP = (0.4, 1.6)         # the ramp's ends, as fractions of eq. 30's dF without twist
TOLERANCE = 0.10          # of dF, fixed before running
SOFT_LEVER = {"probe.lever_length_um": 20, "probe.deflection_nm_per_V": 116, "probe.lateral_nN_per_V": 0.8,
              "probe.tip_height_um": 3}   # a short tip: theta of degrees, the apex only h theta = 0.2 um aside

# (name, figure, gamma deg, push point as a fraction of L, F_a,os / F_a,ts, soft lever)
POINTS = {
    "full": [("f16_g40", 16, 40, 0.25, 20, False), ("f16_g50", 16, 50, 0.25, 20, False), ("f16_g55", 16, 55, 0.25, 20, False),
             ("f16_g40_soft", 16, 40, 0.25, 20, True), ("f16_g50_soft", 16, 50, 0.25, 20, True),
             ("f17_g30_end", 17, 30, 0.03, 50, False), ("f17_g30_q25", 17, 30, 0.25, 50, False),
             ("f17_g30_q40", 17, 30, 0.40, 50, False), ("f17_g50_end", 17, 50, 0.03, 50, False),
             ("f17_g50_q25", 17, 50, 0.25, 50, False)],
    "reduced": [("f16_g50", 16, 50, 0.25, 20, False), ("f17_g30_q25", 17, 30, 0.25, 50, False)],
}


def _model(gamma, q, ratio, twist_deg=0.0):
    return common.calc("model", "squeeze", "--length-nm", f"{ROD_L:.1f}", "--push-at-nm", f"{q * ROD_L:.1f}",
                       "--gamma-deg", gamma, "--mu", MU_OS, "--fl-nN", f"{MU_OS * ratio * F_A_TS:.4f}",
                       "--fa-ts-nN", F_A_TS, "--twist-deg", f"{twist_deg:.5f}")


def model_df(gamma, q, ratio, rad_per_nN=0.0):
    """Eq. 30's dF (nN) and the twist (deg) at which it holds: theta =
    rad_per_nN H, with H the model's push, iterated to its fixed point."""
    twist = 0.0
    for _ in range(8):
        m = _model(gamma, q, ratio, twist)
        new = math.degrees(rad_per_nN * m["push_nN"])
        if abs(new - twist) < 1e-4:
            break
        twist = new
    return float(m["df_nN"]), twist


def runs(size):
    out = []
    for name, _, gamma, q, ratio, soft in POINTS[size]:
        df0, _ = model_df(gamma, q, ratio)
        hi = RAMP[1] * df0 * (1.4 if soft else 1.0)   # the twist raises dF
        x = -ROD_L / 2 + q * ROD_L
        settings = {"probe.tip_half_angle_deg": gamma, "sample.wire.adhesion_nN_per_um": round(ratio * F_A_TS / ROD_L * 1e3, 5),
                    "operator.load_nN": round(RAMP[0] * df0, 4), "operator.load_ramp_to_nN": round(hi, 4),
                    "operator.path_nm": [[x, -STROKE if i % 2 == 0 else STROKE] for i in range(CROSSINGS + 1)],
                    "operator.speed_nm_per_s": SPEED}
        if soft:
            settings.update(SOFT_LEVER)
        out.append(common.Run(name=name, scene=SCENE, cost_s=3, settings=settings))
    return out


def crossings(run_dir, gap_blocks=20):
    """The run's crossings of the rod, from the card alone (FW_STATE): runs of
    blocks flagged RIDE-OVER or contact, split where gap_blocks pass without
    either. Each: (first seq, pushed: any contact block, ridden: any
    RIDE-OVER block, the card's F_z (nN) at its first flagged block)."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE"})
    flag = afmlog.afm.fw_state_t
    states = sorted(afmlog.by_seq(log.get("FW_STATE", [])).values(), key=lambda m: m.seq)
    out, last = [], None
    for m in states:
        ride, contact = bool(m.flags & flag.FLAG_RIDEOVER), bool(m.flags & flag.FLAG_CONTACT)
        if not (ride or contact):
            continue
        if last is None or m.seq - last > gap_blocks:
            out.append({"seq": m.seq, "pushed": False, "ridden": False, "load_nN": float(m.force_nN[2])})
        out[-1]["pushed"] |= contact
        out[-1]["ridden"] |= ride
        last = m.seq
    return out


def measure(run_dir):
    """The measured dF (nN) and its resolution (half the step between the
    last ridden crossing and the first pushed one), or an error naming what
    the run lacks."""
    xs = crossings(run_dir)
    first = next((i for i, c in enumerate(xs) if c["pushed"]), None)
    if first is None:
        raise common.PaperError(f"{run_dir}: no crossing pushed the rod ({len(xs)} crossings, all ridden over): "
                                "the ramp ends below dF")
    if first == 0 or not xs[first - 1]["ridden"]:
        raise common.PaperError(f"{run_dir}: the first crossing already pushed the rod: the ramp starts above dF")
    lo, hi = xs[first - 1]["load_nN"], xs[first]["load_nN"]
    return 0.5 * (lo + hi), 0.5 * abs(hi - lo), first


def rad_per_nN(run_dir):
    """The card's twist per nN of lateral force: K_l / (k_theta K_l / h), from
    the card's configuration in run.json."""
    card = common.run_json(run_dir)["card"]
    return card["twist_urad_per_v"] * 1e-6 / (card["lateral_gain_pn_per_v"] * 1e-3)


def rows(res, dirs, size):
    """One row per point: the measured dF against eq. 30 within 10 %."""
    pts = []
    for name, fig, gamma, q, ratio, soft in POINTS[size]:
        d = dirs[name]
        df, half_step, n = measure(d)
        want, twist = model_df(gamma, q, ratio, rad_per_nN(d))
        pts.append(dict(name=name, fig=fig, gamma=gamma, q=q, ratio=ratio, soft=soft, df=df, want=want, twist=twist))
        lever = "soft lever" if soft else "paper's lever"
        res.rows.append(common.Row(
            f"fig. {fig}: dF, gamma {gamma} deg, l = {q:.2f} L, F_a,os = {ratio} F_a,ts, {lever} (theta {twist:.2f} deg)",
            "nN", bench=df, truth=want, tolerance=TOLERANCE, relative=True,
            note=f"the load ramp's first push at crossing {n + 1} of {CROSSINGS}, +- {half_step:.2f} nN (half the ramp's step); "
                 f"truth column: eq. 30 by the firmware's solver, the model under test; dF / F_a,ts = {df / F_A_TS:.2f}"))
    return pts


def plot(exp_dir, pts):
    """Fig. 16 (dF / F_a,ts against gamma, paper's and soft lever) and fig. 17
    (against gamma at three push points): eq. 30's curves and the runs."""
    p = common.plt()
    fig, axs = p.subplots(1, 2, figsize=(10, 3.8))
    gs = np.linspace(25, 58, 18)
    for ax, figno, ratio in ((axs[0], 16, 20), (axs[1], 17, 50)):
        mine = [pt for pt in pts if pt["fig"] == figno]
        for key in sorted({(pt["q"], pt["soft"]) for pt in mine}):
            q, soft = key
            sel = [pt for pt in mine if (pt["q"], pt["soft"]) == key]
            rate = 0.0
            if soft:
                # the soft lever's twist per nN of push, from a measured point
                s0 = sel[0]
                rate = math.radians(s0["twist"]) / _model(s0["gamma"], q, ratio, s0["twist"])["push_nN"]
            label = f"l = {q:.2f} L" + (", soft lever" if soft else "")
            line, = ax.plot(gs, [model_df(g, q, ratio, rate)[0] / F_A_TS for g in gs], "-", lw=0.9,
                            label=f"eq. 30, {label}")
            ax.plot([pt["gamma"] for pt in sel], [pt["df"] / F_A_TS for pt in sel], "o", color=line.get_color(),
                    label=f"runs (load ramp), {label}")
        ax.axhline(0, color="grey", lw=0.5)
        ax.set_xlabel("cone half angle gamma (deg)")
        ax.set_ylabel("dF / F_a,ts")
        ax.set_title(f"fig. {figno}: F_a,os = {ratio} F_a,ts, mu_os = {MU_OS}", fontsize=9)
        ax.legend(fontsize=6)
    fig.tight_layout()
    return common.save(fig, exp_dir, "df_figs_16_17.png")
