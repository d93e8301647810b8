"""The fault matrix's fast rows (faults/faults.py; ./afm faults runs them all):
a stopped process, a killed one, the launcher interrupted, every message
duplicated and reordered, datagrams dropped, duplicated and reordered by the
kernel, a full disk, the scene changed under a run, links the run's user planted in its folder."""
import json
import os
import subprocess
import sys
import unittest

import e2e_support
from analysis import paths

FAULTS = paths.FAULTS
FAST = ["stop:fw_node", "kill:renderer", "launcher:SIGINT", "launcher:SIGKILL", "net:dup", "net:kernel", "disk:full", "scene:changed",
        "spoof-port:pose", "spoof-port:pose:nokey", "planted:link"]
NETFAULT = paths.NETFAULT


class FaultMatrix(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = e2e_support.tmpdir("faults")
        cls.p = subprocess.run([sys.executable, FAULTS, "--out", cls.out, "--quiet", "--only", *FAST], capture_output=True, text=True,
                               timeout=e2e_support.limit(600))
        path = os.path.join(cls.out, "faults.json")
        if not os.path.exists(path):
            raise AssertionError(f"faults/faults.py wrote no faults.json (exit {cls.p.returncode}):\n{cls.p.stdout}\n{cls.p.stderr}")
        with open(path) as f:
            cls.rows = {r["fault"]: r for r in json.load(f)["rows"]}

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def check(self, fault):
        r = self.rows[fault]
        self.assertTrue(r["ok"], f"{fault}: {r}\n{self.p.stdout[-2000:]}")

    def test_a_process_stopped_for_2_s_leaves_the_trajectories_unchanged(self):
        self.check("stop:fw_node")
        self.assertTrue(self.rows["stop:fw_node"]["match"])

    def test_a_killed_process_fails_the_run_naming_it_and_keeps_the_record(self):
        self.check("kill:renderer")
        self.assertTrue(self.rows["kill:renderer"]["kept"])

    def test_links_the_runs_user_planted_are_followed_by_nothing_root_does(self):
        self.check("planted:link")
        if os.geteuid() == 0:
            self.assertIn("targets untouched", self.rows["planted:link"]["bench"])

    def test_an_interrupted_launcher_stops_every_child_and_says_interrupted(self):
        self.check("launcher:SIGINT")

    def test_duplicated_and_reordered_messages_leave_the_trajectories_unchanged(self):
        self.check("net:dup")

    def test_datagrams_dropped_duplicated_and_reordered_by_the_kernel_leave_the_trajectories_unchanged(self):
        self.check("net:kernel")
        r = self.rows["net:kernel"]
        self.assertTrue(r["match"], r)
        self.assertIn("log complete True", r["kept_text"])
        with open(os.path.join(self.out, "net-kernel", "netfault.json")) as f:
            nf = json.load(f)
        # the kernel did drop (only the lockstep's channels), duplicate and reorder
        self.assertGreater(nf["dropped"], 0)
        self.assertEqual(set(nf["dropped_by_channel"]) - {"AFM_ANALOG", "AFM_CMD", "HAPTIC_FORCE", "HAPTIC_POSE"}, set())
        self.assertGreater(nf["duplicated"], 0)
        self.assertEqual(nf["duplicates_failed"], 0)
        self.assertGreater(nf["reordered"], 0)
        for ch in ("AFM_ANALOG", "AFM_CMD", "FW_STATE", "HAPTIC_POSE"):
            self.assertGreater(nf["seen_by_channel"].get(ch, 0), 0, ch)

    def test_the_kernel_fault_tool_refuses_absurd_options_naming_them(self):
        for args, says in ((["--queue", "0", "--report", "x", "--drop", "2"], "--drop"),
                           (["--queue", "0", "--report", "x", "--reorder", "nan"], "--reorder"),
                           (["--queue", "70000", "--report", "x"], "--queue"),
                           (["--queue", "0"], "--report"),
                           (["--queue", "0", "--report", "x", "--hold-us"], "--hold-us"),
                           (["--bogus", "1"], "--bogus")):
            p = subprocess.run([NETFAULT, *args], capture_output=True, text=True, timeout=10)
            self.assertEqual(p.returncode, 2, args)
            self.assertIn(says, p.stderr, args)

    def test_a_full_disk_gives_a_clear_error_and_no_run_json_claiming_success(self):
        self.check("disk:full")

    def test_a_scene_changed_while_the_run_starts_does_not_change_the_run(self):
        self.check("scene:changed")

    def test_a_launcher_killed_outright_takes_its_processes_and_the_next_run_says_so(self):
        # issue 46: SIGKILL of afm_launch left its four children running
        self.check("launcher:SIGKILL")
        self.assertIn("none left", self.rows["launcher:SIGKILL"]["match_text"])

    def test_a_pose_from_the_operators_port_is_refused_with_the_key_and_acts_without(self):
        # issue 46: a pose for block n + 1 from the operator's port (a raw
        # socket) made the run diverge from block 7605 under status ok
        self.check("spoof-port:pose")
        self.assertTrue(self.rows["spoof-port:pose"]["match"])
        self.check("spoof-port:pose:nokey")
        self.assertFalse(self.rows["spoof-port:pose:nokey"]["match"], "without the key the forgery acts: the row shows what the key holds off")

    def test_the_matrix_prints_one_row_per_fault(self):
        self.assertEqual(self.p.returncode, 0, self.p.stdout + self.p.stderr)
        for f in FAST:
            self.assertIn(f, self.p.stdout)


if __name__ == "__main__":
    e2e_support.main()
