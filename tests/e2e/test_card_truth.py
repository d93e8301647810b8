"""The truth does not know the card (issue 47, item 4): one ride scene
(scenes/paper/ride.yaml) run twice, its sample and probe the
same, its card section once the scene's own and once a deliberately wrong
eq. 30 (the cone's half angle 10 deg for 50, the rod's mu and friction far
off, no adhesion). The simulator's truth (SIM_TRUTH, every block, byte for
byte: the tip, the rod, its lift-off) is the same in both runs (the hand
feels no force, so that the card's forces do not move the stylus); the card's
own state (FW_STATE) is not, and run.json's card_sources names where each
of its constants came from."""
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import e2e_support  # noqa: E402
from analysis import afmlog  # noqa: E402

DURATION_S = 5.2
WRONG = """firmware:
  # a card built with a wrong eq. 30: gamma, mu_os, f and the adhesion far off
  tip_half_angle_deg: 10
  adhesion_nN: 0
  wire_mu: 1.5
  wire_friction_nN_per_um: 60
sample:"""


def ride_scene(card_wrong, tag):
    with open(e2e_support.scene("paper/ride.yaml")) as f:
        text = f.read()
    # The hand feels no force (gain 0): the card's forces do not move the
    # stylus, so the card reaches the simulator through nothing but its
    # commands, the same in both runs; the truth's ride-over is its own.
    text = text.replace("operator:\n", "operator:\n  haptic: {force_gain_N_per_nN: 0}\n", 1)
    if card_wrong:
        start, end = text.index("firmware:"), text.index("sample:")
        text = text[:start] + WRONG + text[end + len("sample:"):]
    return e2e_support.write_scene(text, tag)


class CardTruth(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.runs = {}
        for wrong in (False, True):
            out = e2e_support.tmpdir("wrong" if wrong else "right")
            code, _, err, rj = e2e_support.run(ride_scene(wrong, "scene"), out, "--no-verdict", timeout=240)
            if rj is None or rj.get("status") != "ok":
                raise AssertionError(f"the ride run ({'wrong' if wrong else 'right'} card) did not complete: exit {code}: {err[-800:]}")
            log = afmlog.load(os.path.join(out, "bus.lcmlog"), channels={"SIM_TRUTH", "FW_STATE"})
            cls.runs[wrong] = (out, rj, log)
        cls.blocks = int(round(DURATION_S * 1000))

    def test_the_truth_is_the_same_whatever_the_card(self):
        right = e2e_support.encoded_by_seq(self.runs[False][2]["SIM_TRUTH"], self.blocks)
        wrong = e2e_support.encoded_by_seq(self.runs[True][2]["SIM_TRUTH"], self.blocks)
        self.assertGreater(len(right), self.blocks * 0.95)
        self.assertEqual(sorted(right), sorted(wrong))
        differ = [q for q in right if right[q] != wrong[q]]
        self.assertEqual([], differ[:5], f"SIM_TRUTH differs in {len(differ)} blocks, the first {differ[:5]}")

    def test_the_rod_moved_in_the_run(self):
        """The runs cross the rod under a rising load: it is pushed at last
        (the truth's lift-off decided, then its push), so the equality above
        covers a pushing segment."""
        whole = afmlog.whole_by_seq(self.runs[False][2]["SIM_TRUTH"], lambda m: m.objects)
        first, last = whole[min(whole)], whole[max(whole)]
        moved = max(abs(a - b) for a, b in zip(first.wires[0].y_nm, last.wires[0].y_nm))
        self.assertGreater(moved, 5.0, "the rod did not move: no pushing segment to compare")

    def test_the_card_differs(self):
        right = e2e_support.encoded_by_seq(self.runs[False][2]["FW_STATE"], self.blocks)
        wrong = e2e_support.encoded_by_seq(self.runs[True][2]["FW_STATE"], self.blocks)
        self.assertTrue(any(right[q] != wrong.get(q) for q in right), "the wrong card's state is the right one's: the test shows nothing")

    def test_run_json_names_each_constants_source(self):
        for wrong, want in ((False, 50), (True, 10)):
            rj = self.runs[wrong][1]
            self.assertEqual(rj["schema_version"], 3)
            src = {c["field"]: c for c in rj["card_sources"]}
            self.assertEqual(src["tip_half_angle_mdeg"]["key"], "firmware.tip_half_angle_deg")
            self.assertEqual(src["tip_half_angle_mdeg"]["value"], want)
            self.assertEqual(src["tip_half_angle_mdeg"]["source"], "scene card section")
            self.assertEqual(src["board.normal_gain_pn_per_v"]["source"], "nominal")
            for c in rj["card_sources"]:
                self.assertIn(c["source"], ("scene card section", "nominal", "scene configuration"), c)
                self.assertFalse(c["key"].startswith("sample.tip_substrate") or c["key"].startswith("sample.wire"), c)


if __name__ == "__main__":
    e2e_support.main()
