#!/usr/bin/env python3
"""Forges control messages on a live run's bus, as a hostile process of the
run's namespace could (the fault matrix and tests/e2e/test_hostile.py start
it beside afm_launch under one tools/in_netns.sh):

    tools/forge.py finished [--seconds S]   the operator's "finished" heartbeat
                                            (name, pid and seq forged), 50 a second
    tools/forge.py bigscan [--seconds S]    a scan request for 8192 x 8192 px over
                                            the field, 50 a second
    tools/forge.py stop [--seconds S]       the launcher's "stop" heartbeat (name,
                                            pid and seq forged), 50 a second
    tools/forge.py pose [--seconds S]       a pose for block n + 1 as soon as block
                                            n's analog block appears, ahead of the
                                            operator's, steering the tip aside

Prints a JSON line with what it sent. What the bench does against these:
every process admits a message only from the run's own process that
publishes its channel, as the kernel names the sender's socket
(common/senders.hpp): each forgery is counted foreign and never acted on.
Behind that, sim_afm takes "finished" only where a planner runs, and scan
requests only of at most four fields a side at no less than half the finest
pitch of the scene's own scans (sim_afm/main.cpp)."""
import argparse
import json
import os
import signal
import sys
import time

import lcm

from analysis import afmlog

BUS_URL = "udpm://239.255.76.67:7667?ttl=0"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=["finished", "bigscan", "stop", "pose"])
    ap.add_argument("--seconds", type=float, default=5.0)
    a = ap.parse_args()
    afm = afmlog.afm
    lc = lcm.LCM(os.environ.get("LCM_DEFAULT_URL", BUS_URL))
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    n, t0 = 0, time.monotonic()
    if a.what == "pose":
        return forge_poses(lc, afm, a.seconds)
    try:
        while time.monotonic() - t0 < a.seconds:
            if a.what == "stop":
                m = afm.heartbeat_t()
                m.utime, m.name, m.pid, m.state, m.seq, m.sim_utime, m.detail = int(time.time() * 1e6), "launcher", os.getppid(), \
                    "stop", 100, 101000, "forged"
                lc.publish("AFM_HEARTBEAT", m.encode())
            elif a.what == "finished":
                m = afm.heartbeat_t()
                m.utime, m.name, m.pid, m.state, m.seq, m.sim_utime, m.detail = int(time.time() * 1e6), "operator", 4242, \
                    "finished", 100, 101000, ""
                lc.publish("AFM_HEARTBEAT", m.encode())
            else:
                m = afm.scan_req_t()
                m.utime, m.req_id, m.x0_nm, m.y0_nm, m.width_nm, m.height_nm = int(time.time() * 1e6), 999, -1000, -1000, 2000, 2000
                m.nx = m.ny = 8192
                m.first_line, m.n_lines, m.at_seq = 0, 8192, -1
                lc.publish("AFM_SCAN_REQ", m.encode())
            n += 1
            time.sleep(0.02)
    except KeyboardInterrupt:
        pass
    print(json.dumps({"sent": {a.what: n}, "total": n, "seconds": time.monotonic() - t0}), flush=True)
    return 0


def forge_poses(lc, afm, seconds):
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
        lc.publish("HAPTIC_POSE", m.encode())
        sent["n"] += 1

    lc.subscribe("AFM_ANALOG", on_analog)
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < seconds:
            lc.handle_timeout(50)
    except KeyboardInterrupt:
        pass
    print(json.dumps({"sent": {"pose": sent["n"]}, "total": sent["n"], "seconds": time.monotonic() - t0}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
