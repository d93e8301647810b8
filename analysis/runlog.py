"""A run's errors against the simulator's truth, block by block, from its
own bus.lcmlog. SIM_TRUTH is read here, for evaluation only.

Definitions (README, "Sweeps: what each point measures"):
  tip force   |F_firmware - F_true| per block: FW_FORCE (the block's mean)
              against SIM_TRUTH's force (the block's mean too), pN; RMS and
              worst over the blocks; also in % of the card's full scale
              k_n K_n 10 V (run.json card.full_scale_pn).
  apex        the distance in the plane between FW_TIP's apex estimate and
              the true apex at the block's last sample, nm; RMS and worst.
  objects     per object (particles, wires), the distance between the
              firmware's model (FW_OBJECTS of the block, before any local
              scan fix of that block) and the truth; for a wire the larger of
              its two ends; worst over the run and at the last block, nm.
"""
import math
import os

import numpy as np

import afmlog

CHANNELS = ["FW_FORCE", "FW_TIP", "FW_OBJECTS", "SIM_TRUTH"]


def _wire_ends(w):
    return (w.x_nm[0], w.y_nm[0]), (w.x_nm[w.n - 1], w.y_nm[w.n - 1])


def _object_distances(model, truth):
    """{object key: distance nm} for the objects both hold."""
    d = {}
    mp = {p.id: p for p in model.particles}
    for p in truth.particles:
        q = mp.get(p.id)
        if q is not None:
            d[f"particle {p.id}"] = math.hypot(q.x_nm - p.x_nm, q.y_nm - p.y_nm)
    mw = {w.id: w for w in model.wires}
    for w in truth.wires:
        q = mw.get(w.id)
        if q is not None and q.n >= 2 and w.n >= 2:
            (a0, a1), (t0, t1) = _wire_ends(q), _wire_ends(w)
            d[f"wire {w.id}"] = max(math.dist(a0, t0), math.dist(a1, t1))
    return d


def errors(run_dir, full_scale_pn=None):
    """The error figures of a run (a dict; see the module's definitions)."""
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels=CHANNELS)
    force = afmlog.by_seq(log.get("FW_FORCE", []))
    tip = afmlog.by_seq(log.get("FW_TIP", []))
    # Objects as whole sets (a message may list only what changed); the
    # firmware's: the first of each block, before any fix of that block.
    objects = {}
    for msg, whole in afmlog.whole_objects(log.get("FW_OBJECTS", [])):
        objects.setdefault(msg.seq, whole)
    truth = afmlog.by_seq(log.get("SIM_TRUTH", []))
    truth_objects = afmlog.whole_by_seq(log.get("SIM_TRUTH", []), lambda m: m.objects)
    seqs = sorted(s for s in truth if s in force and s in tip)
    if not seqs:
        raise ValueError(f"{run_dir}/bus.lcmlog: no block has both the firmware's outputs and the truth")
    df = np.array([np.linalg.norm(np.subtract(force[s].force_nN, truth[s].force_nN)) * 1e3 for s in seqs])
    da = np.array([math.hypot(tip[s].tip_nm[0] - truth[s].tip_nm[0], tip[s].tip_nm[1] - truth[s].tip_nm[1]) for s in seqs])
    per_object = {}
    last = None
    for s in seqs:
        if s not in objects or s not in truth_objects:
            continue
        d = _object_distances(objects[s], truth_objects[s])
        for k, v in d.items():
            per_object.setdefault(k, {"worst_nm": 0.0})
            per_object[k]["worst_nm"] = max(per_object[k]["worst_nm"], v)
            per_object[k]["final_nm"] = v
        last = s
    out = {
        "blocks": len(seqs),
        "force_rms_pN": float(np.sqrt(np.mean(df ** 2))),
        "force_worst_pN": float(df.max()),
        "apex_rms_nm": float(np.sqrt(np.mean(da ** 2))),
        "apex_worst_nm": float(da.max()),
        "objects_worst_nm": max((o["worst_nm"] for o in per_object.values()), default=0.0),
        "objects_final_nm": max((o["final_nm"] for o in per_object.values()), default=0.0),
        "objects": per_object,
        "last_block": last,
    }
    if full_scale_pn:
        out["force_rms_pct_fs"] = 100.0 * out["force_rms_pN"] / full_scale_pn
        out["force_worst_pct_fs"] = 100.0 * out["force_worst_pN"] / full_scale_pn
    return out
