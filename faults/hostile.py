#!/usr/bin/env python3
"""Publishes hostile datagrams into a live run's bus: every kind of message a
process of the bench must count and drop (bus/inbox.hpp) on every channel
someone listens to. Run it inside the run's network namespace (the test and
./afm faults start it beside afm_launch under one run/in_netns.sh).

    faults/hostile.py [--seconds S] [--rate HZ] [--kinds K,K,...] [--seed N]

Kinds (each datagram is one of them):
  truncated     a valid message of the channel's type cut short
  fingerprint   random bytes behind a fingerprint no type has
  wrong_type    a valid message of another bus type
  array_length  a valid message whose array length field says 2^31 - 1
  non_finite    a valid message with a NaN or an infinity in a double
  seq_past      a valid message of a block long gone (seq -5)
  seq_future    a valid message of a block far ahead (seq 10^12)
  flood         random bytes at the full rate for the whole time
  fragment_claim  only this, at the full rate: a 40-odd-byte fragment 0 of a
                message that claims 16 MiB in 300 fragments, whose other
                fragments never come (each receiver must not hold 16 MiB for it)
The first seven are sent once per channel every cycle, spread over the run;
the flood fills the other half of the rate. Prints a JSON line with what was sent,
by kind and by channel, on exit.

None of them is a plausible message of the run (a spoofed block with the
right seq and time is not a fault the bench can tell from the truth), so a
run that receives them must end exactly as one that did not.
"""
import argparse
import json
import math
import os
import random
import signal
import struct
import sys
import time
from collections import defaultdict

import lcm

from analysis import afmlog, paths   # the generated types and the one table of channels, through the log reader

afm = afmlog.afm
CHANNELS = afmlog.CHANNELS

KINDS = ["truncated", "fingerprint", "wrong_type", "array_length", "non_finite", "seq_past", "seq_future", "flood",
         "fragment_claim"]
# Channels whose valid messages a process would act on (others only count).
SEQ_FIELDS = ("seq", "ack_seq", "at_seq", "index", "fix_id")
# Arrays of structs (the filler cannot read an element's type off the class).
STRUCT_ARRAYS = {"particles": "particle_t", "wires": "wire_t", "trenches": "trench_t"}
BUS_URL = "udpm://239.255.76.67:7667?ttl=0"


NO_BLOCK = -7   # the sequence of every hostile message that is not about sequences: no run has it


def example(tname, seq=NO_BLOCK, count=None, bad_double=None):
    """A message of type `tname` with every field filled plausibly; `seq`
    goes into every sequence field (by default one no run has, so that a
    run's own messages stay apart in its log); `count`, when given, into the
    first array length (arrays sized to it); `bad_double` into the first
    double."""
    m = getattr(afm, tname)()
    first_count, first_double = [True], [True]

    def fill(obj):
        for name in obj.__slots__:
            v = getattr(obj, name)
            if name in ("seq", "ack_seq", "at_seq", "base_seq"):
                setattr(obj, name, seq)
            elif name in ("index", "fix_id"):
                setattr(obj, name, max(min(seq, 2**31 - 1), -2**31))
            elif isinstance(v, float):
                if bad_double is not None and first_double[0]:
                    setattr(obj, name, bad_double)
                    first_double[0] = False
                else:
                    setattr(obj, name, 1.0)
            elif isinstance(v, list) and v and isinstance(v[0], float):
                vals = [1.0] * len(v)
                if bad_double is not None and first_double[0]:
                    vals[0] = bad_double
                    first_double[0] = False
                setattr(obj, name, vals)
            elif isinstance(v, str):
                setattr(obj, name, "hostile")
    fill(m)
    if count is not None:
        # the first count field sizes the arrays behind it: fill them
        for name in m.__slots__:
            if name == "n" or name.startswith("n_"):
                if first_count[0]:
                    setattr(m, name, count)
                    first_count[0] = False
                    arrays = [a for a in m.__slots__ if isinstance(getattr(m, a), list) and a not in ("joy",)]
                    for a in arrays:
                        cur = getattr(m, a)
                        if a in STRUCT_ARRAYS:
                            setattr(m, a, [example(STRUCT_ARRAYS[a]) for _ in range(count)])
                        elif not cur or isinstance(cur[0], float):
                            setattr(m, a, [1.0] * count)
    return m


def encode(m):
    try:
        return m.encode()
    except Exception:  # a type whose arrays the filler cannot size: skip it
        return None


def datagrams(channel, kind, rng):
    """The hostile datagrams of `kind` for `channel` (bytes), may be empty."""
    tname = CHANNELS[channel]
    valid = encode(example(tname))
    out = []
    if kind == "truncated" and valid:
        out.append(valid[: max(1, len(valid) // 2)])
    elif kind == "fingerprint":
        out.append(bytes(rng.getrandbits(8) for _ in range(8 + rng.randrange(64))))
    elif kind == "wrong_type":
        other = next(t for t in sorted(set(CHANNELS.values())) if t != tname and encode(example(t)))
        out.append(encode(example(other)))
    elif kind == "array_length":
        # the message with 3 elements, its count field (found by encoding it
        # with 3 and with 4 elements) replaced by 2^31 - 1
        a, b = encode(example(tname, count=3)), encode(example(tname, count=4))
        if a and b:
            i = next((k for k in range(min(len(a), len(b)) - 3)
                      if a[k:k + 4] == struct.pack(">i", 3) and b[k:k + 4] == struct.pack(">i", 4)), None)
            if i is not None:
                out.append(a[:i] + struct.pack(">i", 2**31 - 1) + a[i + 4:])
    elif kind == "non_finite":
        for bad in (math.nan, math.inf, -math.inf):
            d = encode(example(tname, bad_double=bad))
            if d:
                out.append(d)
    elif kind == "seq_past":
        d = encode(example(tname, seq=-5))
        if d and any(n in SEQ_FIELDS for n in getattr(afm, tname).__slots__):
            out.append(d)
    elif kind == "seq_future":
        d = encode(example(tname, seq=10**12))
        if d and any(n in SEQ_FIELDS for n in getattr(afm, tname).__slots__):
            out.append(d)
    elif kind == "flood":
        out.append(bytes(rng.getrandbits(8) for _ in range(8 + rng.randrange(200))))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=5.0, help="how long to send (wall seconds; default 5)")
    ap.add_argument("--rate", type=float, default=2000.0, help="datagrams per wall second in all (default 2000)")
    ap.add_argument("--kinds", default=",".join(k for k in KINDS if k != "fragment_claim"),
                    help="comma-separated kinds (default: all but fragment_claim, which is sent alone)")
    ap.add_argument("--channels", default="", help="comma-separated channels (default: every channel)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--delay", type=float, default=0.0, help="wait this many wall seconds first")
    ap.add_argument("--echo", type=float, default=0.0, metavar="P",
                    help="instead: send each message seen on the bus once more with probability P, 0-5 ms later "
                         "(duplicates, reordered against what follows them)")
    a = ap.parse_args()
    if a.echo > 0:
        return echo(a)
    kinds = [k for k in a.kinds.split(",") if k]
    for k in kinds:
        if k not in KINDS:
            ap.error(f"--kinds: unknown kind '{k}' (known: {', '.join(KINDS)})")
    if "fragment_claim" in kinds:
        if kinds != ["fragment_claim"]:
            ap.error("--kinds: fragment_claim is sent alone")
        return fragment_claims(a)
    # A valid heartbeat with a process's name would be a spoof: the
    # hostile ones are named "hostile" (the launcher refuses the name).
    channels = [c for c in a.channels.split(",") if c] or [c for c in CHANNELS]
    rng = random.Random(a.seed)
    lc = lcm.LCM(os.environ.get("LCM_DEFAULT_URL", BUS_URL))
    cycle = []
    for ch in channels:
        for k in kinds:
            if k == "flood":
                continue
            if ch == "AFM_HEARTBEAT" and k in ("wrong_type", "non_finite"):
                continue
            for d in datagrams(ch, k, rng):
                cycle.append((k, ch, d))
    sent = defaultdict(lambda: defaultdict(int))
    # SIGTERM (the run is over) ends the sending as SIGINT does: a shell's
    # background job ignores SIGINT, so callers stop it with SIGTERM.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    time.sleep(a.delay)
    t0 = time.monotonic()
    try:
        send(a, kinds, channels, cycle, rng, lc, sent, t0)
    except KeyboardInterrupt:   # SIGINT or SIGTERM: the run is over
        pass
    total = sum(sum(v.values()) for v in sent.values())
    print(json.dumps({"sent": {k: dict(v) for k, v in sent.items()}, "total": total, "seconds": time.monotonic() - t0}), flush=True)


def echo(a):
    """Each datagram on the bus once more, with probability a.echo, after
    0-5 ms: a network that duplicates and reorders (where tc netem is not
    in the kernel)."""
    import heapq
    rng = random.Random(a.seed)
    lc = lcm.LCM(os.environ.get("LCM_DEFAULT_URL", BUS_URL))
    due, seen, n = [], set(), [0, 0]

    def on(channel, data):
        key = hash((channel, data))
        if key in seen:          # our own echo (or a resend, echoed already)
            return
        if len(seen) > 200000:
            seen.clear()
        seen.add(key)
        n[0] += 1
        if rng.random() < a.echo:
            heapq.heappush(due, (time.monotonic() + rng.uniform(0, 0.005), n[0], channel, data))

    lc.subscribe(".*", on)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < a.seconds:
            lc.handle_timeout(1)
            while due and due[0][0] <= time.monotonic():
                _, _, ch, d = heapq.heappop(due)
                lc.publish(ch, d)
                n[1] += 1
    except KeyboardInterrupt:
        pass
    print(json.dumps({"seen": n[0], "echoed": n[1], "seconds": time.monotonic() - t0}), flush=True)
    return 0


def fragment_claims(a):
    """Raw datagrams to the bus's group and port: each an LCM fragment 0
    ("LC03", seq, a 16 MiB message size, offset 0, fragment 0 of 300,
    channel FW_STATE, 10 bytes), a new message number each time."""
    import socket
    from urllib.parse import urlsplit
    u = urlsplit(os.environ.get("LCM_DEFAULT_URL", BUS_URL))
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
    period = 1.0 / a.rate if a.rate > 0 else 0.01
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    time.sleep(a.delay)
    t0 = next_t = time.monotonic()
    n = 0
    try:
        while time.monotonic() - t0 < a.seconds:
            d = struct.pack(">IIIIHH", 0x4C433033, 0x70000000 + n, 16 << 20, 0, 0, 300) + b"FW_STATE\0" + bytes(10)
            s.sendto(d, (u.hostname, u.port))
            n += 1
            next_t += period
            delay = next_t - time.monotonic()
            if delay > 0:
                time.sleep(delay)
    except KeyboardInterrupt:
        pass
    print(json.dumps({"sent": {"fragment_claim": {"raw": n}}, "total": n, "seconds": time.monotonic() - t0}), flush=True)
    return 0


def send(a, kinds, channels, cycle, rng, lc, sent, t0):
    period = 1.0 / a.rate if a.rate > 0 else 0.01
    i = 0
    next_t = t0
    while time.monotonic() - t0 < a.seconds:
        if cycle and (i % 2 == 0 or "flood" not in kinds):
            k, ch, d = cycle[(i // 2 if "flood" in kinds else i) % len(cycle)]
        else:
            k, ch = "flood", rng.choice(channels)
            d = datagrams(ch, "flood", rng)[0]
        lc.publish(ch, d)
        sent[k][ch] += 1
        i += 1
        next_t += period
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)



def run_beside(launch, scene, out, rate=2000.0, kinds=None, admit_any=False, python=sys.executable):
    """Runs `launch --scene SCENE --out OUT --quiet` in a fresh namespace
    (run/in_netns.sh) with this script sending beside it from before the
    start to the end. admit_any: every process admits every sender
    (AFM_ADMIT_ANY_SENDER=1), so that the inboxes' own checks meet the
    datagrams; else they are foreign (bus/senders.hpp). Returns
    (exit code, stderr, run.json, what was sent); the one runner of
    tests/e2e/test_hostile.py and ./afm bench hostile."""
    import subprocess
    extra = f" --kinds {kinds}" if kinds else ""
    script = ('"$PY" "$HOSTILE" --seconds 300 --rate "$RATE"' + extra + ' > "$SENT" & h=$!; '
              '"$LAUNCH" --scene "$SCENE" --out "$OUT" --quiet; rc=$?; kill -TERM $h; wait $h; exit $rc')
    sent_path = out.rstrip("/") + ".sent.json"
    env = dict(os.environ, PY=python, HOSTILE=os.path.abspath(__file__), RATE=str(rate), OUT=out, SENT=sent_path,
               LAUNCH=launch, SCENE=scene, AFM_ADMIT_ANY_SENDER="1" if admit_any else "0",
               AFM_RUN_WRITES=os.path.dirname(sent_path))   # the folders the script writes, for the run's user (in_netns.sh)
    p = subprocess.run([paths.IN_NETNS, "sh", "-c", script], capture_output=True, text=True,
                       timeout=400, env=env)
    try:
        with open(os.path.join(out, "run.json")) as f:
            rj = json.load(f)
    except OSError as e:
        raise RuntimeError(f"hostile: the run wrote no run.json in {out} (exit {p.returncode}): {p.stderr[-1500:]}") from e
    with open(sent_path) as f:
        sent = json.load(f)
    os.remove(sent_path)
    return p.returncode, p.stderr, rj, sent

if __name__ == "__main__":
    sys.exit(main())
