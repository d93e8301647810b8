"""./afm paper at its reduced size (issues 13, 47): every experiment runs on
the bench, is analysed from the runs' own data, and its figures and the
paper's models are checked here against the truth or the closed form within
the tolerance of analysis/paper/tolerances.yaml (recomputed from paper.json,
not taken from its "ok"); every row names an entry of that file and every
entry is used; a row measured from a run whose own verdict failed is never
ok and names the check, and only the runs KNOWN_VERDICT_FAILURES lists may
fail; the command exits 1 exactly when a row is not ok. The report is
written whole (report.html with its figures inline, report.md, paper.json);
bad arguments are named; no raw value in its text (analysis/units.py's
raw_values). The judge itself: tests/py/test_paper_tolerances.py."""
import json
import math
import os
import subprocess
import sys
import unittest

import e2e_support

PY = sys.executable
ENV = dict(os.environ)

from analysis.paper import cli, common  # noqa: E402

# The runs whose own verdict fails today at the reduced size, each with why
# (their rows say "run failed: CHECK"; a run not listed here that fails its
# verdict fails this test).
KNOWN_VERDICT_FAILURES = {
    ("rod", "l_0.45L"): "fidelity: the display ends about 30 nm off the rod pushed near its middle",
    ("drift", "local_scans"): "fidelity: the sample drifts on after the last local scan",
    ("drift", "far"): "fidelity: the sample drifts on after the wider scan's fix",
    ("ablation", "every__off"): "assembly, fidelity: every source on, the compensation off: the planner's pushes miss",
    ("ablation", "every__all_on"): "assembly, fidelity, unobservable_push: every source on, all compensation on: the "
                                   "planner finishes 3 of 10 sites in 40 s (docs/card.md, The ablation)",
}


def value(r):
    """A row's value: the model's on a model row, else the bench's."""
    return r["model"] if r["model"] is not None else r["bench"]


def paper(*args, timeout=480):
    p = subprocess.run([PY, "-m", "analysis.paper", *args], capture_output=True, text=True, timeout=e2e_support.limit(timeout),
                       env=ENV, cwd=e2e_support.SRC)
    return p.returncode, p.stdout, p.stderr


class Reduced(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = e2e_support.tmpdir("paper")
        cls.code, cls.so, cls.se = paper("--size", "reduced", "--out", cls.out)
        with open(os.path.join(cls.out, "paper.json")) as f:
            cls.data = json.load(f)

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def rows(self, exp):
        return {r["quantity"]: r for r in self.data["experiments"][exp]["rows"]}

    def row(self, exp, prefix):
        hits = [r for q, r in self.rows(exp).items() if q.startswith(prefix)]
        self.assertEqual(len(hits), 1, f"{exp}: one row starting {prefix!r}")
        return hits[0]

    def all_rows(self):
        return [(name, r) for name, exp in self.data["experiments"].items() for r in exp["rows"]]

    def test_every_experiment_ran_and_the_command_exits_1_exactly_when_a_row_is_not_ok(self):
        self.assertIn(self.code, (0, 1), self.so[-3000:] + self.se[-3000:])
        self.assertEqual(self.code, 1 if any(not r["ok"] for _, r in self.all_rows()) else 0, self.so[-3000:])
        self.assertEqual(sorted(self.data["experiments"]), sorted(e.NAME for e in cli.EXPERIMENTS))
        self.assertIn("experiment quantity", self.so)
        self.assertIn("the paper's model against the truth", self.so)

    def test_every_judged_figure_within_its_tolerance_recomputed(self):
        for name, r in self.all_rows():
            if not r["ok"] and r["verdict"].startswith("run failed: ") and all(
                    (name, run) in KNOWN_VERDICT_FAILURES for run in r["verdict"].rsplit("(", 1)[-1].rstrip(")").split(", ")):
                continue   # a row of known failed runs (one or more): the test above holds it to "run failed", never ok
            self.assertIsNotNone(value(r), f"{name}: {r['quantity']}: nothing measured ({self.data['experiments'][name]['notes']})")
            if r["tolerance"] is None:
                continue
            if r["truth"] is None:
                self.assertLessEqual(abs(value(r)), r["tolerance"], f"{name}: {r['quantity']}")
                continue
            e = value(r) - r["truth"]
            if r["relative"]:
                e /= r["truth"]
            self.assertLessEqual(abs(e), r["tolerance"], f"{name}: {r['quantity']}: {r}")

    def test_every_row_has_its_entry_in_the_tolerance_file_and_every_entry_is_used(self):
        entries = common.tolerances()
        used = set()
        for name, r in self.all_rows():
            self.assertIn(r["key"], entries, f"{name}: {r['quantity']}")
            self.assertEqual(r["kind"], entries[r["key"]]["kind"], r)
            used.add(r["key"])
        self.assertEqual(set(entries) - used, set(), "entries no row used at the reduced size")

    def test_a_row_of_a_run_whose_verdict_failed_says_so_and_is_never_ok(self):
        failed = {}
        for name, exp in self.data["experiments"].items():
            for run in os.listdir(os.path.join(self.out, name, "runs")):
                rj = os.path.join(self.out, name, "runs", run, "run.json")
                if os.path.isfile(rj):
                    with open(rj) as f:
                        v = json.load(f).get("verdict") or {}
                    if not v.get("pass", True):
                        failed[(name, run)] = [c["check"] for c in v["failed"]]
        self.assertEqual(set(failed) - set(KNOWN_VERDICT_FAILURES), set(), failed)
        for name, r in self.all_rows():
            mine = [run for (e, run) in failed if e == name and (not r["runs"] or run in r["runs"])]
            if mine:
                self.assertFalse(r["ok"], r)
                self.assertTrue(r["verdict"].startswith("run failed: "), r)
                for run in mine:
                    self.assertIn(run, r["verdict"])
            else:
                self.assertFalse(r["verdict"].startswith("run failed"), r)
        ride = self.row("squeeze", "ride-over, gamma 20 deg, load 1.1 dF")
        if ("squeeze", "ride_20_high") in failed:
            self.assertEqual(ride["verdict"], "run failed: fidelity (ride_20_high)")

    def test_the_models_against_the_truth(self):
        # eq. 30's dF against the truth's own lift-off (SIM_TRUTH, the load ramp),
        # the rod's static point and least push against the numeric rod, the
        # particle threshold, the calibrations: each a model row with its truth
        models = [r for _, r in self.all_rows() if r["model"] is not None]
        keys = {r["key"] for r in models}
        for k in ("squeeze.model_liftoff", "rod.model_static_point", "rod.model_least_push",
                  "squeeze.model_particle_threshold", "tilted.mu", "tilted.lateral", "lines.cn", "trench.model_seat",
                  "flex.model_bow"):
            self.assertIn(k, keys)
        for r in models:
            self.assertIsNotNone(r["truth"], r)
            self.assertIn(r["kind"], ("model error", "unit check"), r)
        for r in (r for r in models if r["key"] == "squeeze.model_liftoff"):
            self.assertIn("SIM_TRUTH", r["note"])
            self.assertEqual(r["kind"], "unit check", "the simulator still lifts the tip by eq. 27-28's balance")

    def test_tilted_glass_gives_mu_and_the_lateral_gain_of_the_closed_form(self):
        # physics.md 2: the paper's r_u 0.07, r_d 0.02 give mu 0.0865 and 37.9 nN/V.
        self.assertAlmostEqual(value(self.row("tilted", "mu")), 0.0865, delta=0.0865 * 0.05)
        self.assertAlmostEqual(value(self.row("tilted", "k_theta")), 37.9, delta=37.9 * 0.03)

    def test_lines_find_the_levers_true_cn_not_the_estimate_and_the_calibration_mends_the_apex(self):
        cn = self.row("lines", "C_n")
        self.assertAlmostEqual(value(cn), cn["truth"], delta=0.03 * cn["truth"])
        self.assertGreater(abs(value(cn) - 23.1), 2.0, "the estimate, not a measurement")
        # read from the fresh scans' lines against the card's apex, not from SIM_TRUTH
        est = self.row("lines", "apex error on a cut, C_n estimated")
        cal = self.row("lines", "apex error on a cut, C_n calibrated")
        self.assertGreater(est["bench"], 5 * cal["bench"])
        self.assertAlmostEqual(est["bench"], est["truth"], delta=3.0)
        inc = os.path.join(self.out, "lines", "calibrated_lever.yaml")
        with open(inc) as f:
            self.assertIn("disp_n_nm_per_V", f.read())

    def test_lines_at_scan_angle_0_shift_along_plus_y_a_as_eq_2_turns_the_lever(self):
        # fig. 8's frame: at 0 deg frame A holds frame C a quarter turn on
        # (eq. 2, the frames overlapping at 270), so a deeper line lies
        # further along +y_A; the lines sit where the 270 deg ones, turned, do.
        shift = self.row("lines", "line shift per 500 nm of dz at scan angle 0, along +y_A")
        self.assertGreater(shift["truth"], 100.0)
        self.assertGreater(shift["bench"], 100.0, "the shift's sign is the frame convention's")
        self.assertAlmostEqual(shift["bench"], shift["truth"], delta=0.03 * shift["truth"])
        cn = self.row("lines", "scan angle 0: C_n")
        self.assertAlmostEqual(value(cn), cn["truth"], delta=0.01 * cn["truth"])
        self.assertLess(self.row("lines", "lines at scan angle 0 against the 270 deg lines")["bench"], 3.0)
        self.assertTrue(any("quarter turn" in n for n in self.data["experiments"]["lines"]["notes"]))

    def test_flex_the_long_wire_bends_where_the_cards_rod_cannot(self):
        # fig. 11: the bow in the fresh scan grows with the aspect ratio (the
        # bending length is about 2.7 um); the display's rod misses it.
        bows = [self.row("flex", f"bow of the wire in the fresh scan, ratio {r}")["bench"] for r in (13, 25, 50)]
        self.assertLess(bows[0], 5.0)
        self.assertLess(bows[0], bows[1])
        self.assertGreater(bows[2], 100.0)
        err50 = self.row("flex", "display's error along the wire, ratio 50")
        self.assertGreater(err50["bench"], 50.0, "the rigid display misses the bend")
        self.assertAlmostEqual(err50["bench"], err50["truth"], delta=err50["tolerance"])
        figs = [f for _, f in self.data["experiments"]["flex"]["figures"]]
        for r in (13, 25, 50):
            self.assertIn(f"flex_{r}.png", figs)
            self.assertTrue(os.path.exists(os.path.join(self.out, "flex", f"flex_{r}.png")))

    def test_rod_static_point_and_push_follow_the_closed_form(self):
        L = 1300.0
        from analysis.paper import exp_rod
        s_end, k_end = exp_rod.closed_form(0.03 * L, L)
        # the static point from the rod's centre (the scans need no length)
        self.assertAlmostEqual(self.row("rod", "static point at an end push")["bench"], s_end - L / 2, delta=30)
        # the card's model against the simulator's own numeric rod, not eq. 20, at every push point
        static = [r for r in self.data["experiments"]["rod"]["rows"] if r["key"] == "rod.model_static_point"]
        self.assertEqual(len(static), 4)
        for r in static:
            self.assertLess(abs(r["model"] - r["truth"]), 0.02 * L, r)
            self.assertEqual(r["kind"], "model error")
        self.assertAlmostEqual(self.row("rod", "push that moves the rod at l = 0.03")["bench"], k_end * 26.0, delta=0.1 * 26.0)
        self.assertLess(self.row("rod", "firmware fw_wire against the closed form: static")["bench"], 2.0)

    def test_squeeze_figs_16_17_are_measured_ride_over_loads_within_10_percent(self):
        # one point per figure at reduced size: the load ramp's dF against
        # eq. 30 (the firmware's solver), and the ramp bracketed it
        rows = [r for r in self.data["experiments"]["squeeze"]["rows"] if r["quantity"].startswith("fig. 1") and ": dF," in r["quantity"]]
        self.assertEqual(sorted(r["quantity"][:7] for r in rows), ["fig. 16", "fig. 17"])
        # the card's push judgement beside each: its first contact's load against the measured dF, within 10 %
        judged = [r for r in self.data["experiments"]["squeeze"]["rows"] if "the card's push judgement" in r["quantity"]]
        self.assertEqual(len(judged), 2, judged)
        for r in judged:
            self.assertIsNotNone(r["bench"], r)
            self.assertLessEqual(abs(r["bench"]), r["tolerance"], r)
        for r in rows:
            self.assertGreater(r["truth"], 0.5, r)
            self.assertLess(abs(r["bench"] - r["truth"]), 0.1 * r["truth"], r)
            self.assertIn("first push at stroke", r["note"])

    def test_squeeze_push_follows_eq_29_and_the_rod_stays_past_psi_max(self):
        # eq. 29's horizontal part at an end push, written out here: k f L /
        # (1 - k mu tan gamma), f L = 26 nN, wire mu 0.5, the last cone.
        import math
        from analysis.paper import exp_rod, exp_squeeze
        g = exp_squeeze.GAMMAS["reduced"][-1]
        _, k = exp_rod.closed_form(exp_squeeze.END_Q * 1300.0, 1300.0)
        want = k * 26.0 / (1 - k * 0.5 * math.tan(math.radians(g)))
        self.assertAlmostEqual(self.row("squeeze", "push at an end")["bench"], want, delta=0.1 * want)
        self.assertGreater(self.row("squeeze", "push at an end")["bench"], 1.15 * k * 26.0, "the down force must show")
        for name in ("squeeze_pressed", "squeeze_light"):
            self.assertLess(self.row("squeeze", f"{name}: the rod's move")["bench"], 5.0)
            self.assertEqual(self.row("squeeze", f"{name}: the tip rode over")["bench"], 1.0)
        self.assertEqual(self.row("squeeze", "squeeze_pressed: the card flagged SQUEEZE")["bench"], 1.0)
        self.assertEqual(self.row("squeeze", "squeeze_light: the card flagged SQUEEZE")["bench"], 0.0)
        # the particle: F_th(0) mu_ps tan(gamma) / (1 - mu_ps tan gamma) added, F_th(0) = 0.5 x 5 nN
        t = 0.5 * math.tan(math.radians(exp_squeeze.PARTICLE_GAMMA))
        self.assertAlmostEqual(self.row("squeeze", "particle: what the down force adds")["bench"], 2.5 * t / (1 - t),
                               delta=0.1 * 2.5 * t / (1 - t))

    def test_a_hand_on_the_device_feels_the_ride_over_and_the_push(self):
        # the stylus's z axis sets the load; what the device renders tells a ride-over from a push
        for frac in (0.8, 1.25):
            self.assertEqual(self.row("squeeze", f"by hand, load {frac} x eq. 30's dF: the hand felt")["bench"], 1.0)
            load = self.row("squeeze", f"by hand, load {frac} x dF: the load the stylus")
            self.assertAlmostEqual(load["bench"], load["truth"], delta=0.08 * load["truth"])

    def test_trench_holds_the_rod_and_the_cards_model_knows_it(self):
        # fig. 18: cut, then pushed in by a zigzag; the rod sinks into the
        # groove (its top below the surface in the fresh scan, on the
        # trench's path); the card's rod stays with the simulator's because
        # it feels the trench it cut and settles into it too.
        top = self.row("trench", "the rod's top against the substrate")
        self.assertLess(top["bench"], -100.0, "the rod's top lies well below the surface")
        self.assertAlmostEqual(top["bench"], top["truth"], delta=10.0)
        self.assertEqual(self.row("trench", "the rod lies below the substrate")["bench"], 1.0)
        self.assertLess(self.row("trench", "rod's axis from the trench's path")["bench"], 6.0)
        self.assertLess(abs(self.row("trench", "the card's rod top against the fresh scan's")["bench"]), 10.0)
        self.assertGreater(self.row("trench", "end pushes")["bench"], 4, "a zigzag, not one push")
        self.assertLess(self.row("trench", "the card's rod against the simulator's, at the end")["bench"], 10.0)
        self.assertAlmostEqual(self.row("trench", "trench width")["bench"], 2 * 350 * math.tan(math.radians(20)), delta=20)

    def test_landmark_drift_and_pattern_hold_their_models(self):
        self.assertLess(abs(self.row("landmark", "re-registered offset x")["bench"] - 250), 5)
        self.assertLess(self.row("drift", "registration error while pushing")["bench"], 25)
        self.assertGreater(self.row("drift", "registration error at the end, without")["bench"], 200)
        self.assertEqual(self.row("drift", "far: the 400 nm scan missed")["bench"], 1.0)
        self.assertLess(self.row("drift", "far: registration error after")["bench"], 25)
        self.assertGreater(self.row("drift", "far, the card's default 200 nm limit")["bench"], 200)
        pat = self.row("pattern", "sites filled")
        self.assertEqual(pat["bench"], 10)

    def test_ablation_judges_the_cut_of_the_first_push_with_every_source_on(self):
        # issue 48 item 3, reduced: every source at the lab levels, the card's
        # compensation off and all on, on the planner's ten sites; the card's
        # side from the run's outputs, the truth beside it and labelled so.
        # The compensation cuts the first push's error; whether by the
        # issue's 10x is the cut row's verdict (its tolerance 0.1), which
        # says ok only when the ratio is within it and both runs passed.
        off = self.row("ablation", "every source, compensation off: first push's error")
        on = self.row("ablation", "every source, all compensation on: first push's error")
        for r in (off, on):
            self.assertIsNotNone(r["bench"], r)
            self.assertIsNotNone(r["truth"], r)
            self.assertIn("SIM_TRUTH", r["note"])
        self.assertGreater(off["bench"], on["bench"], (off, on))
        cut = self.row("ablation", "every source: first push's error, all compensation on / off")
        self.assertEqual(cut["tolerance"], 0.1)
        self.assertAlmostEqual(cut["bench"], on["bench"] / off["bench"], places=6)
        self.assertEqual(cut["ok"], cut["bench"] <= 0.1 and not cut.get("run_failed"), cut)
        for case in ("every source, compensation off", "every source, all compensation on"):
            for what in ("pushes per site", "time per site", "final placement"):
                self.assertIsNotNone(self.row("ablation", f"{case}: {what}")["bench"], f"{case}: {what}")
        notes = " ".join(self.data["experiments"]["ablation"]["notes"])
        for missing in ("object_forces", "levelling"):
            self.assertIn(missing, notes, "a source or part no switch turns on is named")
        self.assertTrue(os.path.exists(os.path.join(self.out, "ablation", "ablation.png")))

    def test_report_is_whole_with_figures_inline(self):
        with open(os.path.join(self.out, "report.html")) as f:
            html = f.read()
        n_figs = sum(len(e["figures"]) for e in self.data["experiments"].values())
        self.assertGreaterEqual(n_figs, 10)
        self.assertEqual(html.count("data:image/png;base64,"), n_figs)
        self.assertTrue(os.path.exists(os.path.join(self.out, "report.md")))

    def test_the_report_shows_no_raw_value(self):
        # every number of the rows, notes and captions through analysis/units.py:
        # at most 4 significant digits with its unit, no True/False/None, no code name
        from analysis import units
        with open(os.path.join(self.out, "report.html")) as f:
            page = units.page_text(f.read())
        with open(os.path.join(self.out, "report.md")) as f:
            md = f.read()
        self.assertGreater(len(page), 5000)
        self.assertEqual(units.raw_values(page), [], "report.html")
        self.assertEqual(units.raw_values(md), [], "report.md")


class Judge(unittest.TestCase):
    def test_bad_arguments_are_named(self):
        code, so, se = paper("--only", "nonsense")
        self.assertEqual(code, 2)
        self.assertIn("nonsense", se)
        self.assertIn("tilted", se)


class SeededTruth(unittest.TestCase):
    """./afm paper --truth seeded: the calibrations' truth is drawn from the
    seed and told only to the simulator; the bench recovers it within 1 %
    and prints the seed."""

    def test_a_seeded_lever_and_surface_are_recovered_within_1_percent(self):
        out = e2e_support.tmpdir("paper-seeded")
        self.addCleanup(e2e_support.cleanup, out)
        p = subprocess.run([PY, "-m", "analysis.paper", "--only", "tilted", "--size", "reduced", "--truth", "seeded",
                            "--seed", "3", "--out", out], capture_output=True, text=True, timeout=e2e_support.limit(300), env=ENV,
                           cwd=e2e_support.SRC)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("seeded truth, seed 3", p.stderr)
        with open(os.path.join(out, "paper.json")) as f:
            rows = {r["key"]: r for r in json.load(f)["experiments"]["tilted"]["rows"]}
        mu, lat = rows["tilted.mu"], rows["tilted.lateral"]
        self.assertNotAlmostEqual(mu["truth"], 0.0865, delta=0.005)   # not the paper's
        self.assertNotAlmostEqual(lat["truth"], 37.9, delta=1.0)
        for r in (mu, lat):
            self.assertLess(abs(r["model"] - r["truth"]) / r["truth"], 0.01, r)
        # the card was told the paper's values, not the drawn ones
        with open(os.path.join(out, "tilted", "runs", "load_5nN", "run.json")) as f:
            card = json.load(f)["card"]
        self.assertAlmostEqual(card["lateral_gain_pn_per_v"] * 1e-3, 37.9, delta=0.05)


if __name__ == "__main__":
    e2e_support.main()
