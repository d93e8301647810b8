"""A recorded run in the page (./afm view RUN_DIR; docs/view.md): its
bus.lcmlog read through the package's one log reader (analysis.afmlog) and
its frames (frames/frame_NNNNN.png, as the renderer wrote them; in a run
without them, outputs.png: false, the JPEG frames a run made with --view
published on the bus, VIEW_FRAME, which the record keeps).

Contract: a frame k is what RENDER_FRAME k announced: the card's state
(FW_STATE) of the block it shows, the objects made whole by afmlog's
reader, the file frames/frame_k.png (or VIEW_FRAME k's JPEG: the frames
the page was sent, not every frame); the strip chart is every block's
HAPTIC_FORCE (the card's tip force, the hand's force), about 250 samples
a simulated second. A run folder without bus.lcmlog, or with neither frame
files nor VIEW_FRAMEs, is refused with one line naming what is missing.
"""
import math
import os

from analysis import afmlog, gsf
from analysis.view import frames

CHART_HZ = 250   # strip chart samples per simulated second


class RunError(ValueError):
    """A run folder the page cannot play (its message says what is missing)."""


def _frame_list(renders):
    """[(index, utime, seq)] of the frames announced, each once, by index."""
    seen = {}
    for m in renders:
        seen.setdefault(m.index, (m.index, m.utime, m.seq))
    return [seen[k] for k in sorted(seen)]


def _chart(forces, block_hz):
    """The strip chart's series over the run from HAPTIC_FORCE."""
    every = max(1, int(block_hz // CHART_HZ)) if block_hz else 1
    out = {k: [] for k in ("t", "fx", "fy", "fz", "hx", "hy", "hz")}
    last = -1
    for m in forces:
        if m.seq <= last or m.seq % every:
            continue
        last = m.seq
        out["t"].append(m.utime * 1e-6)
        for k, v in zip(("fx", "fy", "fz"), m.tip_force_nN):
            out[k].append(round(v, 4))
        for k, v in zip(("hx", "hy", "hz"), m.force_N):
            out[k].append(round(v, 6))
    return out


class RecordedSource:
    """A run's frames by index, for the page's scrubber."""

    def __init__(self, run_dir):
        self.run_dir = os.path.abspath(run_dir)
        log = os.path.join(self.run_dir, "bus.lcmlog")
        if not os.path.isfile(log):
            raise RunError(f"view: {log}: no such file (not a run folder?)")
        msgs = afmlog.load(log, channels={"RENDER_FRAME", "FW_STATE", "HAPTIC_FORCE", "AFM_ANALOG", "VIEW_FRAME"})
        self.frames = [f for f in _frame_list(msgs["RENDER_FRAME"]) if os.path.isfile(self._png(f[0]))]
        self.jpegs = {}   # index -> VIEW_FRAME, where the frames are the bus's
        if not self.frames:
            for m in msgs["VIEW_FRAME"]:
                self.jpegs.setdefault(m.index, m)
            self.frames = [(k, self.jpegs[k].utime, self.jpegs[k].seq) for k in sorted(self.jpegs)]
        if not self.frames:
            raise RunError(f"view: {self.run_dir}/frames: no frame files of the frames the log announces "
                           "(outputs.png: false?), and no VIEW_FRAME in bus.lcmlog (a run made with --view has them)")
        self.states = afmlog.by_seq(msgs["FW_STATE"])
        self.objects = afmlog.whole_by_seq(msgs["FW_STATE"], lambda m: m.objects)
        hands = afmlog.by_seq(msgs["HAPTIC_FORCE"])
        self.hands = hands
        analog = msgs["AFM_ANALOG"]
        block_hz = 1e6 / (analog[1].utime - analog[0].utime) if len(analog) > 1 and analog[1].utime > analog[0].utime else 0
        self.chart = _chart(sorted(hands.values(), key=lambda m: m.seq), block_hz)
        if self.jpegs:
            first = self.jpegs[self.frames[0][0]]
            self.size = (first.width, first.height)
            self.field = self._field() or list(first.field_nm)
        else:
            self.size = self._png_size(self._png(self.frames[0][0]))
            self.field = self._field()

    def _png(self, k):
        return os.path.join(self.run_dir, "frames", f"frame_{k:05d}.png")

    @staticmethod
    def _png_size(path):
        with open(path, "rb") as f:
            head = f.read(24)
        return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")

    def hello(self):
        return frames.hello("recorded", run_dir=self.run_dir, frames_total=len(self.frames), chart=self.chart)

    def _objects_at(self, seq):
        """The whole objects of the last block up to seq (None before the first)."""
        keys = [s for s in self.objects if s <= seq]
        return self.objects[max(keys)] if keys else None

    def frame(self, pos):
        """(meta, image bytes) of the pos-th frame: PNG, or the bus's JPEG."""
        index, utime, seq = self.frames[pos]
        st = self.states.get(seq)
        hand = self.hands.get(seq)
        objs = self._objects_at(seq)
        width, height = self.size
        field = self.field
        if self.jpegs:
            image, mime = bytes(self.jpegs[index].jpeg), "image/jpeg"
        else:
            with open(self._png(index), "rb") as f:
                image, mime = f.read(), "image/png"
        meta = frames.frame_meta(
            index=index, utime=utime, seq=seq, frames_total=len(self.frames), width=width, height=height,
            field_nm=field, tip_nm=list(st.tip_nm[:2]) if st else [math.nan, math.nan],
            force_nN=list(st.force_nN) if st else [0, 0, 0], hand_N=list(hand.force_N) if hand else [0, 0, 0],
            flags=st.flags if st else 0,
            particles=[(p.id, p.x_nm, p.y_nm, p.radius_nm) for p in objs.particles] if objs else [], image=mime)
        meta["position"] = pos
        return meta, image

    def _field(self):
        """The field the frames show: the first scan's, whole (scan_initial.gsf,
        in m; docs/data.md), as [x0, y0, side] in nm."""
        path = os.path.join(self.run_dir, "scan_initial.gsf")
        try:
            header, _ = gsf.read(path)
            return [float(header.get("XOffset", 0)) * 1e9, float(header.get("YOffset", 0)) * 1e9,
                    float(header["XReal"]) * 1e9]
        except (OSError, KeyError, ValueError):
            return None   # the page then draws no object ids

    def on_message(self, msg):
        """{"type": "seek", "position": K}: frame K."""
        if msg.get("type") != "seek":
            return None
        pos = msg.get("position")
        if not isinstance(pos, int) or not 0 <= pos < len(self.frames):
            return None
        return self.frame(pos)
