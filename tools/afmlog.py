#!/usr/bin/env python3
"""Read a run's bus.lcmlog: decoded messages per channel, with the project's
generated Python types (build/main/lcmtypes). Used by the end-to-end tests and
handy from a Python prompt:

    import afmlog
    log = afmlog.load("runs/demo/bus.lcmlog")
    log["FW_OBJECTS"][-1].particles[0].x_nm
"""
import os
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


def load(path, channels=None):
    """All messages of `path`, decoded, as {channel: [msg, ...]} in log order.
    Channels not in channels.yaml (e.g. LCM_SELF_TEST) are counted under
    their name with raw bytes."""
    out = defaultdict(list)
    log = lcm.EventLog(path, "r")
    for ev in log:
        if channels and ev.channel not in channels:
            continue
        tname = CHANNELS.get(ev.channel)
        if tname is None:
            out[ev.channel].append(ev.data)
            continue
        out[ev.channel].append(getattr(afm, tname).decode(ev.data))
    return out


def by_seq(msgs):
    """{seq: last message with that seq} (resends carry the same content)."""
    return {m.seq: m for m in msgs}


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: afmlog.py bus.lcmlog   (prints message counts per channel)")
    for ch, msgs in sorted(load(sys.argv[1]).items()):
        print(f"{ch:16s} {len(msgs)}")
