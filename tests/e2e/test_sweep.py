"""./afm sweep (issue 11): a 4-point sweep on a local Dask cluster writes a
CSV with every knob, error and cost; the errors fall as the ADC's bits rise
from 10 to 16; a repeat gives identical errors; running it again resumes
(nothing is run twice). A sweep through a real `dask scheduler` with two
`dask worker` processes on 127.0.0.1. Bad input is named before anything
starts."""
import csv
import json
import os
import socket
import subprocess
import sys
import time
import unittest

import benchtest

PY = sys.executable
DASK = os.path.join(os.path.dirname(PY), "dask")
ENV = dict(os.environ, PYTHONPATH=f"{benchtest.SRC}:{os.path.join(benchtest.SRC, 'tools')}")
SHORT = benchtest.scene("short.yaml")


def sweep(*args, timeout=600):
    p = subprocess.run([PY, "-m", "analysis.sweep", *args], capture_output=True, text=True, timeout=timeout, env=ENV,
                       cwd=benchtest.SRC)
    return p.returncode, p.stdout, p.stderr


def rows(out):
    with open(os.path.join(out, "sweep.csv")) as f:
        return list(csv.DictReader(f))


class LocalSweep(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = benchtest.tmpdir("sweep")
        cls.first = sweep(SHORT, "--vary", "firmware.adc_bits=10,12,14,16", "--out", cls.out, "--workers", "2")

    @classmethod
    def tearDownClass(cls):
        benchtest.cleanup(cls.out)

    def test_four_points_measured_with_every_column(self):
        code, so, se = self.first
        self.assertEqual(code, 0, so + se)
        r = rows(self.out)
        self.assertEqual([x["firmware.adc_bits"] for x in r], ["10", "12", "14", "16"])
        for col in ("firmware.adc_bits", "status", "force_rms_pN", "force_worst_pN", "force_rms_pct_fs", "apex_rms_nm",
                    "apex_worst_nm", "objects_worst_nm", "objects_final_nm", "display_max_nm", "wall_s_per_sim_s",
                    "cpu_s_per_sim_s", "cpu_fw_node_s_per_sim_s", "cpu_sim_afm_s_per_sim_s", "fw_instr_per_sample",
                    "renderer_ms_per_frame", "log_bytes", "run_dir"):
            self.assertIn(col, r[0], col)
        for x in r:
            self.assertEqual(x["status"], "ok", x)
            self.assertTrue(os.path.exists(os.path.join(x["run_dir"], "bus.lcmlog")))
            self.assertGreater(float(x["fw_instr_per_sample"]), 50)
            self.assertGreater(float(x["cpu_fw_node_s_per_sim_s"]), 0)
        for f in ("sweep.json", "report.html"):
            self.assertTrue(os.path.exists(os.path.join(self.out, f)), f)
        plots = os.listdir(os.path.join(self.out, "plots"))
        self.assertIn("apex_rms_nm__fw_instr_per_sample.svg", plots)
        self.assertIn("apex_rms_nm__fw_instr_per_sample.png", plots)
        with open(os.path.join(self.out, "report.html")) as f:
            html = f.read()
        self.assertIn("<svg", html)
        self.assertIn("adc_bits=10", html)
        self.assertIn("adc_bits=16", so)   # the table on stdout

    def test_errors_fall_as_the_adc_bits_rise(self):
        r = {int(x["firmware.adc_bits"]): x for x in rows(self.out)}
        # the apex estimate and the objects' models carry the ADC's steps
        self.assertGreater(float(r[10]["apex_rms_nm"]), 1.1 * float(r[16]["apex_rms_nm"]))
        # (measured on short.yaml: 1.23 nm at 10 bits, 0.93 nm at 16; it was
        # 1.5x before the operator's hand rounded the path's corner, where
        # the 10-bit model lost the particle most)
        self.assertGreater(float(r[10]["objects_worst_nm"]), 1.2 * float(r[16]["objects_worst_nm"]))
        self.assertGreater(float(r[10]["display_max_nm"]), float(r[16]["display_max_nm"]))

    def test_resume_runs_nothing_twice_and_a_repeat_gives_identical_errors(self):
        before = {x["point"]: os.path.getmtime(os.path.join(x["run_dir"], "run.json")) for x in rows(self.out)}
        code, so, se = sweep(SHORT, "--vary", "firmware.adc_bits=10,12,14,16", "--out", self.out, "--workers", "2")
        self.assertEqual(code, 0, so + se)
        self.assertIn("4 done before, 0 to run", se)
        after = {x["point"]: os.path.getmtime(os.path.join(x["run_dir"], "run.json")) for x in rows(self.out)}
        self.assertEqual(before, after, "a done point was run again")
        # two points, each run twice: the errors repeat exactly
        out = benchtest.tmpdir("sweep-repeat")
        self.addCleanup(benchtest.cleanup, out)
        code, so, se = sweep(SHORT, "--vary", "firmware.adc_bits=12,16", "--out", out, "--workers", "2", "--repeat",
                             "2", "--no-callgrind")
        self.assertEqual(code, 0, so + se)
        with open(os.path.join(out, "sweep.json")) as f:
            pts = json.load(f)["points"]
        self.assertEqual(len(pts), 2)
        for p in pts:
            self.assertEqual(len(p["runs"]), 2)
            self.assertTrue(p["errors_identical_over_repeats"])
            self.assertEqual(p["runs"][0]["errors"], p["runs"][1]["errors"])
            self.assertIn("wall_s_per_sim_s", p["cost_spread"])


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class ThroughADaskScheduler(unittest.TestCase):
    def test_a_sweep_through_a_scheduler_and_two_workers_on_127_0_0_1(self):
        port = free_port()
        addr = f"tcp://127.0.0.1:{port}"
        procs = [subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                                  env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)]
        out = benchtest.tmpdir("sweep-sched")
        try:
            for _ in range(2):
                procs.append(subprocess.Popen([DASK, "worker", addr, "--host", "127.0.0.1", "--nthreads", "1",
                                               "--no-dashboard"], env=ENV, stdout=subprocess.DEVNULL,
                                              stderr=subprocess.DEVNULL, start_new_session=True))
            from distributed import Client
            deadline = time.time() + 60
            while True:
                try:
                    with Client(addr, timeout=5) as c:
                        if len(c.scheduler_info()["workers"]) == 2:
                            break
                except OSError:
                    pass
                self.assertLess(time.time(), deadline, "the scheduler and its two workers did not come up")
                time.sleep(0.5)
            code, so, se = sweep(SHORT, "--vary", "firmware.word_bits=16,32", "--out", out, "--scheduler", addr,
                                 "--no-callgrind")
            self.assertEqual(code, 0, so + se)
            self.assertIn(f"Dask cluster at {addr}", open(os.path.join(out, "report.html")).read())
            r = rows(out)
            self.assertEqual(sorted(x["firmware.word_bits"] for x in r), ["16", "32"])
            self.assertTrue(all(x["status"] == "ok" for x in r), r)
        finally:
            for p in reversed(procs):
                p.terminate()
            for p in procs:
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
            benchtest.cleanup(out)


class BadInput(unittest.TestCase):
    def refused(self, *args, needle):
        out = os.path.join(benchtest.tmpdir("sweep-bad"), "out")
        self.addCleanup(benchtest.cleanup, os.path.dirname(out))
        code, so, se = sweep(*args, "--out", out)
        self.assertEqual(code, 2, so + se)
        self.assertIn(needle, se)
        self.assertFalse(os.path.exists(out), "nothing may start for bad input")
        return se

    def test_unknown_knob_is_named_with_its_flag(self):
        se = self.refused(SHORT, "--vary", "firmware.adc_bitz=10,12", needle="--vary firmware.adc_bitz=10,12")
        self.assertIn("firmware.adc_bitz: unknown key", se)

    def test_empty_value_list(self):
        self.refused(SHORT, "--vary", "firmware.adc_bits=", needle="the list of values for firmware.adc_bits is empty")

    def test_non_numeric_value(self):
        se = self.refused(SHORT, "--vary", "firmware.adc_bits=ten", needle="firmware.adc_bits")
        self.assertIn("'ten'", se)

    def test_value_out_of_the_cards_range(self):
        se = self.refused(SHORT, "--vary", "firmware.adc_bits=12,20", needle="point adc_bits=20")
        self.assertIn("8 to 16 bits", se)

    def test_a_scene_that_fails_to_validate(self):
        bad = benchtest.write_scene(open(SHORT).read().replace("duration_s: 0.6", "duration_s: -1"), "sweep-badscene")
        self.addCleanup(benchtest.cleanup, os.path.dirname(bad))
        self.refused(bad, "--vary", "firmware.adc_bits=12,16", needle=f"{bad}: duration_s: must be > 0")

    def test_a_sweep_file_with_an_unknown_key(self):
        path = benchtest.write_scene(f"scene: {SHORT}\nvary: {{firmware.adc_bits: [12]}}\nworkers: 3\n", "sweep-file")
        self.addCleanup(benchtest.cleanup, os.path.dirname(path))
        self.refused(path, needle=f"{path}: unknown key 'workers'")


if __name__ == "__main__":
    benchtest.main()
