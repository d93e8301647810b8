"""Figs. 16-17 from runs (part of the squeeze experiment): the least load dF
that keeps the tip on the substrate while it pushes a rod (eq. 30), measured
by a load ramp within one run (scenes/paper/ride.yaml).

The tip crosses the rod near the push point again and again while the load
rises linearly over the run. Below dF a stroke rides over the rod and the
card's lateral force falls back to the tip's own friction once the tip is
past; the first stroke above dF pushes the rod on in front of the tip, and
the card's lateral force stays up to the stroke's end. The measured dF is
the mean of the card's normal force (FW_STATE F_z where its lateral force
peaks: the contact) in the last ridden stroke and the first pushed one; half their difference
is the ramp's step, the measurement's resolution. The card's own contact
flag is reported beside it: where it comes earlier, the card's ride-over
rule took a ride-over for a push. Nothing here reads SIM_TRUTH: the simulator lifts
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

from analysis.units import show
from analysis.paper import common

SCENE = "ride.yaml"
ROD_L = 1300.0            # nm, the scene's rod
F_A_TS = 2.0              # nN, the scene's tip-substrate adhesion
MU_OS = 0.2
STROKE, SPEED = 300, 3000  # nm either side of the rod's axis, nm/s: 0.2 s a crossing, clear of the soft lever's lag
CROSSINGS = 24            # the zigzag's crossings of the rod (the path has CROSSINGS + 1 points)
RAMP = (0.4, 1.6)         # the ramp's ends, as fractions of eq. 30's dF without twist
MOVED_NM = 2.0            # a stroke in which the truth's rod moves more than this pushed it (issue 47, item 7's 2 nm)
SOFT_LEVER = {"probe.lever_length_um": 20, "probe.deflection_nm_per_V": 174, "probe.lateral_nN_per_V": 1.2,
              "probe.tip_height_um": 3,   # a short tip: theta of degrees, the apex only h theta = 0.2 um aside
              # the card is told the lever it is given (its section: docs/scenes.md "### firmware")
              "firmware.lever_length_um": 20, "firmware.deflection_nm_per_V": 174, "firmware.lateral_nN_per_V": 1.2,
              "firmware.tip_height_um": 3}
WIRE_MU = 0.2             # ride.yaml's mu_os (contact: none): the card's f = mu_os F_a,os / L

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
    """Eq. 30's model at a figure's point: the rod, mu_os and F_a,ts of these figures."""
    return common.squeeze_model(ROD_L, q * ROD_L, gamma, MU_OS, MU_OS * ratio * F_A_TS, F_A_TS, twist_deg)


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
        adh = round(ratio * F_A_TS / ROD_L * 1e3, 5)
        settings = {"probe.tip_half_angle_deg": gamma, "sample.wire.adhesion_nN_per_um": adh,
                    "firmware.tip_half_angle_deg": gamma, "firmware.wire_friction_nN_per_um": round(WIRE_MU * adh, 4),
                    "operator.load_nN": round(RAMP[0] * df0, 4), "operator.load_ramp_to_nN": round(hi, 4),
                    "operator.path_nm": [[x, -STROKE if i % 2 == 0 else STROKE] for i in range(CROSSINGS + 1)],
                    "operator.speed_nm_per_s": SPEED}
        if soft:
            settings.update(SOFT_LEVER)
        out.append(common.Run(name=name, scene=SCENE, cost_s=3, settings=settings))
    return out


def strokes(run_dir):
    """The run's strokes across the rod, from the card's outputs alone
    (FW_STATE): split where the apex target's y turns. Each: (first seq,
    the card's F_z where its |F_y| peaks (nN: the load at the contact), the
    card's median |F_y| over its
    last fifth (nN): the rod still in front of the tip there, or not, and
    whether the card flagged contact in it)."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE"})
    flag = afmlog.afm.fw_state_t
    st = sorted(afmlog.by_seq(log.get("FW_STATE", [])).values(), key=lambda m: m.seq)
    cy = np.array([m.cmd_nm[1] for m in st])
    v = np.sign(np.diff(cy))
    turns = [0] + [i + 1 for i in range(1, len(v)) if v[i] != 0 and v[i - 1] != 0 and v[i] != v[i - 1]] + [len(st)]
    out = []
    for a, b in zip(turns[:-1], turns[1:]):
        if b - a < 20:
            continue
        seg = st[a:b]
        at = max(seg, key=lambda m: abs(m.force_nN[1]))   # the contact: where the push peaks
        out.append({"seq": seg[0].seq, "load_nN": float(at.force_nN[2]),
                    "tail_nN": float(np.median([abs(m.force_nN[1]) for m in seg[int(0.8 * len(seg)):]])),
                    "contact": any(m.flags & flag.FLAG_CONTACT for m in seg)})
    return out


def measure(run_dir):
    """The measured dF (nN), its resolution (half the load step between the
    last ridden stroke and the first pushed one) and that stroke's index,
    and the stroke the card first flagged contact in. A stroke pushed the
    rod when the card's lateral force stays up to its end (the rod goes on
    in front of the tip); ridden over, it falls back to the tip's own
    friction once the tip is past: the card's measured force, not its
    model of the ride-over, decides."""
    xs = strokes(run_dir)
    if len(xs) < 3:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: {len(xs)} strokes across the rod (the path has {CROSSINGS})")
    tails = np.array([x["tail_nN"] for x in xs])
    friction, top = float(np.median(tails)), float(tails.max())
    if top < 3 * friction:
        raise common.PaperError(f"{run_dir}: no stroke pushed the rod (the lateral force never stayed up: the ramp ends below dF)")
    first = int(np.argmax(tails > friction + 0.5 * (top - friction)))
    if first == 0:
        raise common.PaperError(f"{run_dir}: the first stroke already pushed the rod: the ramp starts above dF")
    lo, hi = xs[first - 1]["load_nN"], xs[first]["load_nN"]
    card = next((i for i, x in enumerate(xs) if x["contact"]), None)
    card_load = None if card is None else xs[card]["load_nN"]
    return 0.5 * (lo + hi), 0.5 * abs(hi - lo), first, card, card_load


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
        df, half_step, n, card, card_load = measure(d)
        want, twist = model_df(gamma, q, ratio, rad_per_nN(d))
        pts.append(dict(name=name, fig=fig, gamma=gamma, q=q, ratio=ratio, soft=soft, df=df, want=want, twist=twist))
        lever = "soft lever" if soft else "paper's lever"
        res.rows.append(common.Row(
            f"fig. {fig}: dF, gamma {gamma} deg, l = {q:.2f} L, F_a,os = {ratio} F_a,ts, {lever} (theta {show(twist, 'deg')})",
            "nN", key="squeeze.fig_df", bench=df, truth=want, runs=(name,),
            note=f"the load ramp's first push at stroke {n + 1} of {CROSSINGS} (the card's lateral force stays up to the "
                 f"stroke's end), +- {show(half_step, 'nN')} (half the ramp's step); truth column: eq. 30 by the firmware's "
                 f"solver, the model under test; dF / F_a,ts = {show(df / F_A_TS)}"))
        res.rows.append(common.Row(
            f"fig. {fig}, gamma {gamma} deg, {lever}: the card's push judgement, its first contact's load less dF", "nN",
            key="squeeze.fig_card_judgement", bench=None if card_load is None else card_load - df, scale=df, runs=(name,),
            note=f"the card flagged contact first {'in no stroke' if card is None else f'in stroke {card + 1}'}, the rod was first pushed in "
                 f"stroke {n + 1}: the card's ride-over rule (fw_wire: H_ride = (F_z + F_a,ts) / tan(gamma + theta), its "
                 f"twist estimate) judged a push at {'none' if card_load is None else show(card_load, 'nN')} against the "
                 f"measured {show(df, 'nN')}; held to the figures' own tolerance (tolerances.yaml)"))
        lift, lift_half, lift_n = truth_liftoff(d)
        res.rows.append(common.Row(
            f"fig. {fig}, gamma {gamma} deg, l = {q:.2f} L, {lever}: eq. 30's dF against the load at which the truth's "
            "tip lifts off", "nN", key="squeeze.model_liftoff", model=want, truth=lift, runs=(name,),
            note=f"model: eq. 30 by the firmware's solver (afm_calc model squeeze, twist {show(twist, 'deg')}); truth: the "
                 f"simulator's own record (SIM_TRUTH): the load where its rod first moves over {show(MOVED_NM, 'nm')} in a "
                 f"stroke (stroke {lift_n + 1}), between that stroke's and the last ridden one's, +- {show(lift_half, 'nN')}"))
    return pts


def truth_strokes(run_dir):
    """The run's strokes across the rod as the simulator recorded them
    (SIM_TRUTH alone): split where the piezo's y turns. Each: (the true
    normal load where the true |F_y| peaks (nN), and how far the rod moved
    in it (nm: the larger end's move from the stroke's first block))."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"SIM_TRUTH"})
    tr = afmlog.by_seq(log.get("SIM_TRUTH", []))
    whole = afmlog.whole_by_seq(log.get("SIM_TRUTH", []), objects=lambda m: m.objects)
    st = [tr[s] for s in sorted(s for s in tr if s in whole and whole[s].wires)]
    if len(st) < 50:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: {len(st)} SIM_TRUTH blocks with the rod")
    ends = np.array([[[w.x_nm[0], w.y_nm[0]], [w.x_nm[-1], w.y_nm[-1]]] for w in (whole[m.seq].wires[0] for m in st)])
    v = np.sign(np.diff([m.piezo_nm[1] for m in st]))
    turns = [0] + [i + 1 for i in range(1, len(v)) if v[i] != 0 and v[i - 1] != 0 and v[i] != v[i - 1]] + [len(st)]
    out = []
    for a, b in zip(turns[:-1], turns[1:]):
        if b - a < 20:
            continue
        at = max(range(a, b), key=lambda i: abs(st[i].force_nN[1]))
        moved = float(np.hypot(*(ends[a:b] - ends[a]).transpose(2, 0, 1)).max())
        out.append((abs(float(st[at].force_nN[2])), moved))
    return out


def truth_liftoff(run_dir):
    """The load (nN) at which the truth's tip lifts off the rod rather than
    push it, from the simulator's record of the load ramp: the mean of the
    true load in the last stroke that rode over (the rod stayed within
    MOVED_NM) and the first that pushed it; half their difference; that
    stroke's index."""
    xs = truth_strokes(run_dir)
    first = next((i for i, (_, moved) in enumerate(xs) if moved > MOVED_NM), None)
    if first is None or first == 0:
        raise common.PaperError(f"{run_dir}: the truth's rod moved in {'no' if first is None else 'the first'} stroke: "
                                "the ramp does not bracket the lift-off")
    lo, hi = xs[first - 1][0], xs[first][0]
    return 0.5 * (lo + hi), 0.5 * abs(hi - lo), first


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
