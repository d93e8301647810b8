"""Read a run's bus.lcmlog: decoded messages per channel, with the project's
generated Python types (build/main/lcmtypes), and its objects made whole by
the bus processes' own reader (build/main/common/libafm_objects_view_c.so).
Used by the end-to-end tests and the analyses, and handy from the venv's
Python (the package is installed in .venv by the setup; no sys.path edits):

    from analysis import afmlog
    log = afmlog.load("runs/demo/bus.lcmlog")
    afmlog.whole_objects(log["FW_STATE"], lambda m: m.objects)[-1][1].particles[0].x_nm

events() is the one pass over a log that everything here makes (load, and
analysis.runs.open_run and the export, which also need each event's log
timestamp); strict, it refuses a log that does not end on a whole event.
"""
import ctypes
import os
import struct
import sys
from collections import defaultdict

import lcm

from analysis import paths


def _types_dir():
    """The generated Python types: they live in the build tree, never in the
    source tree (AFM_LCMTYPES_PY overrides, e.g. for another build)."""
    return os.environ.get("AFM_LCMTYPES_PY", os.path.join(paths.BUILD, "lcmtypes"))


# The one place the build tree's generated package is put on the path.
sys.path.insert(0, _types_dir())
import afm  # noqa: E402  (generated at build time)

# Channel -> type, from the one table of channels.
import yaml  # noqa: E402

with open(os.path.join(paths.ROOT, "lcmtypes", "channels.yaml")) as f:
    CHANNELS = {row["channel"]: row["type"] for row in yaml.safe_load(f)}


class Log(defaultdict):
    """{channel: [msg, ...]}, and .undecodable: {channel: count} of the
    datagrams on a known channel that do not decode as its type (a hostile
    or broken sender: the bench's processes refused them too); .truncated_at:
    None, or the byte offset where the log stops being whole events."""

    def __init__(self):
        super().__init__(list)
        self.undecodable = defaultdict(int)
        self.truncated_at = None


class LogError(ValueError):
    """A log that does not read whole: truncated or corrupt (its message
    names the file and the byte offset)."""


EVENT_HEADER_BYTES = 28   # LCM's log framing: sync, event number, timestamp, channel and data lengths


class Event:
    """One event of a log: its recording time (timestamp, microseconds since
    the epoch, the recorder's clock), channel, raw data, and msg: decoded as
    the channel's type, the raw bytes for a channel not in channels.yaml,
    or None when it does not decode."""
    __slots__ = ("timestamp", "channel", "data", "msg")

    def __init__(self, timestamp, channel, data, msg):
        self.timestamp, self.channel, self.data, self.msg = timestamp, channel, data, msg


def _decode(channel, data):
    tname = CHANNELS.get(channel)
    if tname is None:
        return data
    try:
        return getattr(afm, tname).decode(data)
    except (ValueError, struct.error, UnicodeDecodeError, MemoryError, OverflowError):
        return None


def events(path, channels=None, strict=True, on_end=None):
    """The events of `path` in log order (Event), the one way this package
    reads a log. strict: a log that does not end on a whole event raises
    LogError naming the file and the offset after the last whole event;
    otherwise on_end(offset or None) is told where it stopped. A missing
    file raises FileNotFoundError (LCM's)."""
    log = lcm.EventLog(path, "r")
    size = os.path.getsize(path)
    offset = 0
    for ev in log:
        offset += EVENT_HEADER_BYTES + len(ev.channel.encode()) + len(ev.data)
        if channels and ev.channel not in channels:
            continue
        yield Event(ev.timestamp, ev.channel, ev.data, _decode(ev.channel, ev.data))
    stopped = offset if offset != size else None
    if stopped is not None and strict:
        raise LogError(f"{path}: truncated or corrupt: whole events end at byte {offset} of {size}")
    if on_end:
        on_end(stopped)


def load(path, channels=None):
    """All messages of `path`, decoded, as {channel: [msg, ...]} in log order.
    Channels not in channels.yaml (e.g. LCM_SELF_TEST) are counted under
    their name with raw bytes. A message that does not decode as its
    channel's type is left out and counted in .undecodable. A log cut short
    reads up to its last whole event (.truncated_at says where it stopped)."""
    out = Log()

    def ended(at):
        out.truncated_at = at

    for ev in events(path, channels, strict=False, on_end=ended):
        if ev.msg is None:
            out.undecodable[ev.channel] += 1
        else:
            out[ev.channel].append(ev.msg)
    return out


def column(msgs, name):
    """One field of every message, as a numpy array: a number per message,
    or a row per message for a fixed-size array field. For a notebook:

        log = afmlog.load("runs/demo/bus.lcmlog")
        force = afmlog.column(log["FW_STATE"], "force_nN")   # (blocks, 3), nN, frame A
        seq = afmlog.column(log["FW_STATE"], "seq")"""
    import numpy as np
    return np.array([getattr(m, name) for m in msgs])


def by_seq(msgs):
    """{seq: last message with that seq} (resends carry the same content)."""
    return {m.seq: m for m in msgs}


def _objects_lib():
    """The bus processes' reader of objects messages (common/objects_view.hpp)
    behind its C interface (common/objects_view_c.h), built beside the
    generated types."""
    global _LIB
    if _LIB is None:
        path = os.path.join(os.path.dirname(os.path.abspath(_types_dir())), "common", "libafm_objects_view_c.so")
        if not os.path.exists(path):
            raise FileNotFoundError(f"afmlog: {path} is missing: build the bench first (./afm build)")
        lib = ctypes.CDLL(path)
        lib.afm_objects_view_new.restype = ctypes.c_void_p
        lib.afm_objects_view_free.argtypes = [ctypes.c_void_p]
        lib.afm_objects_view_apply.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t, _PLACED, ctypes.c_void_p]
        lib.afm_objects_view_apply.restype = ctypes.c_int
        _LIB = lib
    return _LIB


_LIB = None
_PLACED = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int64, ctypes.c_int32, ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t)


def whole_objects(msgs, objects=lambda m: m):
    """The objects after each message placed, whole: [(msg, whole), ...] in
    the order they were placed; each whole is an objects_t with every
    object (complete). A message may list only the objects that changed
    (objects_t.complete false: lcmtypes/objects_t.lcm). `objects` picks the
    objects_t out of a message (SIM_TRUTH: lambda m: m.objects).

    The reading is ObjectsView's (common/objects_view.hpp), the renderer's
    and the operator's own, called through its C interface: a message
    recorded before the one it follows (the bus reordered them) is held, at
    most objects_t.MAX_HELD, and placed after it, as is one recorded before
    the first complete one; a resend or an older message reads as the set
    it finds; messages after a missed one, until the next complete one, and
    one that names an object the set does not hold, are left out."""
    lib = _objects_lib()
    view = lib.afm_objects_view_new()
    if not view:
        raise MemoryError("afmlog: cannot make an objects reader")
    out, held, cur, placed, failed = [], {}, None, [], []

    def on_placed(_ctx, seq, fix_id, data, n):
        try:
            placed.append(((seq, fix_id), afm.objects_t.decode(ctypes.string_at(data, n))))
        except Exception as e:   # ctypes would print it and go on: keep it for the caller
            failed.append(e)

    callback = _PLACED(on_placed)
    try:
        for msg in msgs:
            m = objects(msg)
            key = (m.seq, m.fix_id)
            data = m.encode()
            placed.clear()
            r = lib.afm_objects_view_apply(view, data, len(data), callback, None)
            if failed:
                raise failed[0]
            if r < 0:
                raise ValueError(f"afmlog: the objects reader refused message {key} (it does not decode, or out of memory)")
            if r == 1:
                held.setdefault(key, msg)   # the first recorded, as a resend carries the same
            elif r == 0 and not placed and cur is not None:
                out.append((msg, cur))   # a resend of the message last placed (or an older one)
            for k, whole in placed:
                out.append((msg if k == key else held.pop(k, msg), whole))
                cur = whole
            if placed and held:   # those the reader let go, made old by the set
                for k in [k for k in held if k <= (cur.seq, cur.fix_id)]:
                    del held[k]
    finally:
        lib.afm_objects_view_free(view)
    return out


def whole_by_seq(msgs, objects=lambda m: m):
    """{seq: the whole objects after the last message of that block}."""
    return {w.seq: w for _, w in whole_objects(msgs, objects)}


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python -m analysis.afmlog bus.lcmlog   (prints message counts per channel)")
    for ch, msgs in sorted(load(sys.argv[1]).items()):
        print(f"{ch:16s} {len(msgs)}")
