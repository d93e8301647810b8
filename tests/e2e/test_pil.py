"""Processor in the loop (issue 36, section 1): the card built for its
processor runs on an emulated mps2-an386 board (qemu-system-arm -icount
shift=0) in the live loop, ./afm run SCENE --firmware qemu. On a short scene,
a wire scene and a lithography scene (whose trench points cross the link
incrementally): the outputs of a run on the board equal the host build's bit
for bit (the board's run replays identical through the host build, the host's
run replays identical through the board), and run.json card.board holds the
board's instructions per block. The board not starting, faulting or hanging
ends the run (or the replay) with one line naming the board, never a hang."""
import json
import os
import subprocess
import time
import unittest

import e2e_support
from analysis import paths

REPLAY = paths.REPLAY


def replay(run_dir, *args, env=None):
    p = subprocess.run([REPLAY, run_dir, *args], capture_output=True, text=True, timeout=120, env=env)
    return p.returncode, p.stdout, p.stderr


def shortened(name, old, new, tag):
    text = open(e2e_support.scene(name)).read()
    assert old in text, (name, old)
    return e2e_support.write_scene(text.replace(old, new), tag)


class PilTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scenes = {
            "short": e2e_support.scene("short.yaml"),
            # the first end push of the rod (it starts at 0.27 s), and the turn it makes
            "wire": shortened("wire_push.yaml", "duration_s: 3.0", "duration_s: 0.9", "wire"),
        }
        cls.runs, cls.walls = {}, {}
        for name, path in cls.scenes.items():
            for fw in ("host", "qemu"):
                out = e2e_support.tmpdir(f"{name}-{fw}")
                t0 = time.monotonic()
                code, _, err, rj = e2e_support.run(path, out, "--firmware", fw)
                cls.walls[(name, fw)] = time.monotonic() - t0
                cls.runs[(name, fw)] = (out, code, err, rj)

    def test_runs_on_the_board_succeed_and_report_the_boards_cost(self):
        for (name, fw), (out, code, err, rj) in self.runs.items():
            with self.subTest(scene=name, firmware=fw):
                self.assertEqual(code, 0, err)
                self.assertEqual(rj["status"], "ok")
                board = rj["card"]["board"]
                self.assertEqual(board["firmware"], fw)
                if fw == "host":
                    continue
                self.assertIn("mps2-an386", board["machine"])
                self.assertEqual(board["blocks"], rj["fw"]["blocks_stepped"])
                ipb, ips = board["instructions_per_block"], board["instructions_per_sample"]
                self.assertGreater(ipb["median"], 1000)
                self.assertGreaterEqual(ipb["worst"], ipb["median"])
                spb = rj["card"]["samples_per_block"]
                self.assertAlmostEqual(ips["worst"] * spb, ipb["worst"], delta=1e-6 * ipb["worst"])
                self.assertAlmostEqual(board["budget"]["fraction_worst_cpi1"], ipb["worst"] / 168000.0, places=9)
                self.assertGreater(board["round_trip_us"]["median"], 0)
                self.assertTrue(os.path.exists(os.path.join(out, "logs", "board.log")))
                print(f"\n  {name}: board {ipb['median']:.0f} instructions a block median, {ipb['worst']:.0f} worst; "
                      f"round trip {board['round_trip_us']['median']:.0f} us median; wall {self.walls[(name, 'qemu')]:.1f} s "
                      f"on the board, {self.walls[(name, 'host')]:.1f} s on the host")

    def test_the_boards_run_replays_identical_through_the_host_build(self):
        for name in self.scenes:
            with self.subTest(scene=name):
                code, out, err = replay(self.runs[(name, "qemu")][0])
                self.assertEqual(code, 0, out + err)
                self.assertIn("identical", out)

    def test_the_hosts_run_replays_identical_through_the_board(self):
        for name in self.scenes:
            with self.subTest(scene=name):
                code, out, err = replay(self.runs[(name, "host")][0], "--firmware", "qemu")
                self.assertEqual(code, 0, out + err)
                self.assertIn("identical", out)
                self.assertIn("the card ran on the board", out)

    def test_the_two_builds_publish_the_same_outputs(self):
        # closed loop both: the card's outputs in the two logs are the same messages, byte for byte
        import lcm
        for name in self.scenes:
            with self.subTest(scene=name):
                sets = {}
                for fw in ("host", "qemu"):
                    log = lcm.EventLog(os.path.join(self.runs[(name, fw)][0], "bus.lcmlog"), "r")
                    sets[fw] = {(ev.channel, bytes(ev.data)) for ev in log if ev.channel in ("AFM_CMD", "HAPTIC_FORCE", "FW_STATE")}
                self.assertGreater(len(sets["host"]), 100)
                self.assertEqual(sets["host"], sets["qemu"])

    def test_trench_points_cross_incrementally(self):
        # lithography: the card records trench points; the board sends the new ones each block
        out = e2e_support.tmpdir("litho-host")
        path = shortened("lithography.yaml", "duration_s: 1.6", "duration_s: 0.8", "litho")
        code, _, err, rj = e2e_support.run(path, out)
        self.assertEqual(code, 0, err)
        code, text, err = replay(out, "--firmware", "qemu")
        self.assertEqual(code, 0, text + err)

    def test_a_board_that_cannot_start_is_named_in_one_line(self):
        out = self.runs[("short", "host")][0]
        code, text, err = replay(out, "--firmware", "qemu", "--board-elf", "/nonexistent/afm_board.elf")
        self.assertEqual(code, 2)
        self.assertIn("no board image at '/nonexistent/afm_board.elf'", err)
        self.assertEqual(len(err.strip().splitlines()), 1, err)
        env = dict(os.environ, AFM_QEMU="/nonexistent/qemu-system-arm")
        code, text, err = replay(out, "--firmware", "qemu", env=env)
        self.assertEqual(code, 2)
        self.assertIn("qemu-system-arm /nonexistent/qemu-system-arm not found", err)
        run = e2e_support.tmpdir("noqemu")
        p = subprocess.run([e2e_support.IN_NETNS, e2e_support.LAUNCH, "--scene", self.scenes["short"], "--out", run, "--quiet",
                            "--firmware", "qemu"], capture_output=True, text=True, timeout=120, env=env)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("the card's board cannot start: qemu-system-arm", p.stderr)

    def test_the_link_alone_answers_without_the_card(self):
        # AFM_BOARD_MODE=exchange (./afm bench pil): the board answers every
        # block without stepping the card, so the replay diverges at block 0
        out = self.runs[("short", "host")][0]
        code, text, err = replay(out, "--firmware", "qemu", env=dict(os.environ, AFM_BOARD_MODE="exchange"))
        self.assertEqual(code, 1, text + err)
        self.assertIn("first at block 0", text + err)
        self.assertRegex(text, r"a round trip [0-9]+ us median")
        code, text, err = replay(out, "--firmware", "qemu", env=dict(os.environ, AFM_BOARD_MODE="fast"))
        self.assertEqual(code, 2, text + err)
        self.assertIn("AFM_BOARD_MODE='fast': only 'exchange' is known", err)

    def test_a_board_that_faults_or_hangs_ends_the_run_naming_it(self):
        for kind, words in (("hardfault", "exited (status 1) at block 120"), ("hang", "hung: no answer to block 120 within 2 s")):
            with self.subTest(kind=kind):
                out = e2e_support.tmpdir(kind)
                env = dict(os.environ, AFM_BOARD_FAULT=f"{kind}:120")
                t0 = time.monotonic()
                p = subprocess.run([e2e_support.IN_NETNS, e2e_support.LAUNCH, "--scene", self.scenes["short"], "--out", out,
                                    "--quiet", "--firmware", "qemu"], capture_output=True, text=True, timeout=120, env=env)
                self.assertLess(time.monotonic() - t0, 30)
                self.assertEqual(p.returncode, 1, p.stderr)
                rj = json.load(open(os.path.join(out, "run.json")))
                self.assertEqual(rj["status"], "failed")
                self.assertIn("the card's board", rj["error"])
                self.assertIn(words, rj["error"])
                board_log = open(os.path.join(out, "logs", "board.log")).read()
                self.assertIn("fault injection", board_log)
                if kind == "hardfault":
                    self.assertIn("FAULT: HardFault", rj["error"])

    def test_the_fault_matrix_rows_of_the_board(self):
        out = e2e_support.tmpdir("faults")
        p = subprocess.run([os.sys.executable, paths.FAULTS, "--out", out, "--quiet",
                            "--only", "board:killed", "board:hung"], capture_output=True, text=True, timeout=300)
        with open(os.path.join(out, "faults.json")) as f:
            rows = {r["fault"]: r for r in json.load(f)["rows"]}
        for row in ("board:killed", "board:hung"):
            self.assertTrue(rows[row]["ok"], f"{rows[row]}\n{p.stdout[-2000:]}")


if __name__ == "__main__":
    e2e_support.main()
