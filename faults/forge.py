#!/usr/bin/env python3
"""Forges control messages on a live run's bus, as a hostile process of the
run's namespace could (the fault matrix and tests/e2e/test_hostile.py start
it beside afm_launch under one run/in_netns.sh):

    faults/forge.py finished [--seconds S]   the operator's "finished" heartbeat
                                            (name, pid and seq forged), 50 a second
    faults/forge.py bigscan [--seconds S]    a scan request for 8192 x 8192 px over
                                            the field, 50 a second
    faults/forge.py stop [--seconds S]       the launcher's "stop" heartbeat (name,
                                            pid and seq forged), 50 a second
    faults/forge.py pose [--seconds S]       a pose for block n + 1 as soon as block
                                            n's analog block appears, ahead of the
                                            operator's, steering the tip aside
    faults/forge.py fix [--seconds S]        a HOST_OBJECT_FIX placing particle 1 far
                                            off (fix ids 1..8, each once a second)
    faults/forge.py view [--seconds S]       a VIEW_FRAME with NaN forces and a JPEG
                                            that is not one, 25 a second

--spoof PROGRAM sends each forgery from a raw socket with the source port of
PROGRAM's sending socket in this namespace (afm_launch, operator, renderer,
...; its UDP socket not bound to the bus's port), as a raw socket in the
run's namespace can (it needs CAP_NET_RAW there: the fault matrix keeps it
for the forger alone). The source port is then that of a process of the run
that publishes the channel: only the bus's MAC (bus/bus_key.hpp) tells
the forgery apart, and every receiver counts it (run.json: each process's
rejected.unproven, by reason and channel).

Prints a JSON line with what it sent. What the bench does against these:
every process admits a message only from the run's own process that
publishes its channel, as the kernel names the sender's socket
(bus/senders.hpp): each forgery is counted foreign and never acted on.
Behind that, sim_afm takes "finished" only where a planner runs, and scan
requests only of at most four fields a side at no less than half the finest
pitch of the scene's own scans (sim_afm/main.cpp)."""
import argparse
import json
import os
import signal
import socket
import struct
import sys
import time

import lcm

from analysis import afmlog

BUS_URL = "udpm://239.255.76.67:7667?ttl=0"
GROUP, PORT = "239.255.76.67", 7667


def sending_port(program):
    """The local port of `program`'s UDP socket not bound to the bus's port,
    in this network namespace (its /proc/PID/fd and /proc/net/udp); None
    while no such process or socket is there."""
    ports = {}
    for path in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            with open(path) as f:
                next(f)
                for line in f:
                    col = line.split()
                    ports[int(col[9])] = int(col[1].rsplit(":", 1)[1], 16)
        except OSError:
            pass
    me = os.readlink("/proc/self/ns/net")
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            if os.path.basename(os.readlink(f"/proc/{d}/exe")) != program or os.readlink(f"/proc/{d}/ns/net") != me:
                continue
            for fd in os.listdir(f"/proc/{d}/fd"):
                link = os.readlink(f"/proc/{d}/fd/{fd}")
                if link.startswith("socket:["):
                    port = ports.get(int(link[8:-1]))
                    if port and port != PORT:
                        return port
        except OSError:
            continue
    return None


class Spoofer:
    """Publishes LCM short messages from a raw socket, the UDP source port
    that of `program`'s sending socket (looked up again until found)."""

    def __init__(self, program):
        self.program, self.port, self.seq = program, None, 0
        self.s = socket.socket(socket.AF_INET, socket.SOCK_RAW, socket.IPPROTO_RAW)   # IP_HDRINCL implied

    def publish(self, channel, data):
        if self.port is None:
            self.port = sending_port(self.program)
            if self.port is None:
                return False
        self.seq += 1
        payload = struct.pack(">II", 0x4C433032, self.seq) + channel.encode() + b"\0" + data
        udp = struct.pack(">HHHH", self.port, PORT, 8 + len(payload), 0) + payload   # checksum 0: none (IPv4)
        src, dst = socket.inet_aton("127.0.0.1"), socket.inet_aton(GROUP)
        ip = struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(udp), 0, 0, 1, socket.IPPROTO_UDP, 0, src, dst)
        self.s.sendto(ip + udp, (GROUP, 0))
        return True


class Plain:
    """Publishes through liblcm, from a socket of its own."""

    def __init__(self, lc):
        self.lc = lc

    def publish(self, channel, data):
        self.lc.publish(channel, data)
        return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=["finished", "bigscan", "stop", "pose", "fix", "view"])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--spoof", metavar="PROGRAM", help="send from PROGRAM's source port, through a raw socket")
    a = ap.parse_args()
    afm = afmlog.afm
    lc = lcm.LCM(os.environ.get("LCM_DEFAULT_URL", BUS_URL))
    out = Spoofer(a.spoof) if a.spoof else Plain(lc)
    # SIGTERM (the runner, once the run is over) ends the loop where it
    # stands, never inside a callback of liblcm's
    signal.signal(signal.SIGTERM, lambda *_: STOP.append(1))
    signal.signal(signal.SIGINT, lambda *_: STOP.append(1))
    n, t0 = 0, time.monotonic()
    if a.what == "pose":
        n = forge_poses(lc, out, afm, a.seconds)
    else:
        while time.monotonic() - t0 < a.seconds and not STOP:
            channel, m = forgery(afm, a.what, n)
            n += out.publish(channel, m.encode())
            time.sleep(0.04 if a.what == "view" else 0.02)
    print(json.dumps({"sent": {a.what: n}, "total": n, "seconds": time.monotonic() - t0,
                      "spoofed_port": getattr(out, "port", None)}), flush=True)
    return 0


STOP = []   # set by SIGTERM or SIGINT


def forgery(afm, what, n):
    """(channel, message) of the n-th forgery of kind `what`."""
    now = int(time.time() * 1e6)
    if what == "stop":
        m = afm.heartbeat_t()
        m.utime, m.name, m.pid, m.state, m.seq, m.sim_utime, m.detail = now, "launcher", os.getppid(), "stop", 100, 101000, "forged"
        return "AFM_HEARTBEAT", m
    if what == "finished":
        m = afm.heartbeat_t()
        m.utime, m.name, m.pid, m.state, m.seq, m.sim_utime, m.detail = now, "operator", 4242, "finished", 100, 101000, ""
        return "AFM_HEARTBEAT", m
    if what == "fix":
        m = afm.object_fix_t()
        m.utime, m.fix_id, m.object_id, m.scan_x_nm, m.scan_y_nm, m.kind = 40000, 1 + (n // 50) % 8, 1, 700.0, 700.0, 1
        return "HOST_OBJECT_FIX", m
    if what == "view":
        m = afm.view_frame_t()
        m.utime, m.index, m.frames_total, m.seq, m.width, m.height = n * 40000, n, 1000, n * 40, 64, 64
        m.field_nm, m.tip_nm = [0.0, 0.0, 2000.0], [float("nan"), 0.0]
        m.force_nN, m.hand_N = [float("nan")] * 3, [0.0] * 3
        m.jpeg = b"\xff\xd8 not a jpeg"
        m.n_jpeg = len(m.jpeg)
        return "VIEW_FRAME", m
    m = afm.scan_req_t()
    m.utime, m.req_id, m.x0_nm, m.y0_nm, m.width_nm, m.height_nm = now, 999, -1000, -1000, 2000, 2000
    m.nx = m.ny = 8192
    m.first_line, m.n_lines, m.at_seq = 0, 8192, -1
    return "AFM_SCAN_REQ", m


def forge_poses(lc, out, afm, seconds):
    """For each analog block n heard, at once a pose for n + 1 that steers the
    joystick to a corner, before the operator's own answer."""
    sent = {"n": 0}

    def on_analog(_channel, data):
        try:
            blk = afm.analog_block_t.decode(data)
        except Exception:
            return
        m = afm.haptic_pose_t()
        m.utime, m.seq, m.joy, m.load_nN, m.engaged = blk.utime, blk.seq + 1, [0.9, 0.9, 0.0], 5.0, True
        sent["n"] += out.publish("HAPTIC_POSE", m.encode())

    lc.subscribe("AFM_ANALOG", on_analog)
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds and not STOP:
        try:
            lc.handle_timeout(50)
        except OSError:   # a signal during the wait (STOP says whether to end)
            pass
    return sent["n"]


if __name__ == "__main__":
    sys.exit(main())
