"""What a run's trajectory is, for holding two runs of one scene equal block
by block (./afm faults, faults/faults.py; tests/e2e/test_hosts.py): the
simulator's truth and the card's answers, by block. The one owner of that
definition; callers import it.

    CHANNELS                   (channel, the field that numbers its block)
    read(out, blocks)          {channel: {block: the message's encoded bytes}}
                               for blocks 0 <= n < blocks of the run folder
                               out's bus.lcmlog, the first message of each
                               block; raises what afmlog.load raises when the
                               log does not read."""
import os

from analysis import afmlog

CHANNELS = [("SIM_TRUTH", "seq"), ("AFM_CMD", "ack_seq"), ("FW_STATE", "seq"), ("HAPTIC_POSE", "seq")]


def read(out, blocks):
    log = afmlog.load(os.path.join(out, "bus.lcmlog"), channels=[c for c, _ in CHANNELS])
    traj = {}
    for ch, field in CHANNELS:
        d = {}
        for m in log[ch]:
            q = getattr(m, field)
            if 0 <= q < blocks:
                d.setdefault(q, m.encode())
        traj[ch] = d
    return traj
