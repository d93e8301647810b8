"""The fault matrix's fast rows (tools/faults.py; ./afm faults runs them all):
a stopped process, a killed one, the launcher interrupted, every message
duplicated and reordered, a full disk, the scene changed under a run."""
import json
import os
import subprocess
import sys
import unittest

import benchtest

FAULTS = os.path.join(benchtest.SRC, "tools", "faults.py")
FAST = ["stop:fw_node", "kill:renderer", "launcher:SIGINT", "net:dup", "disk:full", "scene:changed"]


class FaultMatrix(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = benchtest.tmpdir("faults")
        cls.p = subprocess.run([sys.executable, FAULTS, "--out", cls.out, "--quiet", "--only", *FAST], capture_output=True, text=True,
                               timeout=900)
        path = os.path.join(cls.out, "faults.json")
        if not os.path.exists(path):
            raise AssertionError(f"tools/faults.py wrote no faults.json (exit {cls.p.returncode}):\n{cls.p.stdout}\n{cls.p.stderr}")
        with open(path) as f:
            cls.rows = {r["fault"]: r for r in json.load(f)["rows"]}

    @classmethod
    def tearDownClass(cls):
        benchtest.cleanup(cls.out)

    def check(self, fault):
        r = self.rows[fault]
        self.assertTrue(r["ok"], f"{fault}: {r}\n{self.p.stdout[-2000:]}")

    def test_a_process_stopped_for_2_s_leaves_the_trajectories_unchanged(self):
        self.check("stop:fw_node")
        self.assertTrue(self.rows["stop:fw_node"]["match"])

    def test_a_killed_process_fails_the_run_naming_it_and_keeps_the_record(self):
        self.check("kill:renderer")
        self.assertTrue(self.rows["kill:renderer"]["kept"])

    def test_an_interrupted_launcher_stops_every_child_and_says_interrupted(self):
        self.check("launcher:SIGINT")

    def test_duplicated_and_reordered_messages_leave_the_trajectories_unchanged(self):
        self.check("net:dup")

    def test_a_full_disk_gives_a_clear_error_and_no_run_json_claiming_success(self):
        self.check("disk:full")

    def test_a_scene_changed_while_the_run_starts_does_not_change_the_run(self):
        self.check("scene:changed")

    def test_the_matrix_prints_one_row_per_fault(self):
        self.assertEqual(self.p.returncode, 0, self.p.stdout + self.p.stderr)
        for f in FAST:
            self.assertIn(f, self.p.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
