#!/usr/bin/env python3
"""Read a run's bus.lcmlog: decoded messages per channel, with the project's
generated Python types (build/main/lcmtypes). Used by the end-to-end tests and
handy from a Python prompt:

    import afmlog
    log = afmlog.load("runs/demo/bus.lcmlog")
    afmlog.whole_objects(log["FW_STATE"], lambda m: m.objects)[-1][1].particles[0].x_nm
"""
import copy
import os
import struct
import sys
from collections import defaultdict

import lcm

HERE = os.path.dirname(os.path.abspath(__file__))


def _types_dir():
    return os.environ.get("AFM_LCMTYPES_PY", os.path.join(HERE, "..", "build", "main", "lcmtypes"))


sys.path.insert(0, _types_dir())
import afm  # noqa: E402  (generated at build time)

# Channel -> type, from the one table of channels.
import yaml  # noqa: E402

with open(os.path.join(HERE, "..", "lcmtypes", "channels.yaml")) as f:
    CHANNELS = {row["channel"]: row["type"] for row in yaml.safe_load(f)}


class Log(defaultdict):
    """{channel: [msg, ...]}, and .undecodable: {channel: count} of the
    datagrams on a known channel that do not decode as its type (a hostile
    or broken sender: the bench's processes refused them too)."""

    def __init__(self):
        super().__init__(list)
        self.undecodable = defaultdict(int)


def load(path, channels=None):
    """All messages of `path`, decoded, as {channel: [msg, ...]} in log order.
    Channels not in channels.yaml (e.g. LCM_SELF_TEST) are counted under
    their name with raw bytes. A message that does not decode as its
    channel's type is left out and counted in .undecodable."""
    out = Log()
    log = lcm.EventLog(path, "r")
    for ev in log:
        if channels and ev.channel not in channels:
            continue
        tname = CHANNELS.get(ev.channel)
        if tname is None:
            out[ev.channel].append(ev.data)
            continue
        try:
            out[ev.channel].append(getattr(afm, tname).decode(ev.data))
        except (ValueError, struct.error, UnicodeDecodeError, MemoryError, OverflowError):
            out.undecodable[ev.channel] += 1
    return out


def by_seq(msgs):
    """{seq: last message with that seq} (resends carry the same content)."""
    return {m.seq: m for m in msgs}


class _Whole:
    """objects_t made whole: particles, wires (and the rest) of the set."""

    def __init__(self, m):
        self.utime, self.seq, self.fix_id = m.utime, m.seq, m.fix_id
        self.drift_nm = list(m.drift_nm)
        self.particles = [copy.copy(p) for p in m.particles]
        self.wires = [copy.deepcopy(w) for w in m.wires]
        self.trenches = list(m.trenches)
        self.complete = True


def _place(cur, m):
    """The whole set after changes-only message m, which follows cur."""
    nxt = copy.copy(cur)
    dx, dy = m.drift_nm[0] - cur.drift_nm[0], m.drift_nm[1] - cur.drift_nm[1]
    changed = {p.id: p for p in m.particles}
    nxt.particles = []
    for p in cur.particles:
        q = copy.copy(changed.get(p.id, p))
        if p.id not in changed:
            q.x_nm, q.y_nm = p.x_nm + dx, p.y_nm + dy
        nxt.particles.append(q)
    wchanged = {w.id: w for w in m.wires}
    nxt.wires = []
    for w in cur.wires:
        if w.id in wchanged:
            nxt.wires.append(copy.deepcopy(wchanged[w.id]))
        else:
            v = copy.deepcopy(w)
            v.x_nm = [x + dx for x in w.x_nm]
            v.y_nm = [y + dy for y in w.y_nm]
            nxt.wires.append(v)
    nxt.utime, nxt.seq, nxt.fix_id = m.utime, m.seq, m.fix_id
    nxt.drift_nm = list(m.drift_nm)
    nxt.trenches = list(m.trenches)
    return nxt


def whole_objects(msgs, objects=lambda m: m):
    """The objects after each message placed, whole: [(msg, whole), ...] in
    the order they were placed. A message may list only the objects that
    changed (objects_t.complete false: lcmtypes/objects_t.lcm); the others
    are where the previous message had them, moved by the change in
    drift_nm. `objects` picks the objects_t out of a message (SIM_TRUTH:
    lambda m: m.objects). The reading rule is ObjectsView's
    (common/objects_view.hpp): a message recorded before the one it follows
    (the bus reordered them) is held, at most objects_t.MAX_HELD, and placed
    after it, as is one recorded before the first complete one. Messages
    after a missed one, until the next complete one, are left out."""
    out, cur, held = [], None, []

    def later(a, b):
        return (a.seq, a.fix_id) > (b.seq, b.fix_id)

    for msg in msgs:
        m = objects(msg)
        if cur is not None and not later(m, cur):
            out.append((msg, cur))   # a resend of the message last placed (or an older one)
            continue
        if m.complete:
            cur = _Whole(m)
        elif cur is None or (m.base_seq, m.base_fix_id) != (cur.seq, cur.fix_id):
            if cur is None or (m.base_seq, m.base_fix_id) > (cur.seq, cur.fix_id):   # its base is still to come
                if len(held) >= m.MAX_HELD:   # full: the newest of them and m is let go
                    newest = max(held, key=lambda x: (x[1].seq, x[1].fix_id))
                    if not later(newest[1], m):
                        continue
                    held.remove(newest)
                held.append((msg, m))
            continue   # else one was missed (lcm-logger dropped it): unknown until the next complete one
        else:
            cur = _place(cur, m)
        out.append((msg, cur))
        # the held ones that now follow, in turn; those made old, let go
        while True:
            held = [(hm, h) for hm, h in held if later(h, cur)]
            nxt = next(((hm, h) for hm, h in held if (h.base_seq, h.base_fix_id) == (cur.seq, cur.fix_id)), None)
            if nxt is None:
                break
            held.remove(nxt)
            cur = _place(cur, nxt[1])
            out.append((nxt[0], cur))
    return out


def whole_by_seq(msgs, objects=lambda m: m):
    """{seq: the whole objects after the last message of that block}."""
    return {w.seq: w for _, w in whole_objects(msgs, objects)}


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: afmlog.py bus.lcmlog   (prints message counts per channel)")
    for ch, msgs in sorted(load(sys.argv[1]).items()):
        print(f"{ch:16s} {len(msgs)}")
