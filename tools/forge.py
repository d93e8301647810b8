#!/usr/bin/env python3
"""Forges control messages on a live run's bus, as a hostile process of the
run's namespace could (the fault matrix and tests/e2e/test_hostile.py start
it beside afm_launch under one tools/in_netns.sh):

    tools/forge.py finished [--seconds S]   the operator's "finished" heartbeat
                                            (name, pid and seq forged), 50 a second
    tools/forge.py bigscan [--seconds S]    a scan request for 8192 x 8192 px over
                                            the field, 50 a second

Prints a JSON line with what it sent. What the bench does against these:
sim_afm takes "finished" only where a planner runs, and scan requests only
of at most four fields a side at no less than half the finest pitch of the
scene's own scans (sim_afm/main.cpp)."""
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
    ap.add_argument("what", choices=["finished", "bigscan"])
    ap.add_argument("--seconds", type=float, default=5.0)
    a = ap.parse_args()
    afm = afmlog.afm
    lc = lcm.LCM(os.environ.get("LCM_DEFAULT_URL", BUS_URL))
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    n, t0 = 0, time.monotonic()
    try:
        while time.monotonic() - t0 < a.seconds:
            if a.what == "finished":
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


if __name__ == "__main__":
    sys.exit(main())
