"""./afm check warns before the run (issues 37 and 50): what is valid but
likely unmeant is a warning naming the scene file, the key and the value,
with what to do (host/launch/warnings.hpp); --strict makes it an error
(exit 2); expect: silences the warning of a failure the scene expects.
Each warning fires on a small bad scene and on none of the committed
scenes. Only afm_launch --check runs here: no scene is run."""
import glob
import json
import os
import subprocess
import unittest

import e2e_support

SHORT = open(e2e_support.scene("short.yaml")).read()
PATH = "    - [0, -700]\n    - [0, -90]\n    - [300, -90]\n"


def launch(path, *extra):
    return subprocess.run([e2e_support.LAUNCH, "--check", "--scene", path, *extra], capture_output=True, text=True,
                          timeout=e2e_support.limit(60))


def check(text, *extra):
    """launcher --check on the scene text: (exit code, stderr lines)."""
    path = e2e_support.write_scene(text, "warn")
    p = launch(path, *extra)
    e2e_support.cleanup(os.path.dirname(path))
    return p.returncode, [l for l in p.stderr.splitlines() if l.strip()]


def committed_scenes():
    src = os.path.join(e2e_support.SRC, "scenes")
    return sorted(glob.glob(os.path.join(src, "*.yaml")) + glob.glob(os.path.join(src, "paper", "*.yaml")) +
                  glob.glob(os.path.join(src, "lab", "*.yaml")))


class CheckWarnings(unittest.TestCase):
    def warned(self, text, key, words):
        code, lines = check(text)
        self.assertEqual(code, 0, lines)
        hits = [l for l in lines if f"scene.yaml: warning: {key}" in l and words in l]
        self.assertEqual(len(hits), 1, lines)
        code, lines = check(text, "--strict")
        self.assertEqual(code, 2, lines)
        self.assertTrue(any(key in l and words in l and "warning" not in l for l in lines), lines)
        return hits[0]

    def quiet(self, text):
        code, lines = check(text, "--strict")
        self.assertEqual(code, 0, lines)
        self.assertEqual(lines, [])

    def test_a_push_along_the_levers_axis(self):
        text = SHORT.replace(PATH, "    - [-700, -300]\n    - [300, -300]\n")
        self.warned(text, "operator.path_nm[1]", "pushes particle 1 within 14.48 deg of the lever's axis")
        self.assertEqual(check(text + "expect: [unobservable_push]\n", "--strict")[0], 0)

    def test_particles_without_adhesion(self):
        self.warned(SHORT.replace("[bending_offset, adhesion, ", "[bending_offset, "), "effects", "no adhesion effect")

    def test_a_load_past_the_interlock_and_past_the_levers_range(self):
        self.warned(SHORT.replace("  load_nN: 5\n", "  load_nN: 500\n"), "operator.load_nN", "beyond the card's interlock limit")
        self.assertEqual(check(SHORT.replace("  load_nN: 5\n", "  load_nN: 500\n") + "expect: [interlock]\n", "--strict")[0], 0)
        off = SHORT.replace("  load_nN: 5\n", "  load_nN: 500\n").replace("effects:", "firmware: {interlock: false}\neffects:")
        self.warned(off, "operator.load_nN", "beyond the lever's range")

    def test_a_path_off_the_scan_field_is_refused_outright(self):
        code, lines = check(SHORT.replace("    - [0, -700]\n", "    - [0, -1500]\n"))
        self.assertEqual(code, 2, lines)
        self.assertIn("operator.path_nm[0]", lines[0])
        self.assertIn("outside the joystick's reach", lines[0])

    def test_a_path_that_outlasts_the_run(self):
        # 610 + 300 nm at 2000 nm/s: the script is done at 0.455 s
        line = self.warned(SHORT.replace("duration_s: 0.6", "duration_s: 0.4"), "operator.path_nm:",
                           "the script's path ends at 0.455 s (910 nm at operator.speed_nm_per_s 2000), after duration_s 0.4 s")
        self.assertIn("on the way to operator.path_nm[2]; make duration_s at least 0.455", line)
        self.quiet(SHORT.replace("duration_s: 0.6", "duration_s: 0.455"))
        # mode feel: a felt contact ends a stroke early, so the path's walk is no end time
        code, lines = check(SHORT.replace("duration_s: 0.6", "duration_s: 0.4").replace("  load_nN: 5\n", "  load_nN: 5\n  mode: feel\n"))
        self.assertFalse(any("path ends" in l for l in lines), lines)

    def test_a_stroke_the_particle_cannot_follow(self):
        # 5 nm off the centre, 270 nm past the touch: r_tip + r_p = 60 nm, the
        # sphere leaves the tip 60 ln(1 / tan(asin(5 / 60) / 2)) = 190.6 nm after it
        line = self.warned(SHORT.replace(PATH, "    - [5, -700]\n    - [5, -90]\n    - [300, -90]\n"), "operator.path_nm[1]",
                           "the stroke pushes particle 1, 5 nm off its centre")
        self.assertIn("slides off the tip 190.5 nm after the tip meets it, 79.2 nm before the stroke's end", line)
        # the 400 nm stroke: followed when aimed through the centre, lost 1 nm off it
        self.quiet(SHORT.replace(PATH, "    - [0, -700]\n    - [0, 40]\n"))
        line = self.warned(SHORT.replace(PATH, "    - [1, -700]\n    - [1, 40]\n"), "operator.path_nm[1]", "1 nm off its centre")
        self.assertIn("slides off the tip 286.5 nm after the tip meets it", line)
        # through the centre, a stroke still loses it in the end (the truth's noise seeds the turn: 5 pm)
        line = self.warned(SHORT.replace(PATH, "    - [0, -700]\n    - [0, 300]\n"), "operator.path_nm[1]",
                           "the stroke pushes particle 1 through its centre")
        self.assertIn("slides off the tip 603.6 nm after the tip meets it", line)

    def test_objects_that_start_touching(self):
        touching = SHORT.replace("{id: 2, x_nm: 500, y_nm: 300", "{id: 2, x_nm: 100, y_nm: -300")
        self.warned(touching, "objects.particles[1]", "starts 0 nm from objects.particles[0] (id 1), surface to surface: they touch")
        near = SHORT.replace("{id: 2, x_nm: 500, y_nm: 300", "{id: 2, x_nm: 115, y_nm: -300")
        self.warned(near, "objects.particles[1]", "starts 15 nm from objects.particles[0] (id 1), surface to surface: less than "
                                                  "the tip's diameter (20 nm)")
        code, lines = check(SHORT.replace("{id: 2, x_nm: 500, y_nm: 300", "{id: 2, x_nm: 99, y_nm: -300"))
        self.assertEqual(code, 2, lines)   # an overlap is refused, not warned of
        self.assertIn("overlaps objects.particles[0]", lines[0])

    def test_a_long_run(self):
        long = SHORT.replace("duration_s: 0.6", "duration_s: 600")
        line = self.warned(long, "duration_s:", "a run of 600 simulated s takes about")
        self.assertIn("s of wall time, estimated from its size (600000 blocks", line)
        self.quiet(long + "time_mode: realtime\n")   # it takes duration_s by design
        p = launch(e2e_support.write_scene(long), "--estimate")
        e = json.loads(p.stdout)
        self.assertGreater(e["seconds"], 60)
        self.assertEqual(e["blocks"], 600000)

    def test_a_plan_that_outlasts_the_run(self):
        # the ten-site pattern: the planner's estimate (plan_estimate.hpp, a floor) is 18.5 s; it took 28.2 s
        ten = open(e2e_support.scene("pattern_ten.yaml")).read()
        line = self.warned(ten.replace("duration_s: 40", "duration_s: 10"), "duration_s:",
                           "duration_s: 10 s is shorter than the plan needs, at least 18.51 s of simulated time")
        self.assertIn("(10 particles to their sites: 24 strokes over 12874 nm at operator.plan.speed_nm_per_s 2000, 34 local "
                      "scans of operator.plan.scan_s 0.3 s, 17293 nm lifted at operator.plan.travel_speed_nm_per_s 10000)", line)
        self.assertIn("make duration_s at least 19", line)
        self.quiet(ten.replace("duration_s: 40", "duration_s: 19"))
        # slower pushes need longer: the estimate follows the plan's speeds and scans
        slow = ten.replace("duration_s: 40", "duration_s: 20").replace("plan: {tolerance_nm: 25}",
                                                                        "plan: {tolerance_nm: 25, speed_nm_per_s: 1000}")
        self.warned(slow, "duration_s:", "at least 24.95 s")
        e = json.loads(launch(e2e_support.scene("pattern_ten.yaml"), "--estimate").stdout)["plan"]
        self.assertEqual((e["jobs"], e["strokes"], e["scans"]), (10, 24, 34))
        self.assertAlmostEqual(e["seconds"], 18.51, delta=0.01)
        self.assertNotIn("plan", json.loads(launch(e2e_support.scene("default.yaml"), "--estimate").stdout))
        # a rod counts too: at least one end push (120 nm, wire_step_nm) and the 1,575 ms scan that checks it
        rod = json.loads(launch(e2e_support.scene("wire_plan.yaml"), "--estimate").stdout)["plan"]
        self.assertEqual((rod["jobs"], rod["rods"], rod["strokes"]), (0, 1, 1))
        self.assertAlmostEqual(rod["scan_s"], 1.575, delta=0.001)
        self.assertAlmostEqual(rod["seconds"], 1.71, delta=0.01)
        self.warned(open(e2e_support.scene("wire_plan.yaml")).read().replace("duration_s: 60", "duration_s: 1"), "duration_s:",
                    "1 rods to their targets (an end push and a check scan each at least)")

    def test_the_estimate_of_the_default_scene(self):
        p = launch(e2e_support.scene("default.yaml"))
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertRegex(p.stdout, r"default\.yaml: the run's wall time, estimated from its size: about [0-9.]+ s\n")
        e = json.loads(launch(e2e_support.scene("default.yaml"), "--estimate").stdout)
        self.assertLess(e["seconds"], 10)
        self.assertEqual((e["blocks"], e["samples"], e["frame_px"]), (3000, 60000, 75 * 256 * 256))

    def test_no_committed_scene_is_warned_of(self):
        scenes = committed_scenes()
        self.assertGreater(len(scenes), 20)
        for path in scenes:
            p = launch(path, "--strict")
            self.assertEqual(p.returncode, 0, (path, p.stderr))
            self.assertEqual(p.stderr, "", path)


if __name__ == "__main__":
    e2e_support.main()
