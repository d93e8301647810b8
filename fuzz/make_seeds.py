#!/usr/bin/env python3
"""Writes the committed seed corpus of the fuzz targets (fuzz/corpus/TARGET/).

    .venv/bin/python fuzz/make_seeds.py [--types build/main/lcmtypes] [--log runs/demo/bus.lcmlog]

scene:  small scenes of scenes/ and scenes/paper/, copied, and one that
        includes the calibration file the harness keeps beside its input.
lcm:    valid messages of every channel, the channel's name and a NUL
        before the encoded message (fuzz/fuzz_lcm.cpp); the card's
        inputs fit the harness's scene (4 samples per block).
calc:   the calculator's command lines from its --help texts and its test
        (host/calc/test_afm_calc.cmake), one argument per line.
bus:    datagrams for the bus's gatherer: whole fragmented messages,
        fragment-0 headers that claim 16 MiB, repeats, overlaps, fragments
        out of order or without their fragment 0, two senders at once.
lcmlog: small LCM logs written with the lcm package's EventLog: a few events
        of the bus, one cut inside its last event, and the first events of a
        recorded run (--log, when given), each below 20 KB.

The generated Python bindings come from a build tree (--types: a folder
holding the afm/ package lcm-gen wrote). Seeds are rewritten, never added
to: run it again after changing the messages.
"""
import argparse
import copy
import os
import shutil
import sys

import lcm
import yaml

TOP = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORPUS = os.path.join(TOP, "fuzz", "corpus")

SCENES = ["short.yaml", "tilted_calibration.yaml", "lithography.yaml", "wire_plan.yaml", "pattern_ten.yaml",
          "landmark.yaml", "feel.yaml", "drift.yaml", "paper/rod.yaml", "paper/squeeze.yaml", "paper/trench.yaml",
          "paper/lines_push.yaml"]

INCLUDING_SCENE = """\
name: includes-calibration
seed: 5
duration_s: 0.1
include: calibration.yaml
effects: [adhesion]
sample: {substrate: glass, field_nm: 2000, tip_substrate: {mu: 0.0865, adhesion_nN: 1.0}}
objects:
  particles:
    - {id: 1, x_nm: 0, y_nm: -300, radius_nm: 50}
operator:
  load_nN: 5
  speed_nm_per_s: 2000
  path_nm: [[0, -700], [0, -90]]
outputs: {image_px: 64, video: none, png: false}
"""

CALC = {
    "help": ["--help"],
    "tilted": "calib tilted --up 0.07 --down 0.02 --angle-deg 9 --spring-N-per-m 0.12 --deflection-nm-per-V 89 --json".split(),
    "tilted_refused": "calib tilted --up 0.02 --down 0.07 --angle-deg 9 --spring-N-per-m 0.12 --deflection-nm-per-V 89".split(),
    "tilted_write": "calib tilted --up 0.07 --down 0.02 --angle-deg 9 --spring-N-per-m 0.12 --deflection-nm-per-V 89 --write x.yaml".split(),
    "tilted_help": "calib tilted --help".split(),
    "lines": "calib lines --depths-nm 500,1000,1500,2000 --offsets-nm 0,130,260,390 --deflection-nm-per-V 89".split(),
    "lines_write": "calib lines --depths-nm 500,1000 --offsets-nm 0,130 --deflection-nm-per-V 89 --json --write x.yaml".split(),
    "wire": "model wire --length-nm 1300 --diameter-nm 100 --push-at-nm 0 --f-nN-per-um 1 --json".split(),
    "wire_middle": "model wire --length-nm 1300 --diameter-nm 100 --push-at-nm 650".split(),
    "squeeze": "model squeeze --length-nm 1300 --push-at-nm 0 --gamma-deg 20 --mu 0.2 --fl-nN 20 --fa-ts-nN 1 --json".split(),
    "squeezed": "model squeeze --length-nm 1300 --push-at-nm 650 --gamma-deg 44 --twist-deg -2 --mu 1 --fl-nN 20 --fa-ts-nN 1".split(),
    "force": "calc force --sn 1.2 --sl 0.3 --theta-deg 45 --scan-angle-deg 270 --json".split(),
    "force_along": "calc force --sn 1.2 --sl 0.3 --theta-deg 2 --scan-angle-deg 270".split(),
    "probe": "calc probe --json".split(),
}
CALC_PROBE = "calc force --sn 1.2 --sl 0.3 --theta-deg 45 --scan-angle-deg 0 --probe p.txt".split()


def write(target, name, data):
    d = os.path.join(CORPUS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def fresh(target):
    d = os.path.join(CORPUS, target)
    if os.path.isdir(d):
        shutil.rmtree(d)
    os.makedirs(d)


def scene_seeds():
    fresh("scene")
    for s in SCENES:
        with open(os.path.join(TOP, "scenes", s), "rb") as f:
            write("scene", s.replace("/", "_"), f.read())
    write("scene", "includes_calibration.yaml", INCLUDING_SCENE)


def calc_seeds():
    fresh("calc")
    for name, args in CALC.items():
        write("calc", name, "\n".join(args))
    with open(os.path.join(TOP, "host", "calc", "paper_probe.txt")) as f:
        probe = f.read()
    write("calc", "force_probe", "\n".join(CALC_PROBE) + "\n@probe\n" + probe)


N_SAMPLES = 4   # samples per block of the lcm harness's scene


def _block(afm, seq, y):
    b = afm.analog_block_t()
    n = N_SAMPLES
    b.utime, b.seq, b.fs_hz, b.n = seq * 1000, seq, 4000.0, n
    b.sn_v = [0.5 + 0.01 * i for i in range(n)]
    b.sl_v = [0.1] * n
    b.piezo_x_nm = [0.0] * n
    b.piezo_y_nm = [y + 0.5 * i for i in range(n)]
    b.piezo_z_nm = [-20.0] * n
    return b


def _pose(afm, seq, joy):
    p = afm.haptic_pose_t()
    p.utime, p.seq, p.joy, p.load_nN, p.engaged = seq * 1000, seq, joy, 5.0, True
    return p


def _particle(afm, i, x, y):
    p = afm.particle_t()
    p.id, p.x_nm, p.y_nm, p.radius_nm, p.in_contact = i, x, y, 50.0, False
    return p


def _wire(afm, i):
    w = afm.wire_t()
    w.id, w.n, w.x_nm, w.y_nm, w.diameter_nm, w.in_contact = i, 2, [-650.0, 650.0], [400.0, 400.0], 100.0, False
    return w


def _trench(afm):
    t = afm.trench_t()
    t.id, t.n = 1, 3
    t.x_nm, t.y_nm, t.depth_nm, t.width_nm = [0.0, 10.0, 20.0], [5.0] * 3, [40.0] * 3, [29.0] * 3
    return t


def _objects(afm, seq, complete, with_trench=False):
    o = afm.objects_t()
    o.utime, o.seq, o.complete, o.base_seq, o.base_fix_id = seq * 1000, seq, complete, max(seq - 1, 0), 0
    o.particles = [_particle(afm, 1, 0.0, -300.0 + seq)]
    o.wires = [_wire(afm, 2)] if complete else []
    o.trenches = [_trench(afm)] if with_trench else []
    o.n_particles, o.n_wires, o.n_trenches = len(o.particles), len(o.wires), len(o.trenches)
    o.drift_nm = [0.0, 0.0]
    o.fix_id = 0
    return o


def _fix(afm, fix_id, kind):
    f = afm.object_fix_t()
    f.utime, f.fix_id, f.object_id, f.scan_x_nm, f.scan_y_nm, f.kind = 40000, fix_id, 1, 20.0, -310.0, kind
    return f


def _scan_messages(afm):
    """The card's command, a scan request and one of its lines."""
    cmd = afm.tip_cmd_t()
    cmd.utime, cmd.ack_seq, cmd.piezo_x_nm, cmd.piezo_y_nm, cmd.load_nN, cmd.engaged = 1000, 0, 0.0, -698.0, 5.0, True
    req = afm.scan_req_t()
    req.utime, req.req_id, req.x0_nm, req.y0_nm, req.width_nm, req.height_nm = 1, 7, -1000.0, -1000.0, 2000.0, 2000.0
    req.nx, req.ny, req.first_line, req.n_lines, req.at_seq = 64, 64, 0, 64, -1
    line = afm.scan_line_t()
    line.utime, line.req_id, line.line, line.n_lines, line.x0_nm, line.y_nm, line.dx_nm, line.n = 5, 7, 3, 64, -1000.0, -900.0, 31.25, 8
    line.height_nm = [0.1 * i for i in range(8)]
    line.defl_v = [0.0] * 8
    line.lat_v = [0.01] * 8
    return cmd, req, line


def _state_messages(afm):
    """Two FW_STATEs (whole objects, then changes with a trench), HAPTIC_FORCE and SIM_TRUTH."""
    state = afm.fw_state_t()
    state.utime, state.seq, state.force_nN, state.flags, state.sn_code, state.sl_code, state.sat_count = 1000, 0, [1.0, -2.0, 5.0], 32, 1200, -40, 0
    state.tip_nm, state.piezo_nm, state.cmd_nm = [0.0, -699.0, -20.0], [0.0, -698.0, -20.0], [0.0, -698.0]
    state.objects = _objects(afm, 0, True)
    state1 = copy.deepcopy(state)
    state1.utime, state1.seq, state1.objects = 1000, 1, _objects(afm, 1, False, True)
    hf = afm.haptic_force_t()
    hf.utime, hf.seq, hf.force_N, hf.tip_force_nN, hf.flags = 1000, 0, [0.0, 0.1, 0.0], [1.0, -2.0, 5.0], 0
    truth = afm.sim_truth_t()
    truth.utime, truth.seq, truth.tip_nm, truth.piezo_nm, truth.force_nN = 1000, 1, [0.0, -699.0, -20.0], [0.0, -698.0, -20.0], [1.0, 0.0, 5.0]
    truth.objects = _objects(afm, 1, False)
    return state, state1, hf, truth


def _view_frame(afm):
    view = afm.view_frame_t()
    view.utime, view.index, view.frames_total, view.seq, view.skipped, view.width, view.height = 40000, 1, 15, 39, 0, 2, 2
    view.field_nm, view.tip_nm, view.force_nN, view.hand_N, view.flags = [-2500.0, -2500.0, 5000.0], [0.0, -699.0], [1.0, -2.0, 5.0], [0.0, 0.1, 0.0], 32
    view.particles = [_particle(afm, 1, 0.0, -300.0)]
    view.n_particles = 1
    view.sample_utime = [39000, 40000]
    view.sample_fx_nN, view.sample_fy_nN, view.sample_fz_nN = [1.0] * 2, [-2.0] * 2, [5.0] * 2
    view.sample_hand_x_N, view.sample_hand_y_N, view.sample_hand_z_N = [0.0] * 2, [0.1] * 2, [0.0] * 2
    view.n_samples = 2
    view.jpeg = b"\xff\xd8\xff\xd9"
    view.n_jpeg = len(view.jpeg)
    return view


def bus_messages(afm):
    """(channel, message) pairs: valid messages of every channel."""
    cmd, req, line = _scan_messages(afm)
    state, state1, hf, truth = _state_messages(afm)
    frame = afm.render_frame_t()
    frame.utime, frame.index, frame.seq = 40000, 1, 39
    hb = afm.heartbeat_t()
    hb.utime, hb.name, hb.pid, hb.state, hb.seq, hb.sim_utime, hb.detail = 1700000000000000, "fw_node", 42, "running", 3, 4000, "ok"
    return [
        ("AFM_ANALOG", _block(afm, 0, -700.0)), ("AFM_ANALOG", _block(afm, 1, -698.0)),
        ("AFM_CMD", cmd), ("AFM_SCAN_REQ", req), ("AFM_SCAN_LINE", line),
        ("FW_STATE", state), ("FW_STATE", state1),
        ("HAPTIC_POSE", _pose(afm, 0, [0.0, -0.1, 0.0])), ("HAPTIC_POSE", _pose(afm, 0, [0.5, 0.5, 0.0])),
        ("HAPTIC_FORCE", hf), ("SIM_TRUTH", truth), ("RENDER_FRAME", frame), ("AFM_HEARTBEAT", hb),
        ("VIEW_FRAME", _view_frame(afm)),
        ("HOST_OBJECT_FIX", _fix(afm, 1, 0)), ("HOST_OBJECT_FIX", _fix(afm, 1, 1)),
    ]


def bus_seeds():
    """Datagrams for the bus's gatherer (fuzz/fuzz_bus.cpp): an options
    byte, then [sender][length, 2 bytes BE][datagram] records."""
    import struct
    fresh("bus")

    def short(seq, ch, payload):
        return struct.pack(">II", 0x4C433032, seq) + ch.encode() + b"\0" + payload

    def frag(seq, size, offset, no, count, ch, payload):
        head = struct.pack(">IIIIHH", 0x4C433033, seq, size, offset, no, count)
        return head + ((ch.encode() + b"\0") if no == 0 else b"") + payload

    def rec(sender, d):
        return bytes([sender]) + struct.pack(">H", len(d)) + d

    msg = bytes(range(256)) * 12   # 3072 bytes in 3 fragments of 1024
    parts = [frag(7, len(msg), k * 1024, k, 3, "FW_STATE", msg[k * 1024:(k + 1) * 1024]) for k in range(3)]
    whole = b"".join(rec(2, p) for p in parts)
    write("bus", "short_messages", b"\x03" + rec(2, short(1, "AFM_CMD", b"\1" * 40)) + rec(3, short(2, "AFM_CMD", b"\2" * 8)))
    write("bus", "fragmented_whole", b"\x01" + whole)
    write("bus", "fragmented_out_of_order", b"\x00" + rec(2, parts[0]) + rec(2, parts[2]) + rec(2, parts[1]))
    write("bus", "fragment_repeated", b"\x00" + rec(2, parts[0]) + rec(2, parts[1]) + rec(2, parts[1]) + rec(2, parts[2]))
    write("bus", "two_senders_interleaved", b"\x02" + b"".join(rec(2, p) + rec(4, p) for p in parts))
    claim = frag(9, 16 << 20, 0, 0, 300, "SIM_TRUTH", b"\0" * 8)   # a 40-byte header that claims 16 MiB
    write("bus", "header_claims_16MiB", b"\x01" + b"".join(rec(k, claim) for k in range(8)))
    write("bus", "header_claims_too_much", b"\x00" + rec(1, frag(9, (16 << 20) + 1, 0, 0, 300, "SIM_TRUTH", b"")))
    over = frag(7, 100, 90, 1, 2, "", b"x" * 20)   # past the message's end
    write("bus", "fragment_past_its_end", b"\x00" + rec(2, frag(7, 100, 0, 0, 2, "FW_STATE", b"a" * 50)) + rec(2, over))
    write("bus", "fragment_without_its_zero", b"\x00" + rec(2, parts[1]) + rec(2, parts[2]))
    write("bus", "overlapping", b"\x00" + rec(2, frag(7, 100, 0, 0, 2, "FW_STATE", b"a" * 60)) +
          rec(2, frag(7, 100, 30, 1, 2, "", b"b" * 60)))
    write("bus", "many_partials", b"\x00" + b"".join(rec(k % 8, frag(k, 5000, 0, 0, 5, "FW_STATE", b"z" * 100))
                                                  for k in range(40)))


def lcm_seeds(afm, channels):
    fresh("lcm")
    count = {}
    for ch, m in bus_messages(afm):
        k = count.get(ch, 0)
        count[ch] = k + 1
        assert ch in channels, f"{ch}: not a channel of lcmtypes/channels.yaml"
        write("lcm", f"{ch.lower()}_{k}", ch.encode() + b"\0" + m.encode())


def lcmlog_seeds(afm, run_log):
    fresh("lcmlog")
    d = os.path.join(CORPUS, "lcmlog")
    msgs = bus_messages(afm)

    def log(name, events):
        path = os.path.join(d, name)
        out = lcm.EventLog(path, "w", overwrite=True)
        for i, (ch, data) in enumerate(events):
            out.write_event(1700000000000000 + 250 * i, ch, data)
        out.close()
        return path

    log("bus.lcmlog", [(ch, m.encode()) for ch, m in msgs])
    log("card_inputs.lcmlog", [(ch, m.encode()) for ch, m in msgs if ch in ("AFM_ANALOG", "HAPTIC_POSE", "AFM_CMD")])
    cut = log("cut.lcmlog", [(ch, m.encode()) for ch, m in msgs[:4]])
    with open(cut, "r+b") as f:
        f.truncate(os.path.getsize(cut) - 7)
    log("odd_channel.lcmlog", [("A", b""), ("X" * 300, b"\x00" * 3)])
    if run_log:
        src = lcm.EventLog(run_log, "r")
        events = []
        size = 0
        for ev in src:
            size += 28 + len(ev.channel) + len(ev.data)
            if size > 16000:
                break
            events.append((ev.channel, ev.data))
        log("run_start.lcmlog", events)
    for f in os.listdir(d):
        if os.path.getsize(os.path.join(d, f)) >= 20000:
            sys.exit(f"make_seeds: {f} is not below 20 KB")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--types", default=os.path.join(TOP, "build", "main", "lcmtypes"),
                    help="folder holding the generated Python package afm/ (default build/main/lcmtypes)")
    ap.add_argument("--log", help="a recorded bus.lcmlog whose first events become a seed")
    a = ap.parse_args()
    sys.path.insert(0, a.types)
    import afm  # noqa: E402 (the generated bindings)
    with open(os.path.join(TOP, "lcmtypes", "channels.yaml")) as f:
        channels = [r["channel"] for r in yaml.safe_load(f)]
    scene_seeds()
    calc_seeds()
    lcm_seeds(afm, channels)
    lcmlog_seeds(afm, a.log)
    bus_seeds()
    print(f"make_seeds: wrote {CORPUS}")


if __name__ == "__main__":
    main()
