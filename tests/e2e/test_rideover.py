"""./afm bench rideover at its reduced size (issue 47, item 7): the card's
ride-over judgement near eq. 30's dF on 6 lift-off scenes of the paper's rod
(0.9 to 1.1 dF, two cones, two push points). RIDE-OVER is flagged in every
scene where the truth rides over, never in one where it pushes, and the
rod's true movement during flagged blocks stays within 2 nm; the command
prints the table and exits 0 exactly when both goals are met."""
import unittest

import e2e_support

from analysis import rideover  # noqa: E402


class Reduced(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = e2e_support.tmpdir("rideover")
        cls.results = rideover.run_all("reduced", cls.out)

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def test_both_sides_of_df_are_present(self):
        rode = [r for r in self.results if r[5][0]]
        pushed = [r for r in self.results if not r[5][0]]
        self.assertGreaterEqual(len(rode), 2, rideover.report(self.results)[0])
        self.assertGreaterEqual(len(pushed), 2, rideover.report(self.results)[0])

    def test_every_ride_over_flagged_and_no_push(self):
        text = rideover.report(self.results)[0]
        for name, _, _, _, _, (rode, flagged, moved_flagged, total) in self.results:
            if rode:
                self.assertGreater(flagged, 0, f"{name}: the truth rode over, the card never said so\n{text}")
            else:
                self.assertEqual(flagged, 0, f"{name}: the truth pushed the rod {total:.0f} nm\n{text}")
            self.assertLessEqual(moved_flagged, rideover.MOVE_GOAL_NM, f"{name}\n{text}")

    def test_the_goals_and_the_verdict(self):
        recall, nr, nc, worst, ok = rideover.goals(self.results)
        text, ok2 = rideover.report(self.results)
        self.assertTrue(ok, text)
        self.assertEqual(ok, ok2)
        self.assertIn("rideover: verdict: pass", text)
        self.assertEqual(nr, nc, text)
        self.assertLessEqual(worst, rideover.MOVE_GOAL_NM, text)

    def test_a_judge_that_flags_every_scene_fails(self):
        # the verdict can fail: a card flagging the pushes too misses goal 2
        bad = [(n, g, q, x, dF, (rode, 5, 0.0 if rode else total, total))
               for n, g, q, x, dF, (rode, _, _, total) in self.results]
        self.assertFalse(rideover.goals(bad)[4])
        self.assertIn("MISSED", rideover.report(bad)[0])
        none = [(n, g, q, x, dF, (rode, 0, 0.0, total)) for n, g, q, x, dF, (rode, _, _, total) in self.results]
        self.assertFalse(rideover.goals(none)[4])


if __name__ == "__main__":
    e2e_support.main()
