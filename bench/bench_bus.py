"""./afm bench bus: the bus's floor and the lockstep's overhead, in one run.

1. The raw latency of LCM on a run's bus (udpm on a private namespace's
   loopback) for the message sizes the bench sends (read from the first
   run's log): one-way and round trip, median and p99
   (build/main/bench/host/bench_bus, bench/host/bench_bus.cpp), received
   as the bench's processes receive (a socket of their own, filtered to
   their channels and read on their own thread: bus/bus_tap.hpp) and,
   for comparison, through liblcm's own receive thread.
2. The floor of one lockstep block: the hops a block needs as the protocol
   stands, from those medians (below, FLOOR_PATHS). Twice, as the
   processes are placed (common/placement.hpp): with the lockstep's three
   processes on one CPU (a run's placement) the latency is measured with
   both ends on that CPU and the block's four hops follow one another;
   as the kernel places them (--placement off) the latency is measured
   unpinned and the two paths run in parallel.
3. The lockstep's measured cost per block on a scene (default: the demo's,
   scenes/default.yaml) in six arrangements: as a run is made (placed, the
   log window pacing the simulator, the renderer attached), placement off,
   the log window off, the renderer writing no frame files (the scene's
   outputs png: false, video: none: what encoding the frames costs), the
   renderer off, and both off (in turn: a run of each, --repeat rounds);
   each as a ratio to
   the floor of its placement (received as the processes receive; the
   ratio to liblcm's floor is shown beside it). The cost per block is the
   blocks' wall time less the scans the simulator serves between blocks
   (the display check's final scan, local scans: sim_report.json
   loop_scan_wall_seconds), which are shown apart; with the CPU each process
   spent per block in the loop (run.json timing.loop_cpu_us_per_block), how long the simulator waited
   for the record (the log window) and for the renderer's frames (the frame
   window) after the card had answered, and whether the log holds every
   block. Beside them, the whole command as a user runs it (afm_launch in
   its namespace, from start to exit) and its simulated seconds per second,
   and the CPU the renderer's frame writer spent on a frame's files (its
   PNG and video: renderer_report.json write_ms_per_frame).
4. Two hosts (docs/hosts.md): the floor and the lockstep's cost per block
   with sim_afm in its own namespace across a veth pair, with no shaping and
   with 0.2 ms delay each way (afm_netfault, or netem where the kernel has
   it), each as a ratio to its own floor: the simulator path's two hops
   across the link (AFM_CMD to the afm host, AFM_ANALOG back), one-way
   medians by LCM round trips at those messages' sizes (afm_linkprobe), and
   the operator path on the host's own loopback, as above. In the same
   rounds as the one-namespace arrangements.
5. The disk's state, before the runs: how long creating a frame-sized
   file in the runs' folder takes. On ext4 without a journal it is ten
   times more in the seconds after many files were deleted (docs/bus.md, "The
   lockstep's cost per block"), and the frames' files cost the run as much more.

6. The goal (GOAL_X): the lockstep as a run is made within 2 x the floor of
   its placement; the last line says whether the median of the runs met
   it, with each run's ratio (the spread over --repeat).

A benchmark: it prints figures and never fails on them. Exit 1 only when a
run fails.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import lcm
import yaml

import benchargs
from analysis import paths

TOP, BUILD, IN_NETNS = paths.ROOT, paths.BUILD, paths.IN_NETNS

# The messages whose latency is measured: those of the floor's paths, and
# the largest the simulator sends. Their sizes are read from the first run's
# log (sizes_of), so they follow the types and the scene.
LATENCY_CHANNELS = ["AFM_CMD", "HAPTIC_POSE", "HAPTIC_FORCE", "AFM_ANALOG", "AFM_SCAN_LINE"]

# The hops block n+1 waits for after the card has stepped block n: two
# paths, each of two one-way hops; the block can start on the card when both
# have arrived. On two CPUs the paths run in parallel; on the one CPU of a
# placed lockstep their four hops run one after the other.
FLOOR_PATHS = {
    "simulator": [("AFM_CMD", "fw_node -> sim_afm"), ("AFM_ANALOG", "sim_afm -> fw_node")],
    "operator": [("HAPTIC_FORCE", "fw_node -> operator"), ("HAPTIC_POSE", "operator -> fw_node")],
}

# (label, launcher arguments, the scene's outputs changed)
NO_FILES = {"png": False, "video": "none"}
ARRANGEMENTS = [
    ("as run (placed, window, renderer)", [], None),
    ("placement off", ["--placement", "off"], None),
    ("log window off", ["--log-window", "0"], None),
    ("renderer, no frame files", [], NO_FILES),
    ("renderer off", ["--no-renderer"], None),
    ("both off", ["--log-window", "0", "--no-renderer"], None),
]


# Two hosts: (label, --link SPEC); each run as a user runs it (placed, window, renderer).
TWO_HOSTS = [("two hosts", ""), ("two hosts, 0.2 ms each way", "delay=0.2")]


def link_latency(sizes, count, link, out):
    """{"to_afm": {bytes: us}, "to_host": {bytes: us}}: one-way medians across
    the link of two hosts (afm_linkprobe, run by run/two_hosts.sh), and the probe's JSON."""
    d = os.path.join(out, "link-" + (link.replace("=", "-").replace(",", "-") or "plain"))
    os.makedirs(d, exist_ok=True)
    # ping-pong, each ping once the last is answered: the path kept warm, as the
    # lockstep keeps it (a ping a millisecond measures an idle CPU's wake-up too)
    env = dict(os.environ, AFM_HOSTS="2", AFM_LINK=link, AFM_LINK_DIR=d, AFM_BUILD=BUILD, AFM_LINK_PINGS=str(count),
               AFM_LINK_PROBE_SIZES=",".join(str(b) for b in sorted(set(sizes.values()))), AFM_LINK_PROBE_INTERVAL_US="0")
    p = subprocess.run([IN_NETNS, "true"], capture_output=True, text=True, env=env)
    if p.returncode:
        sys.exit(f"bench bus: the link's probe failed ({p.returncode}): {p.stderr.strip()}")
    with open(os.path.join(d, "probe.json")) as f:
        probe = json.load(f)
    return {k: {int(b): v[k]["median_us"] for b, v in probe["by_size"].items()} for k in ("to_afm", "to_host")}, probe


def floor_two_hosts(link_lat, local_lat, sizes, serial):
    """The floor of one block on two hosts: the simulator path across the
    link (AFM_CMD to the afm host, AFM_ANALOG back), the operator path on
    the host's loopback (floor_of's rule: in parallel, or one after the other)."""
    paths = {"simulator": link_lat["to_afm"][sizes["AFM_CMD"]] + link_lat["to_host"][sizes["AFM_ANALOG"]],
             "operator": sum(local_lat[sizes[ch]]["one_way_median_us"] for ch, _ in FLOOR_PATHS["operator"])}
    if serial:
        return {"floor_us": sum(paths.values()), "path": "both, one after the other", "paths_us": paths}
    worst = max(paths, key=paths.get)
    return {"floor_us": paths[worst], "path": f"the {worst} path", "paths_us": paths}


def scene_with_outputs(scene, outputs, out):
    """A copy of the scene in `out` with its outputs section changed."""
    with open(scene) as f:
        s = yaml.safe_load(f)
    if not isinstance(s, dict):
        sys.exit(f"bench bus: {scene}: not a scene (a mapping at the top)")
    s["outputs"] = dict(s.get("outputs") or {}, **outputs)
    path = os.path.join(out, "scene-" + "-".join(f"{k}-{v}" for k, v in outputs.items()).lower() + ".yaml")
    with open(path, "w") as f:
        yaml.safe_dump(s, f, sort_keys=False)
    return path


def sizes_of(log_path):
    """{channel: median LCM payload in bytes} of LATENCY_CHANNELS in a run's log."""
    seen = {ch: [] for ch in LATENCY_CHANNELS}
    for ev in lcm.EventLog(log_path, "r"):
        if ev.channel in seen:
            seen[ev.channel].append(len(ev.data))
    missing = [ch for ch, v in seen.items() if not v]
    if missing:
        sys.exit(f"bench bus: {log_path} holds no {', '.join(missing)}: the scene sends no such message")
    return {ch: int(statistics.median(v)) for ch, v in seen.items()}


def raw_latency(sizes, count, out, cpu=None, receive="tap"):
    """{bytes: latency row}; cpu: both ends pinned to that CPU (a placed
    lockstep's); receive: tap (as the bench's processes) or liblcm."""
    path = os.path.join(out, f"latency-{receive}" + ("" if cpu is None else f"-cpu{cpu}") + ".json")
    sizes = ",".join(str(b) for b in sorted(set(sizes.values())))
    exe = os.path.join(BUILD, "bench", "host", "bench_bus")
    pin = [] if cpu is None else ["taskset", "-c", str(cpu)]
    p = subprocess.run([IN_NETNS, *pin, exe, "--sizes", sizes, "--count", str(count), "--receive", receive, "--json", path],
                       capture_output=True, text=True, env=dict(os.environ, AFM_RUN_WRITES=out))   # where the probe writes
    if p.returncode:
        sys.exit(f"bench bus: {exe} failed ({p.returncode}): {p.stderr.strip()}")
    with open(path) as f:
        return {r["bytes"]: r for r in json.load(f)}


def floor_of(lat, sizes, serial):
    """{floor_us, path (the one that sets it, or "both"), paths_us}: the paths
    in parallel, or (serial: one CPU) one after the other."""
    paths = {}
    for name, hops in FLOOR_PATHS.items():
        paths[name] = sum(lat[sizes[ch]]["one_way_median_us"] for ch, _ in hops)
    if serial:
        return {"floor_us": sum(paths.values()), "path": "both, one after the other", "paths_us": paths}
    worst = max(paths, key=paths.get)
    return {"floor_us": paths[worst], "path": f"the {worst} path", "paths_us": paths}


def disk_probe(folder, files=100, size=12000):
    """Median ms to create, write and close a file of `size` bytes in folder
    (the files are left for the caller's folder to take away: deleting
    them would slow the next files created)."""
    d = os.path.join(folder, "disk-probe")
    os.makedirs(d, exist_ok=True)
    data = os.urandom(size)
    ms = []
    for k in range(files):
        t0 = time.perf_counter()
        fd = os.open(os.path.join(d, f"f{k:04d}.bin"), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            os.write(fd, data)
        finally:
            os.close(fd)
        ms.append((time.perf_counter() - t0) * 1e3)
    return {"folder": folder, "files": files, "bytes": size, "median_ms": statistics.median(ms), "max_ms": max(ms)}


def one_run(scene, args, out, link=None):
    """One run (link: on two hosts over that --link SPEC)."""
    exe = paths.LAUNCH
    env = None
    if link is not None:
        args = [*args, "--hosts", "2"]
        env = dict(os.environ, AFM_HOSTS="2", AFM_LINK=link, AFM_BUILD=BUILD)
    t0 = time.monotonic()
    p = subprocess.run([IN_NETNS, exe, "--scene", scene, "--out", out, "--quiet", *args], capture_output=True, text=True, env=env)
    run_s = time.monotonic() - t0   # the whole command: namespace, start, loop, end
    if p.returncode:
        sys.exit(f"bench bus: the run {' '.join(args) or '(as run)'} failed ({p.returncode}): {p.stderr.strip()[-2000:]}")
    with open(os.path.join(out, "run.json")) as f:
        run = json.load(f)
    with open(os.path.join(out, "sim_report.json")) as f:
        sim = json.load(f)
    blocks = sim["blocks"]
    mac = mac_cost(run, blocks)
    # each process's CPU in the loop, with its descendants (run.json timing;
    # afm_launch records the bus itself, bus_recorder.hpp)
    cpu = {n: v for n, v in (run["timing"].get("loop_cpu_us_per_block") or {}).items() if "(its children)" not in n}
    # the scans the simulator serves between blocks (the display check's
    # final scan, a local scan) are a cost of their own, not the lockstep's
    scan_s = sim.get("loop_scan_wall_seconds", 0.0)
    files_ms = None   # the frame writer's CPU a frame (no renderer, or no files: None)
    rep = os.path.join(out, "renderer_report.json")
    if os.path.exists(rep):
        with open(rep) as f:
            files_ms = json.load(f).get("write_ms_per_frame") or None
    return {
        "frame_files_cpu_ms": files_ms,
        "us_per_block": (sim["loop_wall_seconds"] - scan_s) / blocks * 1e6,
        "loop_us_per_block": sim["loop_wall_seconds"] / blocks * 1e6,
        "scan_ms": scan_s * 1e3,
        "sim_s_per_wall_s": run["sim_seconds"] / sim["loop_wall_seconds"],
        "run_s": run_s,
        "run_sim_s_per_wall_s": run["sim_seconds"] / run_s,
        "complete": run.get("log", {}).get("complete"),
        "placement": run.get("placement", {"on": False, "why": "not in run.json"}),
        "log_waits": sim["log_window_waits"],
        "log_wait_ms": sim.get("log_window_wait_seconds", 0.0) * 1e3,
        "frame_wait_ms": sim.get("frame_window_wait_seconds", 0.0) * 1e3,
        "log_window_blocks": run.get("launcher", {}).get("log_window_blocks"),
        "cpu_us_per_block": cpu,
        "mac": mac,
    }


def mac_cost(run, blocks):
    """The bus's MAC (bus/bus_key.hpp) a block: what every process of the
    run spent signing what it published and checking what it received, from
    clock reads around that work alone (run.json: each process's
    rejected.proof_cost, the launcher's proof_cost), over the whole run, by
    the blocks simulated. None when the run had no key."""
    if not run.get("launcher", {}).get("bus_mac"):
        return None
    costs = {"afm_launch": run["launcher"].get("proof_cost", {})}
    for p in ("sim", "fw", "operator", "renderer"):
        c = run.get(p, {}).get("rejected", {}).get("proof_cost")
        if c:
            costs[p] = c
    sign = sum(c.get("sign_us", 0.0) for c in costs.values())
    check = sum(c.get("check_us", 0.0) for c in costs.values())
    # the lockstep's own part (sim_afm, fw_node, operator: the chain a block waits for)
    chain = sum(costs[p].get("sign_us", 0.0) + costs[p].get("check_us", 0.0) for p in ("sim", "fw", "operator") if p in costs)
    return {"us_per_block": (sign + check) / blocks, "lockstep_us_per_block": chain / blocks, "sign_us_per_block": sign / blocks, "check_us_per_block": check / blocks,
            "signed_per_block": sum(c.get("signed", 0) for c in costs.values()) / blocks,
            "checked_per_block": sum(c.get("checked", 0) for c in costs.values()) / blocks}


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="./afm bench bus", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=os.path.join(TOP, "scenes", "default.yaml"), help="scene of the lockstep runs (default: the demo's)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each arrangement; the median is shown (default 3)")
    ap.add_argument("--count", type=int, default=2000, help="pings per message size (default 2000)")
    ap.add_argument("--out", help="folder for bench_bus.json and the runs (default: a temporary one, removed)")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON instead of tables")
    a = ap.parse_args(argv)
    a.scene = benchargs.checked_scene(ap, a)
    return a


def run_rounds(a, out):
    """The arrangements in turn, a run of each per round: what slows the
    machine for a while (another job; creating files on ext4 without a
    journal just after many were deleted, docs/bus.md, "The lockstep's cost
    per block") falls on every arrangement alike, not on the first one run.
    Returns each arrangement's runs and each two-host link's."""
    scenes = [a.scene if outputs is None else scene_with_outputs(a.scene, outputs, out) for _, _, outputs in ARRANGEMENTS]
    runs_of = [[] for _ in ARRANGEMENTS]
    two_of = [[] for _ in TWO_HOSTS]
    for i in range(a.repeat):
        for k, (label, args, _) in enumerate(ARRANGEMENTS):
            print(f"bench bus: round {i + 1} of {a.repeat}: {label} ...", file=sys.stderr)
            runs_of[k].append(one_run(scenes[k], args, os.path.join(out, f"run-{k}-{i}")))
        for k, (label, link) in enumerate(TWO_HOSTS):
            print(f"bench bus: round {i + 1} of {a.repeat}: {label} ...", file=sys.stderr)
            two_of[k].append(one_run(a.scene, [], os.path.join(out, f"two-{k}-{i}"), link=link))
    return runs_of, two_of


def median_cpu(runs):
    """Each process's CPU in the loop, us a block, the median over runs."""
    return {n: statistics.median(r["cpu_us_per_block"].get(n, 0) for r in runs)
            for n in sorted({n for r in runs for n in r["cpu_us_per_block"]})}


def lockstep_row(label, args, outputs, runs):
    """One arrangement's figures: the median over its runs."""
    def med(key):
        return statistics.median(r[key] for r in runs)
    return {
        "arrangement": label, "args": args, "outputs": outputs, "us_per_block": med("us_per_block"),
        "runs_us_per_block": [r["us_per_block"] for r in runs],
        "loop_us_per_block": med("loop_us_per_block"), "scan_ms": med("scan_ms"),
        "sim_s_per_wall_s": med("sim_s_per_wall_s"), "run_s": med("run_s"),
        "run_sim_s_per_wall_s": med("run_sim_s_per_wall_s"),
        "log_complete": all(r["complete"] for r in runs),
        "log_waits": med("log_waits"), "log_wait_ms": med("log_wait_ms"), "frame_wait_ms": med("frame_wait_ms"),
        "frame_files_cpu_ms": med("frame_files_cpu_ms") if all(r["frame_files_cpu_ms"] for r in runs) else None,
        "log_window_blocks": runs[0]["log_window_blocks"],
        "cpu_us_per_block": median_cpu(runs),
        "placement": runs[0]["placement"],
        "placed": all(r["placement"].get("on") for r in runs),
        "mac": ({k: statistics.median(r["mac"][k] for r in runs) for k in runs[0]["mac"]}
                if all(r["mac"] for r in runs) else None),
    }


def floors_of(rows, sizes, count, out):
    """The floor of a block, from LCM's latency per message size: as the
    kernel places the two ends, and (when a run was placed) both on the
    lockstep's CPU; each as the processes receive and through liblcm's thread."""
    floors = {}
    placed = next((x["placement"] for x in rows if x["placed"]), None)
    cpu = int(placed["lockstep_cpus"].split(",")[0].split("-")[0]) if placed else None
    for receive, how in (("tap", "received as the processes receive"), ("liblcm", "received through liblcm's thread")):
        suffix = "" if receive == "tap" else " liblcm"
        print(f"bench bus: LCM latency, {how}, {count} pings per size ...", file=sys.stderr)
        lat = raw_latency(sizes, count, out, receive=receive)
        floors["kernel" + suffix] = dict(floor_of(lat, sizes, serial=False), placement=f"as the kernel places them (unpinned), {how}",
                                         latency=list(lat.values()), receive=receive)
        if placed:
            print(f"bench bus: LCM latency on CPU {cpu} (the lockstep's), {how}, {count} pings per size ...", file=sys.stderr)
            lat1 = raw_latency(sizes, count, out, cpu, receive=receive)
            floors["placed" + suffix] = dict(floor_of(lat1, sizes, serial=True),
                                             placement=f"both ends on CPU {cpu}, as a run places the lockstep, {how}",
                                             latency=list(lat1.values()), receive=receive)
    return floors


def two_hosts_rows(two_of, floors, sizes, count, out):
    """Each two-host link's runs against the floor of its link."""
    two = []
    for (label, link), runs in zip(TWO_HOSTS, two_of):
        print(f"bench bus: LCM across the link of two hosts ({label}), {count} pings ...", file=sys.stderr)
        link_lat, probe = link_latency(sizes, count, link, out)
        placed2 = all(r["placement"].get("on") for r in runs) and "placed" in floors
        # the operator path on the host's loopback, as the one-namespace floor of the same placement measured it
        local = {x["bytes"]: x for x in floors["placed" if placed2 else "kernel"]["latency"]}
        fl = floor_two_hosts(link_lat, local, sizes, serial=placed2)
        med = statistics.median(r["us_per_block"] for r in runs)
        two.append({"arrangement": label, "link": link, "us_per_block": med, "runs_us_per_block": [r["us_per_block"] for r in runs],
                    "floor": fl, "ratio_to_floor": med / fl["floor_us"], "placed": placed2,
                    "log_complete": all(r["complete"] for r in runs),
                    "link_one_way_us": {"to_afm": probe["to_afm"], "to_host": probe["to_host"]},
                    "cpu_us_per_block": median_cpu(runs)})
    return two


def against_floors(rows, floors):
    """Each arrangement's block against the floor of its placement."""
    for row in rows:
        row["floor"] = "placed" if row["placed"] and "placed" in floors else "kernel"
        row["ratio_to_floor"] = row["us_per_block"] / floors[row["floor"]]["floor_us"]
        row["ratio_to_liblcm_floor"] = row["us_per_block"] / floors[row["floor"] + " liblcm"]["floor_us"]
        row["loop_ratio_to_floor"] = row["loop_us_per_block"] / floors[row["floor"]]["floor_us"]


# The goal (issue 49, item 2): the lockstep as a run is made (placed, the log
# window, the renderer writing frames and video) within GOAL_X times the
# floor of its placement.
GOAL_X = 2.0
GOAL_ROW = "as run (placed, window, renderer)"


def goal_of(rows):
    """The goal's verdict: the as-run arrangement's median against GOAL_X
    times its floor, with the ratio of each of its runs (the spread over
    --repeat); None when that row is missing."""
    row = next((x for x in rows if x["arrangement"] == GOAL_ROW), None)
    if row is None:
        return None
    floor = row["us_per_block"] / row["ratio_to_floor"]
    runs = sorted(us / floor for us in row["runs_us_per_block"])
    return {"goal_x_floor": GOAL_X, "arrangement": GOAL_ROW, "floor": row["floor"], "floor_us": floor,
            "x_floor": row["ratio_to_floor"], "runs_x_floor": runs, "met": row["ratio_to_floor"] <= GOAL_X,
            "runs_met": sum(r <= GOAL_X for r in runs)}


def print_goal(g):
    if g is None:
        return
    print(f"\nThe goal: the lockstep as a run is made within {g['goal_x_floor']:.1f} x its {g['floor']} floor "
          f"({g['floor_us']:.1f} us): {g['x_floor']:.2f} x, the median of {len(g['runs_x_floor'])} runs "
          f"({g['runs_x_floor'][0]:.2f}-{g['runs_x_floor'][-1]:.2f} x, {g['runs_met']} of {len(g['runs_x_floor'])} within): "
          + ("met" if g["met"] else "NOT met"))


def main(argv=None):
    a = parse_args(argv)
    out, keep = paths.bench_folder(a.out, "afm-bench-bus-")
    disk = disk_probe(out)
    runs_of, two_of = run_rounds(a, out)
    rows = [lockstep_row(label, args, outputs, runs) for (label, args, outputs), runs in zip(ARRANGEMENTS, runs_of)]
    sizes = sizes_of(os.path.join(out, "run-0-0", "bus.lcmlog"))
    floors = floors_of(rows, sizes, a.count, out)
    two = two_hosts_rows(two_of, floors, sizes, a.count, out)
    against_floors(rows, floors)
    report = {"sizes": sizes, "floors": floors, "lockstep": rows, "two_hosts": two, "scene": a.scene, "repeat": a.repeat, "disk": disk,
              "goal": goal_of(rows)}
    with open(os.path.join(out, "bench_bus.json"), "w") as f:
        json.dump(report, f, indent=1)
    if a.json:
        print(json.dumps(report, indent=1))
    else:
        print_tables(report)
    if not keep:
        subprocess.run(["rm", "-rf", out])
    else:
        print(f"\nfigures: {os.path.join(out, 'bench_bus.json')}")
    return 0


def print_tables(r):
    for key, fl in r["floors"].items():
        print(f"LCM on the run's bus (udpm, namespace loopback), {fl['placement']}: latency per message size, us")
        print(f"{'message':14s} {'bytes':>6s} {'one-way med':>12s} {'p99':>8s} {'round trip med':>15s} {'p99':>8s}")
        by_size = {x["bytes"]: x for x in fl["latency"]}
        for ch, b in r["sizes"].items():
            x = by_size[b]
            print(f"{ch:14s} {b:6d} {x['one_way_median_us']:12.1f} {x['one_way_p99_us']:8.1f} {x['round_trip_median_us']:15.1f} "
                  f"{x['round_trip_p99_us']:8.1f}")
        print(f"The floor of one lockstep block, {fl['placement']}: after the card steps block n, block n+1 needs")
        for name, hops in FLOOR_PATHS.items():
            print(f"  {name:9s} path: " + " + ".join(f"{ch} ({who})" for ch, who in hops) + f" = {fl['paths_us'][name]:.1f} us")
        print(f"  floor {fl['floor_us']:.1f} us per block ({fl['path']}), {1e6 / fl['floor_us'] / 1000:.1f} x real time at 1 kHz blocks\n")
    print(f"\nThe lockstep on {os.path.basename(r['scene'])} (median of {r['repeat']} runs; CPU: each process's in the loop, a block, run.json timing)")
    print(f"{'arrangement':34s} {'us/block':>9s} {'x floor':>8s} {'of':>7s} {'x liblcm':>9s} {'scans ms':>9s} {'with scans':>11s} "
          f"{'x real time':>12s} {'run s':>6s} {'run x real':>11s} {'log':>9s} {'window':>7s} {'waits':>7s} {'log ms':>7s} {'frames ms':>10s} "
          f"{'files ms':>9s}  CPU us/block")
    for x in r["lockstep"]:
        cpu = ", ".join(f"{n} {v:.0f}" for n, v in x["cpu_us_per_block"].items())
        print(f"{x['arrangement']:34s} {x['us_per_block']:9.1f} {x['ratio_to_floor']:8.2f} {x['floor']:>7s} {x['ratio_to_liblcm_floor']:9.2f} "
              f"{x['scan_ms']:9.1f} {x['loop_us_per_block']:11.1f} {x['sim_s_per_wall_s']:12.2f} {x['run_s']:6.2f} {x['run_sim_s_per_wall_s']:11.2f} {'complete' if x['log_complete'] else 'GAPS':>9s} {x['log_window_blocks'] or 0:7d} "
              f"{x['log_waits']:7.0f} {x['log_wait_ms']:7.1f} {x['frame_wait_ms']:10.1f} "
              f"{'-' if x['frame_files_cpu_ms'] is None else format(x['frame_files_cpu_ms'], '.2f'):>9s}  {cpu}")
    print("us/block: the blocks' wall time less the scans the simulator served between them (scans ms: the display "
          "check's final scan, any local scan; with scans: the loop's whole wall time per block; x real time is of the loop with its scans)")
    print("run s, run x real: the whole command as a user runs it (the namespace, the processes' start, the first scan, the loop, "
          "the files, the record closed), and the simulated seconds per second of it")
    print("x floor: against the floor of the arrangement's placement, received as the processes receive; "
          "x liblcm: against the same floor received through liblcm's thread")
    print("waits, log ms: the simulator's waits for the record (the log window) and their wall time; frames ms: the wall "
          "time blocks waited for the renderer's frames after the card had answered (the frame window)")
    print("files ms: the CPU the renderer's frame writer spent on a frame's files (its PNG and video)")
    print("\nThe bus's MAC (bus/bus_key.hpp: every datagram signed by its sender and checked by each receiver), apart from the "
          "floor: the time every process of the run spent on it, a block, against the block's cost (target: at most 10 %)")
    for x in r["lockstep"]:
        m = x.get("mac")
        if m:
            print(f"  {x['arrangement']:34s} {m['us_per_block']:6.2f} us a block ({m['sign_us_per_block']:.2f} signing "
                  f"{m['signed_per_block']:.1f} messages, {m['check_us_per_block']:.2f} checking {m['checked_per_block']:.1f}), "
                  f"{100 * m['us_per_block'] / x['us_per_block']:.1f} % of {x['us_per_block']:.1f} us; the lockstep's processes' part "
                  f"{m['lockstep_us_per_block']:.2f} us, {100 * m['lockstep_us_per_block'] / x['us_per_block']:.1f} %")
        else:
            print(f"  {x['arrangement']:34s} no key (AFM_BUS_MAC=off)")
    print("\nTwo hosts (docs/hosts.md): sim_afm in its own namespace across a veth pair; the floor's simulator path crosses the link")
    print(f"{'arrangement':34s} {'us/block':>9s} {'floor us':>9s} {'x floor':>8s} {'sim path':>9s} {'op path':>8s} {'link ms one-way':>16s} "
          f"{'log':>9s}  CPU us/block")
    for x in r.get("two_hosts", []):
        fl, lk = x["floor"], x["link_one_way_us"]
        cpu = ", ".join(f"{n} {v:.0f}" for n, v in x["cpu_us_per_block"].items())
        print(f"{x['arrangement']:34s} {x['us_per_block']:9.1f} {fl['floor_us']:9.1f} {x['ratio_to_floor']:8.2f} "
              f"{fl['paths_us']['simulator']:9.1f} {fl['paths_us']['operator']:8.1f} "
              f"{lk['to_afm']['median_us'] / 1e3:7.3f}/{lk['to_host']['median_us'] / 1e3:.3f}  "
              f"{'complete' if x['log_complete'] else 'GAPS':>9s}  {cpu}")
    print("x floor: against its own floor (the simulator path's two hops across the link, by LCM round trips at the messages' "
          "sizes, and the operator path on the host's loopback; in series when placed); link ms: median one-way, to afm / to host")
    d = r["disk"]
    print(f"the disk, before the runs: creating a {d['bytes'] // 1000} kB file in {d['folder']} took a median {d['median_ms']:.3f} ms "
          f"({d['files']} files, the slowest {d['max_ms']:.3f} ms); ext4 without a journal takes about ten times more in the "
          "seconds after many files were deleted, and so do the frames' files (docs/bus.md, \"The lockstep's cost per block\")")
    unplaced = {x["placement"].get("why") for x in r["lockstep"] if not x["placed"] and "--placement" not in x["args"]}
    for why in sorted(w for w in unplaced if w):
        print(f"  not placed: {why}")
    print_goal(r.get("goal"))


if __name__ == "__main__":
    sys.exit(main())
