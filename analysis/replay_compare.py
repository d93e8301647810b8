"""The A/B view of a replay (./afm replay RUN --compare): how the firmware as
built now differs from the recording over the whole run, not only where it
first diverges.

    python -m analysis.replay_compare RECORDED_LOG REPLAYED_LOG --out DIR

Both logs carry FW_STATE per block: the recording's (the firmware that ran)
and the replay's (afm_replay --write: the recorded inputs and the new
outputs). Per block and quantity, new minus recorded:
  - the card's force (nN, x y z) and its piezo command (nm, x y);
  - its apex estimate (nm, in the plane);
  - each object's model (nm: a particle's centre; a wire's farther end).
Writes DIR/compare.md (a table: blocks compared, blocks that differ, the
first, the largest and the RMS difference, per quantity) and
DIR/compare.png (the differences over simulated time), and prints the
table. Exit 0 when nothing differs, 1 when something does, 2 when a log
cannot be read or holds no FW_STATE.

Every file is opened, and each output written, through analysis/safefs.py
(no link followed, no pipe waited on, outputs through a temporary file of
its own): started as root, the run folder holds what a run's user wrote. A
refused file is named in one line, exit 2."""
import argparse
import os
import sys

import io

import numpy as np

from analysis import afmlog, safefs


def states(path):
    """{seq: FW_STATE} and {seq: whole objects} of a log."""
    log = afmlog.load(path, channels={"FW_STATE"})
    msgs = log.get("FW_STATE", [])
    if not msgs:
        raise ValueError(f"{path}: no FW_STATE message")
    return afmlog.by_seq(msgs), afmlog.whole_by_seq(msgs, objects=lambda m: m.objects)


def object_positions(w):
    """{('p', id) or ('w', id): (x, y) or ((x0, y0), (x1, y1))} of a whole objects set."""
    out = {("p", p.id): np.array([p.x_nm, p.y_nm]) for p in w.particles}
    for r in w.wires:
        out[("w", r.id)] = np.array([[r.x_nm[0], r.y_nm[0]], [r.x_nm[-1], r.y_nm[-1]]])
    return out


def differences(rec, new):
    """Per quantity: (seqs, differences per block): force x y z and command
    x y signed, apex and objects as distances."""
    (sa, oa), (sb, ob) = rec, new
    seqs = sorted(set(sa) & set(sb))
    if not seqs:
        raise ValueError("the two logs share no FW_STATE block")
    d = {f"force {c} (nN)": [sb[s].force_nN[i] - sa[s].force_nN[i] for s in seqs] for i, c in enumerate("xyz")}
    d.update({f"command {c} (nm)": [sb[s].cmd_nm[i] - sa[s].cmd_nm[i] for s in seqs] for i, c in enumerate("xy")})
    d["apex (nm)"] = [float(np.hypot(sb[s].tip_nm[0] - sa[s].tip_nm[0], sb[s].tip_nm[1] - sa[s].tip_nm[1])) for s in seqs]
    obj = []
    for s in seqs:
        pa = object_positions(oa[s]) if s in oa else {}
        pb = object_positions(ob[s]) if s in ob else {}
        worst = 0.0
        for k in set(pa) | set(pb):
            if k not in pa or k not in pb:
                worst = float("inf")   # an object one side has and the other has not
                break
            worst = max(worst, float(np.max(np.linalg.norm(np.atleast_2d(pb[k] - pa[k]), axis=1))))
        obj.append(worst)
    d["objects, worst model (nm)"] = obj
    return np.array(seqs), {k: np.array(v, dtype=float) for k, v in d.items()}


def table(seqs, diffs):
    rows = []
    for name, v in diffs.items():
        a = np.abs(v)
        bad = np.nonzero(a > 0)[0]
        finite = a[np.isfinite(a)]
        rows.append((name, len(v), len(bad), int(seqs[bad[0]]) if len(bad) else None,
                     float(a.max()) if len(a) else 0.0, float(np.sqrt(np.mean(finite ** 2))) if len(finite) else 0.0))
    return rows


def render(rows):
    head = "| quantity | blocks | differ | first at block | largest | RMS |\n|---|---:|---:|---:|---:|---:|\n"
    return head + "".join(f"| {n} | {b} | {k} | {'-' if f is None else f} | {m:.6g} | {r:.6g} |\n" for n, b, k, f, m, r in rows)


def plot(out, out_fd, seqs, diffs, block_hz):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = seqs / block_hz
    fig, axs = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for k in ("force x (nN)", "force y (nN)", "force z (nN)"):
        axs[0].plot(t, diffs[k], lw=0.8, label=k.split(" (")[0])
    axs[0].set_ylabel("force, new - recorded (nN)")
    for k in ("command x (nm)", "command y (nm)", "apex (nm)"):
        axs[1].plot(t, diffs[k], lw=0.8, label=k.split(" (")[0])
    axs[1].set_ylabel("new - recorded (nm)")
    obj = np.where(np.isfinite(diffs["objects, worst model (nm)"]), diffs["objects, worst model (nm)"], np.nan)
    axs[2].plot(t, obj, lw=0.8, color="C3")
    axs[2].set_ylabel("objects' models, worst (nm)")
    axs[2].set_xlabel("simulated time (s), block / block rate")
    for ax in axs:
        ax.grid(True, alpha=0.3)
        ax.axhline(0, color="grey", lw=0.5)
    axs[0].legend(fontsize=7)
    axs[1].legend(fontsize=7)
    axs[0].set_title("The firmware as built now against the recording, block by block", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    safefs.write_atomic(out_fd, "compare.png", buf.getvalue(), out)
    return os.path.join(out, "compare.png")


def _checked(path):
    """A log's path once safefs passed it: (its folder's descriptor, the path to read)."""
    d = os.path.dirname(os.path.abspath(path))
    fd = safefs.open_dir(d)
    return fd, safefs.checked(fd, os.path.basename(path), d)


def _block_hz(rec_fd):
    """The block rate of the run's scene.yaml beside the recording (1000 without one)."""
    if not safefs.is_file(rec_fd, "scene.yaml"):
        return 1000.0
    import yaml
    return float((yaml.safe_load(safefs.read_bytes(rec_fd, "scene.yaml")) or {}).get("block_hz", 1000.0))


def main(argv=None):
    ap = argparse.ArgumentParser(prog="./afm replay RUN --compare", description=__doc__.split("\n\n")[0])
    ap.add_argument("recorded", help="the run's bus.lcmlog")
    ap.add_argument("replayed", help="afm_replay --write's log")
    ap.add_argument("--out", required=True, help="folder for compare.md and compare.png")
    ap.add_argument("--block-hz", type=float, default=None,
                    help="the scene's block rate, for the time axis (default: the run's scene.yaml beside the recording, else 1000)")
    a = ap.parse_args(argv)
    names = {}   # the paths read -> the paths given, for messages
    try:   # safefs.Refused is a ValueError
        (rec_fd, recorded), (_, replayed) = _checked(a.recorded), _checked(a.replayed)
        names = {recorded: a.recorded, replayed: a.replayed}
        if a.block_hz is None:
            a.block_hz = _block_hz(rec_fd)
        seqs, diffs = differences(states(recorded), states(replayed))
        os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
        out_fd = safefs.make_dir(safefs.open_dir(os.path.dirname(os.path.abspath(a.out))), os.path.basename(os.path.abspath(a.out)), a.out)
        rows = table(seqs, diffs)
        text = render(rows)
        safefs.write_atomic(out_fd, "compare.md", f"# Replay against the recording\n\nrecorded: `{a.recorded}`\nreplayed: `{a.replayed}`\n\n{text}", a.out)
        png = plot(a.out, out_fd, seqs, diffs, a.block_hz)
    except (ValueError, OSError) as e:
        msg = str(e)
        for path, given in names.items():
            msg = msg.replace(path, given)
        print(f"compare: {msg}", file=sys.stderr)
        return 2
    print(text, end="")
    print(f"compare: {os.path.join(a.out, 'compare.md')}, {png}")
    return 1 if any(r[2] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
