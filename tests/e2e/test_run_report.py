"""report.html in every run folder (issue 37): one self-contained page with
the verdict, the contact sheet, the force, apex and objects against the
truth, the fidelity check, the card's configuration, the planner's or hand's
account and the costs; opened in a real browser (Debian's chromium,
headless), whose screenshot is kept in the test's output."""
import os
import re
import shutil
import subprocess
import sys
import unittest

import benchtest

PY = sys.executable


class RunReport(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = os.path.join(benchtest.tmpdir("report"), "run")
        cls.code, _, cls.err, cls.rj = benchtest.run(benchtest.scene("short.yaml"), cls.out)
        p = subprocess.run([PY, "-m", "analysis.run_report", cls.out], capture_output=True, text=True, timeout=300)
        cls.gen = p
        with open(os.path.join(cls.out, "report.html")) as f:
            cls.html = f.read()

    def test_the_page_is_written_and_self_contained(self):
        self.assertEqual(self.code, 0, self.err)
        self.assertEqual(self.gen.returncode, 0, self.gen.stderr)
        self.assertIn("report in", self.gen.stdout)
        srcs = re.findall(r'src="([^"]+)"', self.html)
        self.assertGreaterEqual(len(srcs), 5, "contact sheet, force, apex, objects, fidelity image")
        self.assertTrue(all(s.startswith("data:") for s in srcs), [s[:40] for s in srcs if not s.startswith("data:")])
        self.assertNotIn("http://", self.html)
        self.assertNotIn("https://", self.html)

    def test_it_says_the_verdict_and_each_part(self):
        self.assertIn("Verdict: pass", self.html)
        for part in ("Contact sheet", "Force of the sample on the tip", "The apex", "Objects (the", "Fidelity",
                     "The card's configuration", "Costs", "fw_node CPU (s)"):
            self.assertIn(part, self.html)

    def test_a_failed_verdict_is_listed_with_its_figures(self):
        out = os.path.join(benchtest.tmpdir("report-fail"), "run")
        text = open(benchtest.scene("interlock.yaml")).read().replace("expect: [interlock]", "")
        code, _, err, _ = benchtest.run(benchtest.write_scene(text, "il"), out)
        self.assertEqual(code, 4, err)
        p = subprocess.run([PY, "-m", "analysis.run_report", out], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(os.path.join(out, "report.html")) as f:
            page = f.read()
        self.assertIn("Verdict: FAILED", page)
        self.assertIn("<b>interlock</b>: the card&#x27;s force interlock tripped", page)

    def test_not_a_run_folder_is_named(self):
        d = benchtest.tmpdir("notarun")
        p = subprocess.run([PY, "-m", "analysis.run_report", d], capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{d}: no run.json", p.stderr)

    def test_a_real_browser_renders_it(self):
        chromium = shutil.which("chromium")
        self.assertIsNotNone(chromium, "chromium is installed by ./afm setup")
        shot_dir = os.path.join(benchtest.BUILD, "test-output", "run_report")
        os.makedirs(shot_dir, exist_ok=True)
        shot = os.path.join(shot_dir, "report.png")
        if os.path.exists(shot):
            os.remove(shot)
        p = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}", "--window-size=1280,800",
                            "file://" + os.path.join(self.out, "report.html")], capture_output=True, text=True, timeout=120)
        self.assertTrue(os.path.exists(shot), p.stderr[-500:])
        from PIL import Image
        im = Image.open(shot).convert("L")
        self.assertEqual(im.size, (1280, 800))
        lo, hi = im.getextrema()
        self.assertLess(lo, 100, "the page shows text, not a blank")
        print(f"screenshot: {shot}")


if __name__ == "__main__":
    benchtest.main()
