"""Thermal drift and local scans (physics.md section 10) across the bench:
the simulator drifts the sample; before each push the renderer takes a quick
local scan around the particle, the firmware re-registers its models by the
difference (object_fix_t -> fw_drift), and the display replaces the region.
Checked from the log: every fix acknowledged, the fixed object's model on
the truth within 1 nm right after each fix, the firmware's drift within
0.5 nm of the true drift for objects not yet pushed, and the final display
within 5 nm of a fresh scan. The report's reader (analysis/report_series.py)
on this drifting log, where every particle moves every block: its fine bins
keep every bin's extremes and figures of a reading row by row, and hand on
rows bounded by the bins, not the blocks."""
import math
import unittest

import numpy as np

import e2e_support
from analysis import afmlog


class DriftAndLocalScans(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out, cls.code, cls.err, cls.rj, cls.log = e2e_support.run_and_load("drift.yaml", "drift")

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def test_run_ok_and_every_local_scan_found_its_particle(self):
        self.assertEqual(self.code, 0, self.err)
        scans = self.rj["renderer"]["local_scans"]
        self.assertEqual(len(scans), 3)
        for s in scans:
            self.assertTrue(s["found"], s)

    def test_each_fix_re_registers_the_model_to_the_truth(self):
        # A fix measures the scanned object against its model: drift, plus
        # whatever error the model of that object had (after a push). Right
        # after the fix that object's model must sit on the truth; and for
        # objects not yet pushed the difference is the drift alone.
        fixes = {f.fix_id: f for f in self.log["HOST_OBJECT_FIX"]}
        self.assertEqual(sorted(fixes), [1, 2, 3])
        truth = afmlog.whole_by_seq(self.log["SIM_TRUTH"], lambda m: m.objects)
        acked = {}
        for m in (s.objects for s in self.log["FW_STATE"]):   # a fix's answer lists every object (complete)
            if m.fix_id and m.fix_id not in acked:
                self.assertTrue(m.complete)
                acked[m.fix_id] = m
        self.assertEqual(sorted(acked), [1, 2, 3])
        for fid, m in sorted(acked.items()):
            oid = fixes[fid].object_id
            model = next(p for p in m.particles if p.id == oid)
            true = next(p for p in truth[m.seq].particles if p.id == oid)
            reg = math.hypot(model.x_nm - true.x_nm, model.y_nm - true.y_nm)
            d_fw, d_true = m.drift_nm, truth[m.seq].drift_nm
            drift_err = math.hypot(d_fw[0] - d_true[0], d_fw[1] - d_true[1])
            print(f"fix {fid} (object {oid}) at block {m.seq}: model-truth {reg:.2f} nm; firmware drift "
                  f"({d_fw[0]:.2f}, {d_fw[1]:.2f}) nm, true ({d_true[0]:.2f}, {d_true[1]:.2f}) nm")
            self.assertLess(reg, 1.0)
            if fid <= 2:   # before any push of the object: pure drift
                self.assertLess(drift_err, 0.5)
        self.assertGreater(math.hypot(*truth[max(truth)].drift_nm), 2.0, "the scene must drift measurably")

    def test_final_display_matches_a_fresh_scan(self):
        fid = self.rj["fidelity"]
        print(f"fidelity: max {fid['max_position_error_nm']:.2f} nm")
        self.assertLess(fid["max_position_error_nm"], 5.0)

    def test_the_reports_reader_keeps_the_extremes_in_rows_bounded_by_its_bins(self):
        from analysis import report_series
        path, bins = f"{self.out}/bus.lcmlog", 64   # 64 bins: fine bins of 16 blocks over these 2 s
        every = report_series.read(path, None, bins)              # every difference handed on
        fine = report_series.read(path, self.rj["sim_seconds"], bins)
        ids = fine.particle_diff_ids()
        self.assertEqual(ids, every.particle_diff_ids())
        self.assertTrue(ids, "particles compared")
        blocks = fine.block_rows[report_series.TRUTH]
        print(f"{blocks} blocks, {len(ids)} particles: {every.diff_rows} difference rows handed on row by row, "
              f"{fine.diff_rows} in fine bins of {report_series.fine_bin_us(self.rj['sim_seconds'], bins):g} us")
        self.assertGreater(every.diff_rows, len(ids) * blocks, "the drift moves every particle every block, on both sides")
        self.assertLessEqual(fine.diff_rows, len(ids) * 5 * 2 * bins, "at most 4 extremes and a late row per fine bin")
        a, b = fine.particle_diff, every.particle_diff
        self.assertEqual(a.width, b.width)
        for i in ids:
            s, r = fine.diff_index[i], every.diff_index[i]
            self.assertTrue(np.array_equal(a.lo[s], b.lo[r]) and np.array_equal(a.hi[s], b.hi[r]), f"particle {i}: a bin's extremes")
            for col in ("x_nm", "y_nm"):
                self.assertEqual(fine.particle_diff_stats[i].figures(col), every.particle_diff_stats[i].figures(col))


class CantileverChangeAndLandmark(unittest.TestCase):
    """scenes/landmark.yaml: the lever is changed (the work space jumps by
    (250, -180) nm, known only to the simulator); a scan around a landmark
    re-registers the firmware's models, the joystick and the display's
    background; the next push lands on the particle where it really is."""

    @classmethod
    def setUpClass(cls):
        cls.out, cls.code, cls.err, cls.rj, cls.log = e2e_support.run_and_load("landmark.yaml", "landmark",
                                                                            {"FW_STATE", "SIM_TRUTH"})

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def test_landmark_scan_finds_the_jump_and_the_run_stays_registered(self):
        self.assertEqual(self.code, 0, self.err)
        scans = self.rj["renderer"]["local_scans"]
        self.assertEqual([s["kind"] for s in scans], ["landmark"])
        self.assertTrue(scans[0]["found"])
        truth = afmlog.whole_by_seq(self.log["SIM_TRUTH"], lambda m: m.objects)
        acked = next(s.objects for s in self.log["FW_STATE"] if s.objects.fix_id == 1)
        true = truth[acked.seq].drift_nm
        err = math.hypot(acked.drift_nm[0] - true[0], acked.drift_nm[1] - true[1])
        print(f"landmark fix: firmware offset ({acked.drift_nm[0]:.2f}, {acked.drift_nm[1]:.2f}) nm, "
              f"true ({true[0]:.2f}, {true[1]:.2f}) nm")
        self.assertGreater(math.hypot(*true), 300.0)
        self.assertLess(err, 2.0)
        first = {p.id: p for p in truth[min(truth)].particles}
        last = {p.id: p for p in truth[max(truth)].particles}
        pushed = math.hypot(last[2].x_nm - first[2].x_nm - true[0], last[2].y_nm - first[2].y_nm - true[1])
        self.assertGreater(pushed, 50.0, "particle 2 must be pushed after the re-registration")
        self.assertLess(self.rj["fidelity"]["max_position_error_nm"], 5.0)


if __name__ == "__main__":
    e2e_support.main()
