"""A run that tells the truth about itself (issue 37, verdicts): a run that
completes but fails one of its own checks says so in its last line, records
verdict {pass, failed, expected, met} in run.json and exits 4 (--no-verdict:
0). A scene's expect: lists the checks it fails on purpose. Two bodies in one
place are refused before anything starts."""
import os
import unittest

import e2e_support

SHORT = open(e2e_support.scene("short.yaml")).read()
INTERLOCK = open(e2e_support.scene("interlock.yaml")).read()


def last_line(text):
    lines = [l for l in text.splitlines() if l.strip()]
    return lines[-1] if lines else ""


class Verdicts(unittest.TestCase):
    def run_text(self, text, tag, *extra):
        path = e2e_support.write_scene(text, tag)
        out = os.path.join(os.path.dirname(path), "out")
        code, so, se, rj = e2e_support.run(path, out, *extra)
        return code, so, se, rj

    def test_a_run_that_passes_its_checks_says_so_and_exits_0(self):
        code, so, se, rj = self.run_text(SHORT, "pass")
        self.assertEqual(code, 0, se)
        self.assertEqual(last_line(so), "run: verdict: pass")
        self.assertEqual(rj["verdict"], {"pass": True, "failed": [], "expected": [], "met": []})

    def test_a_tripped_interlock_fails_the_run_with_exit_4(self):
        # the interlock scene without its expect: the cut at 120 nN trips it
        text = "\n".join(l for l in INTERLOCK.splitlines() if not l.startswith("expect:"))
        code, so, se, rj = self.run_text(text, "interlock")
        self.assertEqual(code, 4, so + se)
        self.assertEqual(rj["status"], "ok")   # it completed; its verdict is what failed
        checks = [f["check"] for f in rj["verdict"]["failed"]]
        self.assertIn("interlock", checks)
        self.assertTrue(last_line(so).startswith("run: verdict: FAILED: "), so)
        self.assertIn("interlock (the card's force interlock tripped", last_line(so))

    def test_no_verdict_exits_0_and_still_records_it(self):
        text = "\n".join(l for l in INTERLOCK.splitlines() if not l.startswith("expect:"))
        code, so, se, rj = self.run_text(text, "noverdict", "--no-verdict")
        self.assertEqual(code, 0, se)
        self.assertFalse(rj["verdict"]["pass"])
        self.assertTrue(last_line(so).startswith("run: verdict: FAILED"))

    def test_an_expected_failure_passes_and_an_unmet_expectation_fails(self):
        code, so, se, rj = self.run_text(INTERLOCK, "expected")   # the committed scene expects its interlock
        self.assertEqual(code, 0, so + se)
        self.assertIn("interlock", rj["verdict"]["met"])
        self.assertIn("failed as the scene expects: interlock", last_line(so))
        code, so, se, rj = self.run_text(SHORT + "\nexpect: [interlock]\n", "unmet")
        self.assertEqual(code, 4, so + se)
        self.assertEqual([f["check"] for f in rj["verdict"]["failed"]], ["expect"])
        self.assertIn("expects interlock to fail", rj["verdict"]["failed"][0]["detail"])

    def test_a_push_along_the_levers_axis_is_unobservable_and_fails(self):
        # frame C is frame A (scan angle 270): the lever lies along x; a push
        # along x moves the particle where the card cannot see F_x
        text = SHORT.replace("    - [0, -700]\n    - [0, -90]\n    - [300, -90]\n", "    - [-700, -300]\n    - [300, -300]\n")
        self.assertNotEqual(text, SHORT)
        code, so, se, rj = self.run_text(text, "axis")
        self.assertEqual(code, 4, so + se)
        self.assertIn("unobservable_push", [f["check"] for f in rj["verdict"]["failed"]])
        self.assertGreater(rj["fw"]["unobservable_push_blocks"], 0)


class TwoBodiesInOnePlace(unittest.TestCase):
    def refused(self, text, key, words):
        path = e2e_support.write_scene(text, "overlap")
        out = os.path.join(os.path.dirname(path), "out")
        code, _, se, _ = e2e_support.run(path, out)
        lines = [l for l in se.splitlines() if l.strip()]
        self.assertEqual(code, 2, se)
        self.assertEqual(len(lines), 1, se)
        self.assertIn(key, lines[0])
        self.assertIn(words, lines[0])
        self.assertFalse(os.path.exists(out))

    def test_coincident_particles_are_refused(self):
        self.refused(SHORT.replace("{id: 2, x_nm: 500, y_nm: 300", "{id: 2, x_nm: 0, y_nm: -300"), "objects.particles[1]",
                     "overlaps objects.particles[0] (id 1): centres 0.0 nm apart")

    def test_overlapping_particles_are_refused_and_touching_ones_are_not(self):
        self.refused(SHORT.replace("{id: 2, x_nm: 500, y_nm: 300", "{id: 2, x_nm: 99, y_nm: -300"), "objects.particles[1]", "overlaps")
        path = e2e_support.write_scene(SHORT.replace("{id: 2, x_nm: 500, y_nm: 300", "{id: 2, x_nm: 100, y_nm: -300"), "touching")
        code, _, se, _ = e2e_support.run(path, os.path.join(os.path.dirname(path), "out"), "--check")
        self.assertEqual(code, 0, se)

    def test_a_particle_on_a_wire_and_crossing_wires_are_refused(self):
        wire = SHORT.replace("objects:\n", "objects:\n  wires:\n    - {id: 7, x0_nm: -600, y0_nm: -300, x1_nm: 600, y1_nm: -300, diameter_nm: 100}\n")
        self.refused(wire, "objects.particles[0]", "lies on objects.wires[0] (id 7)")
        cross = SHORT.replace("objects:\n", "objects:\n  wires:\n    - {id: 7, x0_nm: -600, y0_nm: 600, x1_nm: 600, y1_nm: 600, diameter_nm: 100}\n"
                                            "    - {id: 8, x0_nm: 0, y0_nm: 0, x1_nm: 0, y1_nm: 900, diameter_nm: 100}\n")
        self.refused(cross, "objects.wires[1]", "touches or crosses objects.wires[0] (id 7)")


if __name__ == "__main__":
    e2e_support.main()
