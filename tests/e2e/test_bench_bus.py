"""./afm bench bus (issue 15), reduced: the latency probe answers every
ping of every size and measures a hop above zero; the benchmark's six
arrangements (and two on two hosts, docs/hosts.md) run a short scene, each to a complete log, without the
renderer or without its frame files when asked; and the record the launcher writes (bus_recorder.hpp)
holds every message the launcher counted, readable by the log reader."""
import json
import os
import subprocess
import sys
import unittest

import e2e_support
import lcm

BENCH = os.path.join(e2e_support.SRC, "bench", "bench_bus.py")
PROBE = os.path.join(e2e_support.BUILD, "bench", "host", "bench_bus")


class BenchBus(unittest.TestCase):
    def test_the_probe_answers_every_ping_of_every_size(self):
        # as the processes receive (the default), and through liblcm's thread
        for receive in ([], ["--receive", "liblcm"]):
            p = subprocess.run([e2e_support.IN_NETNS, PROBE, "--sizes", "24,836,6200", "--count", "50", *receive], capture_output=True,
                               text=True, timeout=120)
            self.assertEqual(p.returncode, 0, p.stderr)
            rows = [l.split() for l in p.stdout.splitlines()[1:]]
            self.assertEqual([r[0] for r in rows], ["24", "836", "6200"])
            for r in rows:
                self.assertEqual(r[1], "50/50", p.stdout)
                one_way, round_trip = float(r[2]), float(r[6])
                self.assertGreater(one_way, 0)
                self.assertGreater(round_trip, one_way, "a round trip is two hops")

    def test_the_probe_refuses_absurd_sizes_and_counts(self):
        for args in (["--sizes", "23"], ["--sizes", "100000"], ["--sizes", "49,x"], ["--count", "3"], ["--receive", "udp"]):
            p = subprocess.run([e2e_support.IN_NETNS, PROBE, *args], capture_output=True, text=True, timeout=60)
            self.assertEqual(p.returncode, 2, args)
            self.assertIn("bench_bus:", p.stderr)

    def test_benches_refuse_a_missing_scene_and_no_rounds_naming_them(self):
        # bench view read a missing scene with a traceback; the three share benchargs.checked_scene
        for name in ("bench_bus.py", "bench_pil.py", "bench_view.py"):
            bench = os.path.join(e2e_support.SRC, "bench", name)
            for args, named in ((["--scene", "/nonexistent/scene.yaml"], "--scene: /nonexistent/scene.yaml: no such file"),
                                (["--repeat", "0"], "--repeat: 0: give 1 or more")):
                p = subprocess.run([sys.executable, bench, *args], capture_output=True, text=True, timeout=60)
                self.assertEqual(p.returncode, 2, (name, args, p.stderr))
                self.assertIn(named, p.stderr, name)
                self.assertNotIn("Traceback", p.stderr, name)

    def test_six_arrangements_each_with_a_complete_log(self):
        top = e2e_support.tmpdir("bench-bus")
        self.addCleanup(e2e_support.cleanup, top)
        out = os.path.join(top, "new", "runs")   # --out a folder not there yet: made, as a user would expect
        p = subprocess.run([sys.executable, BENCH, "--scene", e2e_support.scene("short.yaml"), "--repeat", "1", "--count", "50",
                            "--out", out], capture_output=True, text=True, timeout=e2e_support.limit(300),
                           env=dict(os.environ, AFM_BUILD=e2e_support.BUILD))
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("The bus's MAC", p.stdout)
        with open(os.path.join(out, "bench_bus.json")) as f:
            r = json.load(f)
        self.check_goal(r, p.stdout)
        self.assertGreater(r["floors"]["kernel"]["floor_us"], 0)
        self.assertGreater(r["floors"]["kernel liblcm"]["floor_us"], 0)
        self.assertEqual(r["floors"]["kernel"]["receive"], "tap")
        self.assertEqual(len(r["lockstep"]), 6)
        self.check_two_hosts(r)
        with open(os.path.join(out, "run-0-0", "sim_report.json")) as f:
            blocks = json.load(f)["blocks"]   # every run of the scene has as many
        for k, row in enumerate(r["lockstep"]):
            self.check_arrangement(r, k, row, out, blocks)
        self.check_record(os.path.join(out, "run-0-0"))

    def check_goal(self, r, stdout):
        # the goal's verdict, from the as-run row: its median and each run against 2 x its floor
        g = r["goal"]
        row = r["lockstep"][0]
        self.assertEqual(g["arrangement"], row["arrangement"])
        self.assertAlmostEqual(g["x_floor"], row["ratio_to_floor"], places=9)
        self.assertEqual(g["met"], row["ratio_to_floor"] <= 2.0)
        self.assertEqual(len(g["runs_x_floor"]), 1)
        line = next(l for l in stdout.splitlines() if l.startswith("The goal: the lockstep as a run is made within 2.0 x its"))
        self.assertTrue(line.endswith(": met" if g["met"] else ": NOT met"), line)

    def check_two_hosts(self, r):
        # two hosts (docs/hosts.md): a plain link and 0.2 ms each way, each against its own floor
        self.assertEqual([x["link"] for x in r["two_hosts"]], ["", "delay=0.2"])
        for x in r["two_hosts"]:
            self.assertTrue(x["log_complete"], x)
            self.assertGreater(x["floor"]["paths_us"]["simulator"], 0, x)
            self.assertAlmostEqual(x["ratio_to_floor"], x["us_per_block"] / x["floor"]["floor_us"], places=9)
        plain, delayed = r["two_hosts"]
        self.assertGreater(delayed["floor"]["paths_us"]["simulator"], plain["floor"]["paths_us"]["simulator"] + 2 * 200,
                           "0.2 ms each way: two delayed hops on the simulator path")

    def check_arrangement(self, r, k, row, out, blocks):
        """One arrangement's row: its frames, floor, scans, MAC, run and log window."""
        frames = os.listdir(os.path.join(out, f"run-{k}-0", "frames")) if os.path.isdir(os.path.join(out, f"run-{k}-0", "frames")) else []
        if row["outputs"]:   # the renderer draws, announces and checks, but writes no frame file
            self.assertEqual(row["outputs"], {"png": False, "video": "none"})
            self.assertEqual(frames, [], row)
            self.assertFalse([n for n in os.listdir(os.path.join(out, f"run-{k}-0")) if n.startswith("video")], row)
            self.assertIn("renderer", row["cpu_us_per_block"])
        elif "--no-renderer" not in row["args"]:
            self.assertTrue(frames, row)
        self.assertGreaterEqual(row["frame_wait_ms"], 0)
        if "--no-renderer" in row["args"]:
            self.assertEqual(row["frame_wait_ms"], 0, "no renderer, no frame to wait for")
        # a placed run is held to the floor of one CPU (the four hops in
        # series, pinned), an unplaced one to the kernel's (two paths in parallel)
        self.assertEqual(row["floor"], "placed" if row["placed"] else "kernel", row)
        self.assertGreater(r["floors"][row["floor"]]["floor_us"], 0)
        self.assertGreater(r["floors"][row["floor"] + " liblcm"]["floor_us"], 0)
        self.assertGreater(row["ratio_to_liblcm_floor"], 0)
        if "--placement" in row["args"]:
            self.assertFalse(row["placed"], row)
        self.assertTrue(row["log_complete"], row)
        self.assertGreater(row["us_per_block"], 0)
        # the scans served between blocks are taken out of the lockstep's
        # cost: the renderer's display check asks for a final one
        self.assertAlmostEqual(row["loop_us_per_block"] - row["us_per_block"], row["scan_ms"] * 1e3 / blocks, delta=0.5)
        if "--no-renderer" in row["args"]:
            self.assertEqual(row["scan_ms"], 0, row)
        else:
            self.assertGreater(row["scan_ms"], 0, row)
        self.assertIn("afm_launch", row["cpu_us_per_block"], "the recorder's CPU is counted")
        # the bus's MAC, apart from the floor: signed and checked a block,
        # its time a small part of the block's (bus_key.hpp)
        mac = row["mac"]
        self.assertIsNotNone(mac, row)
        self.assertGreater(mac["signed_per_block"], 3, mac)   # the lockstep's four hops at least
        self.assertGreater(mac["checked_per_block"], mac["signed_per_block"], mac)   # the launcher checks them all, and their readers
        self.assertGreater(mac["us_per_block"], 0, mac)
        self.assertAlmostEqual(mac["us_per_block"], mac["sign_us_per_block"] + mac["check_us_per_block"], places=6)
        # the whole command holds the loop and more (the start, the first scan, the files)
        self.assertGreater(row["run_s"], row["loop_us_per_block"] * blocks * 1e-6, row)
        with open(os.path.join(out, f"run-{k}-0", "run.json")) as f:
            sim_s = json.load(f)["sim_seconds"]
        self.assertAlmostEqual(row["run_sim_s_per_wall_s"] * row["run_s"], sim_s, places=6)
        self.assertEqual("renderer" in row["cpu_us_per_block"], "--no-renderer" not in row["args"], row)
        if "--log-window" in row["args"]:
            self.assertEqual(row["log_waits"], 0, "no window, no wait")
            self.assertEqual(row["log_window_blocks"], 0, row)
        else:   # the launcher's window: from its receive buffer, 8 to 64 blocks
            self.assertTrue(8 <= row["log_window_blocks"] <= 64, row)

    def check_record(self, run):
        """The record of a run: every event the launcher wrote reads back."""
        with open(os.path.join(run, "run.json")) as f:
            rj = json.load(f)
        log = afmlog_events(os.path.join(run, "bus.lcmlog"))
        self.assertEqual(log, rj["launcher"]["recorded_events"])
        self.assertEqual(sum(rj["channels"].values()), log)


def afmlog_events(path):
    """Events in a log, counted by LCM's own reader (not the bench's)."""
    return sum(1 for _ in lcm.EventLog(path, "r"))


if __name__ == "__main__":
    e2e_support.main()
