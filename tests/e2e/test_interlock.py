"""The card's force interlock on the bench (issue 14, firmware/include/fw_guard.h):
scenes/interlock.yaml's operator asks for 120 nN, above the card's normal
limit (80 % of k_n K_n 10 V: 85.44 nN), with a z servo of 20 um/s. Checked
from the run's own bus log: FW_STATE carries INTERLOCK from the block whose
samples crossed the limit; the command of that block retracts the tip and
the simulator's force drops to zero at once, z 100 nm above contact; the
interlock holds while the operator keeps pressing and releases once the
load falls below the limit less its hysteresis; the display shows it; no
trench is cut. And the bound: the true normal force never exceeds the limit
by more than k_n v_z T_block (plus half an ADC step), measured sample by
sample, on the scene and on a copy whose limit makes the crossing fall on a
block's first sample (the worst case: the whole block's rise), where it
comes within 10 % of the bound."""
import os
import unittest

import yaml
import matplotlib.image

import e2e_support
from analysis import afmlog

FLAG_INTERLOCK = afmlog.afm.fw_state_t.FLAG_INTERLOCK   # = the firmware's FW_FLAG_INTERLOCK (fw_node checks)
CHANNELS = {"FW_STATE", "SIM_TRUTH", "AFM_CMD", "HAPTIC_POSE", "AFM_ANALOG", "RENDER_FRAME"}


class Run:
    """One run of a scene and what the test reads from it."""

    def __init__(self, scene_path, tag):
        self.out = e2e_support.tmpdir(tag)
        self.code, _, self.err, self.rj = e2e_support.run(scene_path, self.out)
        log = afmlog.load(os.path.join(self.out, "bus.lcmlog"), channels=CHANNELS)
        self.force = afmlog.by_seq(log["FW_STATE"])
        self.truth = log["SIM_TRUTH"]
        self.truth_by_seq = afmlog.by_seq(self.truth)
        self.cmd = {m.ack_seq: m for m in log["AFM_CMD"]}
        self.pose = afmlog.by_seq(log["HAPTIC_POSE"])
        self.analog = afmlog.by_seq(log["AFM_ANALOG"])
        # the block each frame shows, from its first announcement
        self.frame_seq = {}
        for m in log["RENDER_FRAME"]:
            self.frame_seq.setdefault(m.index, m.seq)
        with open(os.path.join(self.out, "scene.yaml")) as f:
            self.scene = yaml.safe_load(f)
        card = self.rj["card"]
        # the lever's normal stiffness and gain as the card has them (the
        # scene's probe): k_n = k_n K_n / K_n, nN/nm
        self.kn_kn = card["normal_gain_pn_per_v"] * 1e-3                         # nN/V
        self.kn = card["normal_gain_pn_per_v"] / card["deflection_pm_per_v"]   # nN/nm
        self.half_lsb = card["full_scale_pn"] * 1e-3 / 2 ** card["adc_bits"]    # nN: half of 20 V / 2^bits
        fw = self.scene.get("firmware") or {}
        self.limit = fw.get("interlock_normal_nN", 0.8 * card["full_scale_pn"] * 1e-3)
        self.v_z = self.scene["afm"]["z_speed_nm_per_s"]
        self.t_block = card["samples_per_block"] / self.scene["sample_rate_hz"]
        self.bound = self.kn * self.v_z * self.t_block

    def true_fz(self, n):
        """The true normal force at each sample of block n, nN: k_n K_n S_n
        from the simulator's volts (F_x = 0: the tip slides across the lever;
        no noise effect; the ADC quantises later, on the card)."""
        a = self.analog[n]
        return [self.kn_kn * v for v in a.sn_v[:a.n]]

    def latched(self, n):
        return bool(self.force[n].flags & FLAG_INTERLOCK)

    def first_trip(self):
        return min(n for n in self.force if self.latched(n))

    def overshoot(self):
        """The largest true normal force, sample by sample, over the limit."""
        return max(max(self.true_fz(n)) for n in self.analog) - self.limit


class Interlock(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.base = Run(e2e_support.scene("interlock.yaml"), "interlock")
        cls.worst = None
        if cls.base.code == 0:
            # The same scene with the limit just above the last sample of the
            # block before the trip: the first sample of the next block
            # crosses it, and that block's whole rise lies past the limit.
            r = cls.base
            last = r.true_fz(r.first_trip() - 1)[-1]
            rise = r.kn * r.v_z / r.scene["sample_rate_hz"]
            with open(e2e_support.scene("interlock.yaml")) as f:
                text = f.read()
            limit = round(last + rise / 2, 3)
            text = text.replace("  compensate: false\n", f"  compensate: false\n  interlock_normal_nN: {limit}\n", 1)
            cls.worst = Run(e2e_support.write_scene(text, "interlock-worst"), "interlock-worst-run")

    @classmethod
    def tearDownClass(cls):
        for r in (cls.base, cls.worst):
            if r is not None:
                e2e_support.cleanup(r.out)

    def test_run_ok_and_the_per_sample_forces_are_the_truths(self):
        self.assertEqual(self.base.code, 0, self.base.err)
        # the per-sample reading agrees with SIM_TRUTH's block means
        for n, t in self.base.truth_by_seq.items():
            f = self.base.true_fz(n)
            self.assertAlmostEqual(sum(f) / len(f), t.force_nN[2], delta=1e-6)

    def test_the_block_that_crosses_the_limit_trips_and_flags_interlock(self):
        r = self.base
        n = r.first_trip()
        print(f"limit {r.limit:.3f} nN: tripped in block {n}, its samples up to {max(r.true_fz(n)):.3f} nN; "
              f"block {n - 1} up to {max(r.true_fz(n - 1)):.3f} nN")
        self.assertEqual(r.rj["fw"]["interlock_trips"], 1)   # fw_node's report: one trip, held after it
        self.assertGreater(max(r.true_fz(n)), r.limit - r.half_lsb)
        self.assertLessEqual(max(r.true_fz(n - 1)), r.limit + r.half_lsb)
        self.assertEqual(r.pose[n].load_nN, 120.0)

    def test_the_tip_retracts_at_once(self):
        r = self.base
        n = r.first_trip()
        self.assertFalse(r.cmd[n].engaged)
        self.assertTrue(r.pose[n].engaged)   # the operator still presses; the card lifts
        before, after = r.truth_by_seq[n], r.truth_by_seq[n + 1]
        self.assertGreater(before.force_nN[2], 80.0)
        self.assertEqual(max(abs(v) for v in r.analog[n + 1].sn_v[:r.analog[n + 1].n]), 0.0)   # from the first sample on
        self.assertEqual(after.force_nN[2], 0.0)
        # z: from contact at the load to 100 nm above the contact height (flat: 0)
        print(f"z at block {n}: {before.piezo_nm[2]:.1f} nm, at block {n + 1}: {after.piezo_nm[2]:.1f} nm")
        self.assertAlmostEqual(after.piezo_nm[2], 100.0, delta=1e-6)
        self.assertAlmostEqual(r.analog[n + 1].piezo_z_nm[0], 100.0, delta=1e-6)

    def test_it_holds_while_the_operator_presses_and_releases_past_the_hysteresis(self):
        r = self.base
        n = r.first_trip()
        release = r.limit - r.limit / 8
        m = n + 1
        while r.pose[m].load_nN >= release:
            self.assertTrue(r.latched(m), m)
            self.assertFalse(r.cmd[m].engaged, m)
            self.assertEqual(r.truth_by_seq[m + 1].force_nN[2], 0.0)
            m += 1
        print(f"held blocks {n}..{m - 1} at the operator's {r.pose[m - 1].load_nN} nN; released in block {m} "
              f"at {r.pose[m].load_nN} nN (below {release:.2f} nN)")
        self.assertGreater(m - n, 50)
        self.assertFalse(r.latched(m))
        self.assertTrue(r.cmd[m].engaged)
        self.assertEqual(r.cmd[m].load_nN, r.pose[m].load_nN)
        self.assertFalse(any(r.latched(k) for k in r.force if k > m))

    def test_the_bound_holds_sample_by_sample(self):
        for r in (self.base, self.worst):
            self.assertIsNotNone(r)
            self.assertEqual(r.code, 0, r.err)
            worst_mean = max(t.force_nN[2] for t in r.truth) - r.limit
            print(f"limit {r.limit:.3f} nN, bound k_n v_z T_block = {r.kn:.3f} nN/nm x {r.v_z:.0f} nm/s x "
                  f"{r.t_block * 1e3:.1f} ms = {r.bound:.3f} nN (+ {r.half_lsb * 1e3:.2f} pN): largest overshoot "
                  f"{r.overshoot():.3f} nN per sample, {worst_mean:.3f} nN as SIM_TRUTH's block mean")
            self.assertLessEqual(r.overshoot(), r.bound + r.half_lsb)
            self.assertLessEqual(worst_mean, r.bound + r.half_lsb)
            self.assertGreater(r.overshoot(), 0.0)
        # the crossing on a block's first sample: the whole block's rise,
        # the bound less the part of one sample's rise below the limit
        self.assertGreater(self.worst.overshoot(), 0.9 * self.worst.bound)

    def test_the_display_shows_it(self):
        # Each frame shows its own block: the objects, the force and the tip
        # (FW_STATE) of the block it fell due at, which its announcement
        # names (RENDER_FRAME.seq), and the red border exactly when that
        # block's FW_STATE is latched.
        r = self.base
        fps, bhz = r.scene["frame_rate_hz"], r.scene["block_hz"]
        self.assertEqual(r.rj["renderer"]["frames_mixed_blocks"], 0)

        def red_border(k):
            img = matplotlib.image.imread(os.path.join(r.out, "frames", f"frame_{k:05d}.png"))
            col = img[:, 0, :3]
            return float(((col[:, 0] > 0.8) & (col[:, 1] < 0.2) & (col[:, 2] < 0.2)).mean())

        shown = {True: 0, False: 0}
        for k, seq in r.frame_seq.items():
            self.assertLessEqual(k / fps, (seq + 1) / bhz + 1e-9, (k, seq))   # due by the block's end
            self.assertEqual(red_border(k), 1.0 if r.latched(seq) else 0.0, (k, seq))
            shown[r.latched(seq)] += 1
        print(f"{len(r.frame_seq)} of {r.rj['frames']} frames announced one by one: {shown[True]} latched, {shown[False]} not")
        self.assertGreater(len(r.frame_seq), r.rj["frames"] // 2)
        self.assertTrue(shown[True] and shown[False], shown)

    def test_no_trench_is_cut(self):
        # the cut asked 120 nN against a 100 nN threshold: the interlock kept
        # the force below it, the sample is untouched
        self.assertLess(self.base.overshoot() + self.base.limit, self.base.scene["sample"]["lithography"]["threshold_nN"])
        self.assertTrue(all(t.objects.n_trenches == 0 for t in self.base.truth))


if __name__ == "__main__":
    e2e_support.main()
