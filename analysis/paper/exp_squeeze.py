"""The cone's down force (figs. 16-17; eq. 23-24 and 29-30; physics.md
sections 5-7), in the live loop: the simulator's effect down_force presses
what the tip pushes by H tan psi, the card models the same (fw_wire_update,
the particles' down threshold of fw_particles) and flags SQUEEZE past psi_max.

- A rod (1.3 um x 100 nm, f L = 26 nN, wire mu 0.5) pushed at an end by cones
  of several half angles, pressed at 40 nN so that the tip stays down: the
  push measured from the card's force (FW_STATE, less the tip's own friction
  measured in the same run before contact) against the firmware's eq. 29
  (afm_calc model squeeze) and the simulator; dF = H tan psi - F_a,ts from
  the measured push against eq. 30.
- The tip's lift-off (eq. 27-30) in the live loop: the same end push at 0.9
  and 1.1 of eq. 30's least load dF (the firmware's solver), at two or three
  cones. The simulator lifts the tip by its own contact balance (the push on
  the cone's flank against load and adhesion); at 0.9 dF the tip rides over
  and the rod stays (the run's scans; the card flags RIDE-OVER), at 1.1 dF
  the rod is pushed (the card flags contact, the scans see it moved).
- The same rod pushed near its middle with mu 1 and gamma 50 deg, past
  psi_max: it stays (scans and SIM_TRUTH). Pressed at 40 nN the card flags
  SQUEEZE; at 5 nN the tip rides up over it before the push gets that far.
- A particle (mu_ps 0.5, F_adh 5 nN) pushed with and without the down force:
  its threshold F_th(0) / (1 - mu_ps tan gamma) against F_th(0).
- Figs. 16-17 from the firmware's solver: dF / F_a,ts against gamma, mu and
  l for F_a,os = 20 and 50 F_a,ts, mu 0.2."""
import math
import os

import numpy as np

from analysis.units import show, listed
from analysis.paper import common, squeeze_figs, squeeze_hand
from analysis.paper.exp_rod import rod_pose, truth_poses

NAME = "squeeze"
TITLE = "Tip-substrate-wire squeeze and load-dependent friction"
FIGURES = "figs. 16-17, eq. 23-24, 29-30"

GAMMAS = {"full": [10, 20, 30, 40, 50], "reduced": [20, 45]}
PRESSED_NN = 40.0       # the gamma runs' load: the tip stays down at every cone (eq. 30's dF is below it)
RIDE_GAMMAS = {"full": [20, 35, 50], "reduced": [20, 35]}
RIDE_LOADS = {"low": 0.9, "high": 1.1}   # of eq. 30's least load
END_Q = 0.03            # the end push, as in the rod experiment
MID_Q = 0.45            # near the middle: k = 0.909
SQUEEZE_GAMMA, SQUEEZE_MU = 50, 1.0
RIDDEN_Y_NM = 60        # the rod's far side: an apex that ends past it rode over
PARTICLE = {"particles": [{"id": 1, "x_nm": 0, "y_nm": -200, "radius_nm": 50}]}
PARTICLE_GAMMA = 40


def _path(q, sc):
    w = sc["objects"]["wires"][0]
    x = w["x0_nm"] + q * (w["x1_nm"] - w["x0_nm"])
    return [[x, p[1]] for p in sc["operator"]["path_nm"]]


def _rod_constants(sc):
    """(L, f L, wire mu, F_a,ts) of the squeeze scene's rod, nm and nN."""
    w = sc["objects"]["wires"][0]
    L = float(w["x1_nm"] - w["x0_nm"])
    return (L, float(sc["sample"]["wire"]["friction_nN_per_um"]) * L * 1e-3, float(sc["sample"]["wire"]["mu"]),
            float(sc["sample"]["tip_substrate"]["adhesion_nN"]))


def ride_load(sc, gamma):
    """Eq. 30's least load for the end push at cone half angle gamma (the
    firmware's solver, no twist): the model under test, which picks the
    ride-over runs' loads."""
    L, fl, mu, fats = _rod_constants(sc)
    return float(common.squeeze_model(L, END_Q * L, gamma, mu, fl, fats)["df_nN"])


def runs(size):
    sc = common.load_scene("squeeze.yaml")
    out = [common.Run(name=f"gamma_{g}", scene="squeeze.yaml", cost_s=4,
                      settings={"probe.tip_half_angle_deg": g, "firmware.tip_half_angle_deg": g, "operator.path_nm": _path(END_Q, sc),
                                "operator.load_nN": PRESSED_NN}) for g in GAMMAS[size]]
    for g in RIDE_GAMMAS[size]:
        dF = ride_load(sc, g)
        for tag, x in RIDE_LOADS.items():
            out.append(common.Run(name=f"ride_{g}_{tag}", scene="squeeze.yaml", cost_s=4,
                                  settings={"probe.tip_half_angle_deg": g, "firmware.tip_half_angle_deg": g, "operator.path_nm": _path(END_Q, sc),
                                            "operator.load_nN": round(x * dF, 4)}))
    for name, load in (("squeeze_pressed", 40), ("squeeze_light", 5)):
        out.append(common.Run(name=name, scene="squeeze.yaml", cost_s=4,
                              settings={"probe.tip_half_angle_deg": SQUEEZE_GAMMA, "sample.wire.mu": SQUEEZE_MU,
                                        "firmware.tip_half_angle_deg": SQUEEZE_GAMMA, "firmware.wire_mu": SQUEEZE_MU,
                                        "operator.load_nN": load, "operator.path_nm": _path(MID_Q, sc)}))
    for name, on in (("particle_down", True), ("particle_flat", False)):
        out.append(common.Run(name=name, scene="squeeze.yaml", cost_s=3,
                              settings={"objects": PARTICLE, "effects.down_force": on,
                                        "probe.tip_half_angle_deg": PARTICLE_GAMMA, "firmware.tip_half_angle_deg": PARTICLE_GAMMA,
                                        "operator.path_nm": [[0, -700], [0, 100]]}))
    return out + squeeze_figs.runs(size) + squeeze_hand.runs(size)


def _rod_moved(run_dir):
    """How far the rod's centre moved (nm): between the run's scans, and in SIM_TRUTH."""
    c0, _, _ = rod_pose(run_dir, "scan_initial")
    c1, _, _ = rod_pose(run_dir, "scan_final")
    (t0, _), (t1, _) = truth_poses(run_dir)
    return float(np.linalg.norm(c1 - c0)), float(np.linalg.norm(t1 - t0))


def _apex_final_y(run_dir, channel="FW_STATE"):
    """The apex's last y (nm) from the card (FW_STATE) or the simulator
    (SIM_TRUTH): past the rod when the tip rode over it."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={channel})
    tips = sorted(afmlog.by_seq(log.get(channel, [])).values(), key=lambda m: m.seq)
    if not tips:
        raise common.PaperError(f"{run_dir}/bus.lcmlog: no {channel}")
    return float(tips[-1].tip_nm[1])


def analyse(dirs, exp_dir, size):
    sc = common.truth(dirs[f"gamma_{GAMMAS[size][0]}"])
    w = sc["objects"]["wires"][0]
    L, fl, mu, fats = _rod_constants(sc)
    k_end = common.calc("model", "wire", "--length-nm", f"{L:.1f}", "--diameter-nm", w["diameter_nm"],
                        "--push-at-nm", f"{END_Q * L:.1f}", "--f-nN-per-um", f"{fl / L * 1e3:.4f}")["min_force_nN"]
    pts = []
    for g in GAMMAS[size]:
        d = dirs[f"gamma_{g}"]
        hb, ht, _ = common.push_excess(d)
        if hb is None:
            raise common.PaperError(f"{d}: the card never flagged contact with the rod")
        m = common.squeeze_model(L, END_Q * L, g, mu, fl, fats)
        pts.append(dict(g=g, H_card=hb, H_truth=ht, H_fw=m["push_nN"], dF_fw=m["df_nN"],
                        dF_card=hb * math.tan(math.radians(g)) - fats))
    res = common.Result()
    last = pts[-1]
    rms = float(np.sqrt(np.mean([(p["H_card"] - p["H_fw"]) ** 2 for p in pts])))
    res.rows = [
        common.Row(f"push at an end, gamma {last['g']} deg (eq. 29: k f L / (1 - k mu tan psi))", "nN",
                   key="squeeze.end_push_eq29", bench=last["H_card"], truth=last["H_fw"], runs=(f"gamma_{last['g']}",),
                   note=f"without the down force k f L = {show(k_end, 'nN')}; truth column: the firmware's solver"),
        common.Row(f"push, card against eq. 29 (RMS over {len(pts)} cones)", "nN", key="squeeze.push_eq29_rms", bench=rms,
                   scale=k_end, runs=tuple(f"gamma_{p['g']}" for p in pts),
                   note="simulator: " + listed([p['H_truth'] for p in pts], "nN")),
        common.Row(f"dF at gamma {last['g']} deg from the measured push (eq. 30)", "nN", key="squeeze.df_from_push",
                   bench=last["dF_card"], truth=last["dF_fw"], runs=(f"gamma_{last['g']}",),
                   note="dF = H tan psi - F_a,ts; > 0: the load must exceed it to keep the apex down"),
    ]
    _squeeze_rows(res, dirs, L, fl, fats)
    _ride_rows(res, dirs, sc, size)
    _particle_rows(res, dirs, sc)
    fig_pts = squeeze_figs.rows(res, dirs, size)
    hand_fig = squeeze_hand.rows(res, dirs, exp_dir)
    res.notes.append("per cone: " + "; ".join(
        f"gamma {show(p['g'], 'deg')}: the push {show(p['H_card'], 'nN')} by the card, {show(p['H_truth'], 'nN')} by the "
        f"simulator, {show(p['H_fw'], 'nN')} by eq. 29; dF {show(p['dF_card'], 'nN')} (eq. 30: {show(p['dF_fw'], 'nN')})"
        for p in pts))
    res.figures = [("Push at an end against the cone's half angle: card, simulator, eq. 29 (firmware), and no down force",
                    _plot_runs(exp_dir, pts, k_end, L, mu, fl, fats)),
                   ("Figs. 16-17 from runs: the least load dF / F_a,ts found by a load ramp in each run, against eq. 30 "
                    "(the firmware's solver) with the lever's twist", squeeze_figs.plot(exp_dir, fig_pts)),
                   ("By hand through the haptic device, the stylus pressed to set the load: the force the hand feels over "
                    "a ride-over and over a push", hand_fig)]
    return res


def _squeeze_rows(res, dirs, L, fl, fats):
    m = common.squeeze_model(L, MID_Q * L, SQUEEZE_GAMMA, SQUEEZE_MU, fl, fats)   # the firmware's k(l) and psi_max
    k, psi_max = m["k"], m["psi_max_deg"]
    for name, load in (("squeeze_pressed", 40), ("squeeze_light", 5)):
        d = dirs[name]
        moved_scan, moved_truth = _rod_moved(d)
        _, _, flagged = common.push_excess(d)
        y_end = _apex_final_y(d)
        ride = (load + fats) / math.tan(math.radians(SQUEEZE_GAMMA))
        res.rows.append(common.Row(f"{name}: the rod's move past psi_max ({SQUEEZE_GAMMA} > {show(psi_max, 'deg')}), load {show(load, 'nN')}",
                                   "nm", key="squeeze.past_psi_max_move", bench=moved_scan, truth=moved_truth, runs=(name,),
                                   note="between the run's scans; truth: SIM_TRUTH (the rod stays)"))
        # The model: past psi_max no push moves the rod; the card flags SQUEEZE
        # once the push passes half of k f L, which the tip
        # reaches before it rides up only when (load + F_a,ts) / tan psi does.
        flag_expected = ride > k * fl / 2
        res.rows.append(common.Row(f"{name}: the card flagged SQUEEZE (1 yes, 0 no)", "", key="squeeze.squeeze_flag",
                                   bench=float(flagged > 0), truth=float(flag_expected), runs=(name,),
                                   note=f"{flagged} blocks; the tip rides up once H tan psi - F_a,ts > load, at H = "
                                        f"{show(ride, 'nN')}; the card flags past half of k f L = {show(k * fl / 2, 'nN')}"))
        y_true = _apex_final_y(d, "SIM_TRUTH")
        res.rows.append(common.Row(f"{name}: the tip rode over the rod (1 yes, 0 no)", "", key="squeeze.rode_over",
                                   bench=float(y_end > RIDDEN_Y_NM), truth=float(y_true > RIDDEN_Y_NM), runs=(name,),
                                   note=f"the apex's last y: the card's {show(y_end, 'nm')}, the simulator's {show(y_true, 'nm')} "
                                        f"(SIM_TRUTH, the truth column); the rod's far side is {show(RIDDEN_Y_NM, 'nm', sign=True)}, the "
                                        f"path ends at +100; the stroke pushes on until the lift exceeds the load"))


def _ride_flags(run_dir):
    """Blocks the card flagged RIDE-OVER, and contact (FW_STATE)."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE"})
    flag = afmlog.afm.fw_state_t
    states = log.get("FW_STATE", [])
    return sum(1 for m in states if m.flags & flag.FLAG_RIDEOVER), sum(1 for m in states if m.flags & flag.FLAG_CONTACT)


def _ride_rows(res, dirs, sc, size):
    """The end push at 0.9 and 1.1 of eq. 30's least load: ridden over (the
    rod stays, the card flags it) or pushed, judged from the run's scans and
    the card's flags; the truth columns from SIM_TRUTH and sim_report.json."""
    for g in RIDE_GAMMAS[size]:
        dF = ride_load(sc, g)
        for tag, x in RIDE_LOADS.items():
            name = f"ride_{g}_{tag}"
            d = dirs[name]
            moved_scan, moved_truth = _rod_moved(d)
            ridden, contact = _ride_flags(d)
            sim_ridden = common.run_json(d).get("sim", {}).get("wire_ridden_samples", 0)
            load = x * dF
            if tag == "low":
                res.rows.append(common.Row(f"ride-over, gamma {g} deg, load 0.9 dF = {show(load, 'nN')}: the rod's move", "nm",
                                           key="squeeze.ride_low_move", bench=moved_scan, runs=(name,),
                                           note=f"between the run's scans (5 nm: the scan's pixel is 7.8 nm); simulator "
                                                f"{show(moved_truth, 'nm')}; eq. 30's dF = {show(dF, 'nN')}"))
                res.rows.append(common.Row(f"ride-over, gamma {g} deg, 0.9 dF: the card flagged RIDE-OVER (1 yes)", "",
                                           key="squeeze.ride_low_flag", bench=float(ridden > 0), truth=float(sim_ridden > 0),
                                           runs=(name,),
                                           note=f"{ridden} blocks flagged; the simulator's tip rode over in {sim_ridden} "
                                                f"samples (truth column)"))
            else:
                pushed = float(contact >= 5 and moved_scan > 20.0)
                res.rows.append(common.Row(f"ride-over, gamma {g} deg, load 1.1 dF = {show(load, 'nN')}: pushed (1 yes)", "",
                                           key="squeeze.ride_high_pushed", bench=pushed, truth=float(moved_truth > 20.0),
                                           runs=(name,),
                                           note=f"the card flagged contact in {contact} blocks and RIDE-OVER in {ridden}; "
                                                f"the scans see the rod moved {show(moved_scan, 'nm')} (simulator "
                                                f"{show(moved_truth, 'nm')})"))


def _particle_rows(res, dirs, sc):
    ps = sc["sample"]["particle_substrate"]
    base = float(ps["mu"]) * float(ps["adhesion_nN"])
    down = base / (1 - float(ps["mu"]) * math.tan(math.radians(PARTICLE_GAMMA)))
    got = {}
    for name, want, what in (("particle_down", down, "F_th(0) / (1 - mu_ps tan gamma)"), ("particle_flat", base, "F_th(0)")):
        hb, ht, _ = common.push_excess(dirs[name])
        if hb is None:
            raise common.PaperError(f"{dirs[name]}: the card never flagged contact with the particle")
        got[name] = hb
        how = "with" if name == "particle_down" else "without"
        res.rows.append(common.Row(f"particle push, {how} the down force (gamma {PARTICLE_GAMMA} deg)", "nN",
                                   key="squeeze.particle_push", bench=hb, truth=want, runs=(name,),
                                   note=f"truth: section 5's {what}; simulator {show(ht, 'nN')} (both above the threshold by "
                                        "the contact's relaxation lag while the particle slides)"))
        res.rows.append(common.Row(f"particle threshold, {how} the down force: the model's {what} against the truth's "
                                   "push", "nN", key="squeeze.model_particle_threshold", model=want, truth=ht, runs=(name,),
                                   note=f"model: section 5 with the values the card is handed (mu_ps {show(ps['mu'])}, F_adh "
                                        f"{show(ps['adhesion_nN'], 'nN')}); truth: the simulator's lateral force (SIM_TRUTH) while "
                                        "it pushes the particle (median), less the tip's own sliding friction before"))
    res.rows.append(common.Row("particle: what the down force adds to the push", "nN", key="squeeze.particle_added",
                               bench=got["particle_down"] - got["particle_flat"], truth=down - base,
                               runs=("particle_down", "particle_flat"),
                               note="the two runs' difference: the lag common to both cancels"))


def _plot_runs(exp_dir, pts, k_end, L, mu, fl, fats):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 4.0))
    gs = np.linspace(1, 60, 60)
    ax.plot(gs, [common.squeeze_model(L, END_Q * L, g, mu, fl, fats)["push_nN"] for g in gs], "-", lw=0.8,
            label="eq. 29 (firmware's solver)")
    ax.axhline(k_end, ls=":", color="grey", lw=0.8, label="without the down force: k f L")
    ax.plot([q["g"] for q in pts], [q["H_card"] for q in pts], "o", label="bench (card's force)")
    ax.plot([q["g"] for q in pts], [q["H_truth"] for q in pts], "x", label="simulator (truth)")
    ax.set_xlabel("cone half angle gamma (deg)")
    ax.set_ylabel("push that moves the rod (nN)")
    ax.legend(fontsize=7)
    return common.save(fig, exp_dir, "push_vs_gamma.png")
