"""./afm run SCENE --calibrate (analysis/card_calib.py; issue 47, item 4):
a scene whose card section gives no mu and no k_theta K_l / h runs the
tilted calibration first on its own probe and tip-substrate pair, and the
card takes what it measured: run.json card_sources names "calibration run
tilted sha256:KEY" for board.mu_ppm, its value within 2 % of the truth's mu
(the calibration's accuracy) and not the truth's bit for bit. A second run
takes the calibration from the cache ("from the cache: no run" on stderr,
no calibration run made, and faster). A symbolic link planted at the
cache's entry or in place of the cache's folder is refused, not followed.
The scene's probe is in a file it includes: card_calib reads the scene as
the launcher resolves it (afm_launch --resolved), whose own case, an
include merged and a relative path made absolute, is class Resolved."""
import glob
import json
import os
import struct
import subprocess
import sys
import time
import unittest

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import e2e_support  # noqa: E402

AFM = os.path.join(e2e_support.SRC, "afm")
TRUTH_MU = 0.12          # the card's nominal is 0.1: the calibration must find this one
TRUTH_LATERAL = 42.0     # nN/V; the nominal 37.9


def short_text():
    with open(e2e_support.scene("short.yaml")) as f:
        return f.read()


def scene_without_card_mu():
    """scenes/short.yaml on the truth's mu, its probe's truth in probe.yaml
    beside it (include: relative): no firmware section."""
    text = short_text().replace("tip_substrate: {mu: 0.0865, adhesion_nN: 1.0}", f"tip_substrate: {{mu: {TRUTH_MU}, adhesion_nN: 1.0}}")
    assert f"mu: {TRUTH_MU}" in text and "firmware" not in text and "include" not in text
    path = e2e_support.write_scene("include: probe.yaml\n" + text, "scene")
    with open(os.path.join(os.path.dirname(path), "probe.yaml"), "w") as f:
        f.write(f"probe:\n  lateral_nN_per_V: {TRUTH_LATERAL}\n")
    return path


def afm_run(scene, cache, tag, *extra):
    """./afm run SCENE --calibrate with XDG_CACHE_HOME=cache: (exit code, stderr, run.json or None, wall s)."""
    out = os.path.join(e2e_support.tmpdir(tag), "run")
    env = dict(os.environ, XDG_CACHE_HOME=cache)
    t0 = time.monotonic()
    p = subprocess.run([AFM, "run", scene, "--calibrate", "--out", out, "--quiet", "--no-verdict", *extra],
                       capture_output=True, text=True, env=env, timeout=e2e_support.limit(500))
    wall = time.monotonic() - t0
    rj = None
    if os.path.exists(os.path.join(out, "run.json")):
        with open(os.path.join(out, "run.json")) as f:
            rj = json.load(f)
    return p.returncode, p.stderr, rj, wall


def source_of(rj, field):
    return next(c for c in rj["card_sources"] if c["field"] == field)


class CalibrateFirst(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scene = scene_without_card_mu()
        cls.cache = e2e_support.tmpdir("cache")
        cls.first = afm_run(cls.scene, cls.cache, "first")
        cls.second = afm_run(cls.scene, cls.cache, "second")
        for name, (code, err, rj, _) in (("first", cls.first), ("second", cls.second)):
            if code != 0 or rj is None:
                raise AssertionError(f"the {name} run did not complete: exit {code}: {err[-1500:]}")
        cls.entries = glob.glob(os.path.join(cls.cache, "afm-calib", "*.json"))

    def test_1_the_card_takes_the_measured_mu(self):
        code, err, rj, wall = self.first
        self.assertIn("calibrating the card", err)
        mu = source_of(rj, "board.mu_ppm")
        self.assertEqual(mu["key"], "firmware.calibration.mu")
        self.assertRegex(mu["source"], r"^calibration run tilted sha256:[0-9a-f]{16}$")
        self.assertLess(abs(mu["value"] - TRUTH_MU) / TRUTH_MU, 0.02, mu)
        self.assertNotEqual(mu["value"], TRUTH_MU, "the card's mu is the truth's bit for bit: copied, not measured")
        lat = source_of(rj, "board.lateral_gain_pn_per_v")
        self.assertEqual(lat["source"], mu["source"])
        self.assertLess(abs(lat["value"] - TRUTH_LATERAL) / TRUTH_LATERAL, 0.02, lat)
        print(f"first run: {wall:.1f} s; mu {mu['value']:.5f} (truth {TRUTH_MU}), k_theta K_l / h {lat['value']:.3f} "
              f"(truth {TRUTH_LATERAL}); {mu['source']}", file=sys.stderr)

    def test_2_the_second_run_takes_the_cache(self):
        code, err, rj, wall = self.second
        self.assertIn("from the cache", err)
        self.assertNotIn("calibrating the card", err)
        self.assertEqual(source_of(rj, "board.mu_ppm"), source_of(self.first[2], "board.mu_ppm"))
        self.assertLess(wall, self.first[3], "the cached run took as long as the one that calibrated")
        self.assertEqual(len(self.entries), 1, self.entries)
        st = os.stat(os.path.join(self.cache, "afm-calib"))
        self.assertEqual((st.st_uid, st.st_mode & 0o777), (os.geteuid(), 0o700))
        print(f"second run: {wall:.1f} s against {self.first[3]:.1f} s", file=sys.stderr)

    def test_3_a_link_at_the_cache_entry_is_refused(self):
        """A link in place of the entry, to a file that holds the truth's
        values (what a link would smuggle in), is refused: no run."""
        cache = e2e_support.tmpdir("linked-entry")
        os.mkdir(os.path.join(cache, "afm-calib"), 0o700)
        fake = os.path.join(e2e_support.tmpdir("fake"), "fake.json")
        with open(fake, "w") as f:
            json.dump({"mu": TRUTH_MU, "lateral_nN_per_V": TRUTH_LATERAL}, f)
        os.symlink(fake, os.path.join(cache, "afm-calib", os.path.basename(self.entries[0])))
        code, err, rj, _ = afm_run(self.scene, cache, "linked-entry")
        self.assertNotEqual(code, 0, err[-800:])
        self.assertIsNone(rj, "the run started with a linked calibration")
        self.assertIn("a symbolic link, not followed", err)

    def test_4_a_link_in_place_of_the_cache_folder_is_refused(self):
        cache = e2e_support.tmpdir("linked-folder")
        os.symlink(os.path.join(self.cache, "afm-calib"), os.path.join(cache, "afm-calib"))
        code, err, rj, _ = afm_run(self.scene, cache, "linked-folder")
        self.assertNotEqual(code, 0, err[-800:])
        self.assertIsNone(rj)
        self.assertIn("a symbolic link, not a folder", err)


def flat_gsf(path, side_m):
    """A flat 2 x 2 Gwyddion Simple Field map, side_m across, centred on frame A's origin."""
    head = (f"Gwyddion Simple Field 1.0\nXRes = 2\nYRes = 2\nXReal = {side_m}\nYReal = {side_m}\n"
            f"XOffset = {-side_m / 2}\nYOffset = {-side_m / 2}\nXYUnits = m\nZUnits = m\n").encode()
    with open(path, "wb") as f:
        f.write(head + b"\0" * (4 - len(head) % 4) + struct.pack("<4f", 0, 0, 0, 0))


def launch(*args):
    return subprocess.run([e2e_support.LAUNCH, *args], capture_output=True, text=True, timeout=e2e_support.limit(60))


class Resolved(unittest.TestCase):
    """afm_launch --scene FILE --resolved: the scene checked as --check
    checks it, then on stdout as a run keeps it (scene.hpp:
    resolved_scene_text), which card_calib reads."""

    def setUp(self):
        self.dir = e2e_support.tmpdir("resolved")
        with open(os.path.join(self.dir, "part.yaml"), "w") as f:
            f.write(f"probe:\n  lateral_nN_per_V: {TRUTH_LATERAL}\nsample:\n  field_nm: 999\n  temperature_K: 301\n")
        flat_gsf(os.path.join(self.dir, "flat.gsf"), 4e-6)
        text = short_text().replace("  substrate: glass\n", "  substrate: {gsf: flat.gsf, material: glass}\n")
        self.scene = os.path.join(self.dir, "scene.yaml")
        with open(self.scene, "w") as f:
            f.write("include: part.yaml\n" + text)

    def test_an_include_merged_and_a_path_made_absolute(self):
        p = launch("--scene", self.scene, "--resolved", "--quiet")
        self.assertEqual(p.returncode, 0, p.stderr)
        doc = yaml.safe_load(p.stdout)
        self.assertNotIn("include", doc)
        self.assertEqual(doc["probe"]["lateral_nN_per_V"], TRUTH_LATERAL)        # from the include
        self.assertEqual(doc["sample"]["temperature_K"], 301)                   # from the include
        self.assertEqual(doc["sample"]["field_nm"], 2000)                       # the scene's own wins
        self.assertEqual(doc["sample"]["substrate"]["gsf"], os.path.join(os.path.realpath(self.dir), "flat.gsf"))

    def test_a_refusal_as_check_gives_it(self):
        with open(self.scene, "a") as f:
            f.write("zz_not_a_key: 1\n")
        check, res = launch("--scene", self.scene, "--check", "--quiet"), launch("--scene", self.scene, "--resolved", "--quiet")
        self.assertEqual((res.returncode, res.stdout, res.stderr), (2, "", check.stderr))
        self.assertIn("zz_not_a_key", res.stderr)

    def test_it_runs_nothing(self):
        p = launch("--scene", self.scene, "--resolved", "--out", os.path.join(self.dir, "run"))
        self.assertEqual(p.returncode, 2)
        self.assertIn("--resolved", p.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.dir, "run")))


if __name__ == "__main__":
    e2e_support.main()
