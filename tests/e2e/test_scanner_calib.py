"""./afm calib scanner at a reduced size (128 px) on the lab scene's
instrument (issue 48, item 2): the fitted model is the simulator's scanner
within a few nm on the demo's path (the truth's hysteresis computed here
from the scene's afm.hysteresis, which the calibration never reads); its
include makes a valid scene; and the card's scanner keys are refused in one
line naming the key and its value (the reader's ranges and the card's
rules)."""
import os
import subprocess
import unittest

import numpy as np
import yaml

import e2e_support

from analysis import scanner_calib, scanner_fit  # noqa: E402

LAB = os.path.join(e2e_support.SRC, "scenes", "lab", "default.yaml")


def truth_scanner(x, x0, width, span):
    """physics.md 17.1's model (the simulator's PlayHysteresis), started at x0."""
    n = 16
    a = 4 * width / (1 + 2 * width)
    g = 1 / (1 - a / 2)
    r = (np.arange(n) + 0.5) / n * span / 2
    z = np.full(n, float(x0))
    out = []
    for xk in x:
        z = np.maximum(xk - r, np.minimum(xk + r, z))
        out.append(x0 + g * ((1 - a) * (xk - x0) + a / n * np.sum(z - x0)))
    return np.array(out)


def check(text, tag):
    path = os.path.join(e2e_support.tmpdir(tag), "scene.yaml")
    with open(path, "w") as f:
        f.write(text)
    p = subprocess.run([e2e_support.LAUNCH, "--check", "--scene", path], capture_output=True, text=True,
                       timeout=e2e_support.limit(60))
    return p.returncode, p.stderr.strip().splitlines()


class Calibration(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = e2e_support.tmpdir("scanner_calib")
        cls.include = os.path.join(cls.out, "scanner.yaml")
        # 320 px, as scenes/lab/calibration/scanner.yml was fitted: the grating
        # spans 1.25 times the field, and at 224 px the fit is 5.1 nm off on y
        cls.code = scanner_calib.main([LAB, "--px", "320", "--out", cls.out, "--write", cls.include,
                                       "--timeout-s", str(e2e_support.limit(240))])
        with open(LAB) as f:
            cls.scene = yaml.safe_load(f)

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def test_it_writes_the_include_and_the_plot(self):
        self.assertEqual(self.code, 0)
        self.assertTrue(os.path.getsize(os.path.join(self.out, "scanner_loop.png")) > 10000)
        with open(self.include) as f:
            doc = yaml.safe_load(f)
        sc = doc["firmware"]["scanner"]
        self.assertTrue(sc["run"].startswith("scanner sha256:"))
        for ax in ("x", "y"):
            self.assertEqual(len(sc[ax]["r_nm"]), 16)
            self.assertEqual(sc[ax]["r_nm"][0], 0)

    def test_the_fit_is_the_simulators_scanner_on_the_demos_path(self):
        with open(self.include) as f:
            sc = yaml.safe_load(f)["firmware"]["scanner"]
        h = self.scene["afm"]["hysteresis"]
        path = np.array(self.scene["operator"]["path_nm"], dtype=float)
        for i, ax in enumerate(("x", "y")):
            x = np.concatenate([np.linspace(path[k][i], path[k + 1][i], 200) for k in range(len(path) - 1)])
            true = truth_scanner(x, x[0], h["width_pct"] / 100, h["span_nm"])
            fit = scanner_fit.pi_model(x - x[0], sc[ax]["r_nm"], sc[ax]["w"]) + x[0]
            worst = float(np.max(np.abs(fit - true)))
            self.assertLess(worst, 5.0, f"{ax}: the fit {worst:.1f} nm off the truth's scanner (uncompensated: "
                                        f"{float(np.max(np.abs(true - x))):.0f} nm)")
            self.assertGreater(float(np.max(np.abs(true - x))), 50.0)   # the path does show the hysteresis

    def test_a_scene_including_it_is_valid(self):
        text = open(LAB).read().replace("include: [calibration/scanner.yml]", f"include: [{self.include}]")
        code, lines = check(text, "scanner_ok")
        self.assertEqual(code, 0, lines)


class Refusals(unittest.TestCase):
    """The card's scanner keys refused in one line naming key and value."""
    BASE = open(LAB).read().replace("include: [calibration/scanner.yml]\n", "").replace("  creep_gamma_pct_per_decade: 1.5\n", "")
    MODEL = ("  scanner:\n    run: test\n    x: {r_nm: [0, 500], w: [0.8, W]}\n"
             "    y: {r_nm: [0, 500], w: [0.8, 0.2]}\n")

    def refused(self, firmware_extra, key, *words):
        text = self.BASE.replace("firmware:\n  adc_bits: 16\n", "firmware:\n  adc_bits: 16\n" + firmware_extra)
        code, lines = check(text, "scanner_bad")
        self.assertEqual(code, 2, lines)
        self.assertEqual(len(lines), 1, lines)
        self.assertIn(key, lines[0])
        for w in words:
            self.assertIn(w, lines[0])

    def test_hysteresis_on_without_a_model(self):
        self.refused("", "firmware.hyst_enable", "needs the scanner's model", "./afm calib scanner")

    def test_a_model_the_card_cannot_invert(self):
        self.refused(self.MODEL.replace("W", "1.3"), "firmware.scanner.x.w[1]", "partial sum", "1.3")

    def test_thresholds_out_of_order(self):
        self.refused(self.MODEL.replace("W", "0.2").replace("x: {r_nm: [0, 500]", "x: {r_nm: [0, -5]"),
                     "firmware.scanner.x.r_nm[1]", "-5")

    def test_a_weight_out_of_range(self):
        self.refused(self.MODEL.replace("W", "-2.5"), "firmware.scanner.x.w[1]", "-2.5")

    def test_a_creep_law_out_of_range(self):
        self.refused(self.MODEL.replace("W", "0.2") + "  creep_gamma_pct_per_decade: 12\n", "firmware.creep_gamma_pct_per_decade", "12")

    def test_a_creep_law_the_card_refuses(self):
        # the block's 1 ms past t0 / 16: the card's rule, named by its switch
        self.refused(self.MODEL.replace("W", "0.2") + "  creep_t0_s: 0.01\n", "firmware.creep_enable", "firmware.creep_t0_s 0.01")


if __name__ == "__main__":
    e2e_support.main()
