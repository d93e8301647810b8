"""report.html in every run folder (issue 37): one self-contained page with
the verdict, the contact sheet, the force, apex and objects against the
truth, the fidelity check, the card's configuration, the planner's or hand's
account and the costs; opened in a real browser (Debian's chromium,
headless), whose screenshot is kept in the test's output. The video is
H.264 (ffprobe) with its index first, or run.json says the fallback ran and
why; it plays in Chromium (no MEDIA_ERR, its time advances); at 1280 x 800
every text on the page is 12 px or more, the frames' labels included at the
size the page shows them. The run's, the sweep's and the paper's pages
(the sweep's and the paper's from small fixtures: tests/py/test_units.py's)
at 1280 px: no element wider than the page, no raw value in the text a
person reads (analysis/units.py raw_values), the video's controls below the
picture, each figure's SVG beside its PNG and linked."""
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import time
import unittest

import e2e_support

PY = sys.executable
CHROMIUM = shutil.which("chromium")
DRIVER = shutil.which("chromedriver")
SHOT_DIR = os.path.join(e2e_support.BUILD, "test-output", "run_report")


def browser():
    """Debian's chromium under Selenium, 1280 x 800 at 100 %."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,800", "--force-device-scale-factor=1",
              "--autoplay-policy=no-user-gesture-required", "--no-first-run", "--disable-background-networking"):
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(DRIVER), options=opts)


def top_level_boxes(path):
    """The MP4 file's top-level box types, in order."""
    out = []
    with open(path, "rb") as f:
        while True:
            head = f.read(8)
            if len(head) < 8:
                return out
            size, kind = struct.unpack(">I4s", head)
            if size == 1:
                size = struct.unpack(">Q", f.read(8))[0] - 8
            out.append(kind.decode("latin-1"))
            if size < 8:
                return out
            f.seek(size - 8, os.SEEK_CUR)


# Every element's own text, its computed font size; every image with text
# (data-label-cap-px), the capitals' height as shown.
SIZES_JS = """
const small = [];
for (const el of document.querySelectorAll('body *')) {
  const own = [...el.childNodes].some(n => n.nodeType === 3 && n.textContent.trim());
  if (own) { const fs = parseFloat(getComputedStyle(el).fontSize); if (fs < 12) small.push(el.tagName + ' ' + fs + 'px: ' + el.textContent.trim().slice(0, 40)); }
}
const images = [];
for (const el of document.querySelectorAll('[data-label-cap-px]')) {
  const natural = el.videoWidth || el.naturalWidth || parseFloat(el.dataset.naturalPx);
  const shown = el.getBoundingClientRect().width;
  images.push([el.tagName, parseFloat(el.dataset.labelCapPx) * shown / natural, natural, shown]);
}
return [small, images];
"""


class RunReport(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = os.path.join(e2e_support.tmpdir("report"), "run")
        cls.code, _, cls.err, cls.rj = e2e_support.run(e2e_support.scene("short.yaml"), cls.out)
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
                     "The card's configuration", "Costs", "fw_node CPU time", "The card minus the truth"):
            self.assertIn(part, self.html)

    def test_a_failed_verdict_is_listed_with_its_figures(self):
        out = os.path.join(e2e_support.tmpdir("report-fail"), "run")
        text = open(e2e_support.scene("interlock.yaml")).read().replace("expect: [interlock]", "")
        code, _, err, _ = e2e_support.run(e2e_support.write_scene(text, "il"), out)
        self.assertEqual(code, 4, err)
        p = subprocess.run([PY, "-m", "analysis.run_report", out], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(os.path.join(out, "report.html")) as f:
            page = f.read()
        self.assertIn("Verdict: FAILED", page)
        self.assertIn("<b>interlock</b>: the card&#x27;s force interlock tripped", page)

    def test_not_a_run_folder_is_named(self):
        d = e2e_support.tmpdir("notarun")
        p = subprocess.run([PY, "-m", "analysis.run_report", d], capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{d}: no run.json", p.stderr)

    def test_a_real_browser_renders_it(self):
        chromium = shutil.which("chromium")
        self.assertIsNotNone(chromium, "chromium is installed by ./afm setup")
        shot_dir = os.path.join(e2e_support.BUILD, "test-output", "run_report")
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


    def test_the_video_is_h264_or_the_fallback_is_recorded(self):
        v = self.rj["renderer"]["video"]
        path = os.path.join(self.out, v["file"])
        print(f"video: {json.dumps(v)}")
        if v["codec"] == "h264":
            self.assertIsNone(v["fallback_why"])
            p = subprocess.run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-show_entries", "stream=codec_name,pix_fmt,nb_frames",
                                "-of", "json", path], capture_output=True, text=True, timeout=60)
            self.assertEqual(p.returncode, 0, p.stderr)
            st = json.loads(p.stdout)["streams"][0]
            self.assertEqual((st["codec_name"], st["pix_fmt"]), ("h264", "yuv420p"))
            self.assertEqual(int(st["nb_frames"]), self.rj["frames"])
            boxes = top_level_boxes(path)
            self.assertLess(boxes.index("moov"), boxes.index("mdat"), f"no faststart: {boxes}")
        else:   # no ffmpeg with libx264 here: OpenCV's writer, and why
            self.assertEqual(v["codec"], "mp4v")
            self.assertTrue(v["fallback_why"])
            self.assertIn("do not play", self.html)

    def test_the_video_plays_in_chromium(self):
        self.assertTrue(CHROMIUM and DRIVER, "chromium and chromium-driver are installed by ./afm setup")
        d = browser()
        try:
            d.get("file://" + os.path.join(self.out, "report.html"))
            deadline = time.time() + 30
            while True:
                state = d.execute_script("const v = document.getElementById('run-video');"
                                         "return [v.readyState, v.error ? v.error.code : null, v.duration];")
                if state[0] >= 2 or state[1] or time.time() > deadline:
                    break
                time.sleep(0.2)
            print(f"video in Chromium: readyState {state[0]}, error {state[1]}, duration {state[2]} s")
            if self.rj["renderer"]["video"]["codec"] != "h264":   # the fallback does not play, as the page says
                self.assertEqual(state[1], 4, "MEDIA_ERR_SRC_NOT_SUPPORTED")
                return
            self.assertIsNone(state[1], "MEDIA_ERR")
            self.assertGreaterEqual(state[0], 2, "HAVE_CURRENT_DATA")
            import yaml
            with open(os.path.join(self.out, "scene.yaml")) as f:
                fps = yaml.safe_load(f)["frame_rate_hz"]
            self.assertAlmostEqual(state[2], self.rj["frames"] / fps, delta=1.5 / fps)
            played = d.execute_async_script(
                "const done = arguments[arguments.length - 1]; const v = document.getElementById('run-video');"
                "v.play().then(() => setTimeout(() => done([v.currentTime, v.paused, v.error ? v.error.code : null]), 600))"
                ".catch(e => done(['play() refused: ' + e]));")
            print(f"after play(): {played}")
            self.assertEqual(len(played), 3, played)
            self.assertGreater(played[0], 0.1, "the video's time advances")
            self.assertIsNone(played[2])
        finally:
            d.quit()

    def test_the_run_page_fits_and_shows_no_raw_value(self):   # RunReport's run, its page as written there
        self.assertTrue(CHROMIUM and DRIVER, "chromium and chromium-driver are installed by ./afm setup")
        out, page = self.out, self.html
        for name in ("force", "apex", "objects"):
            for ext in ("png", "svg"):
                self.assertTrue(os.path.isfile(os.path.join(out, "figures", f"{name}.{ext}")), f"{name}.{ext}")
                self.assertIn(f'href="figures/{name}.{ext}"', page)
        self.assertRegex(page, r"<tr><th>F_x</th><td>[+-][0-9.]+ nN</td><td>[0-9.]+ nN</td>", "F_x's bias and RMS as numbers")
        over, raw = page_faults(os.path.join(out, "report.html"))
        self.assertEqual(over, [], "elements past the page's 1,000 px")
        self.assertEqual(raw, [], "raw values on the page")
        d = browser()
        try:
            d.get("file://" + os.path.join(out, "report.html"))
            video, controls = d.execute_script("return [document.getElementById('run-video').getBoundingClientRect().bottom,"
                                               "document.getElementById('run-video-play').getBoundingClientRect().top];")
        finally:
            d.quit()
        self.assertGreaterEqual(controls, video, "the video's controls below the picture")

    def test_text_is_at_least_12_px_at_1280_by_800(self):
        self.assertTrue(CHROMIUM and DRIVER, "chromium and chromium-driver are installed by ./afm setup")
        d = browser()
        try:
            d.get("file://" + os.path.join(self.out, "report.html"))
            deadline = time.time() + 30
            while d.execute_script("const v = document.getElementById('run-video'); return v.readyState < 1 && !v.error;") \
                    and time.time() < deadline:
                time.sleep(0.2)
            small, images = d.execute_script(SIZES_JS)
            os.makedirs(SHOT_DIR, exist_ok=True)
            d.save_screenshot(os.path.join(SHOT_DIR, "report_selenium.png"))
        finally:
            d.quit()
        from analysis import run_report
        print(f"images with text (tag, capitals as shown px, natural width, shown width): {images}")
        self.assertEqual(small, [], "text under 12 px")
        self.assertGreaterEqual(len(images), 3, "the video, the contact sheet, the fidelity figure")
        for tag, cap, natural, shown in images:
            self.assertGreaterEqual(cap, run_report.MIN_CAP_PX, f"{tag}: labels {cap:.1f} px high as shown ({natural} -> {shown} px)")
        # the figures' text: 9 pt at 100 dpi is 12.5 px
        p = run_report._plt()
        for key in ("font.size", "legend.fontsize", "legend.title_fontsize", "xtick.labelsize", "ytick.labelsize", "axes.labelsize"):
            pts = p.rcParams[key]
            if not isinstance(pts, (int, float)):   # "small", "medium": relative to font.size
                from matplotlib.font_manager import FontProperties
                pts = FontProperties(size=pts).get_size_in_points()
            self.assertGreaterEqual(pts * 100 / 72, 12, key)


# Every element whose box reaches past the page's 1,000 px column (or the
# window), or that scrolls sideways; the page's own scroll width.
OVERFLOW_JS = """
const page = Math.min(1000, document.documentElement.clientWidth), body = document.body.getBoundingClientRect();
const left = body.left + (body.width - Math.min(body.width, page)) / 2, out = [];
for (const el of document.querySelectorAll('body *')) {
  const r = el.getBoundingClientRect();
  if (r.width && (r.right > left + page + 0.5 || r.left < left - 0.5 || el.scrollWidth > el.clientWidth + 1 &&
      getComputedStyle(el).overflowX !== 'visible'))
    out.push(el.tagName + '.' + el.className + ' ' + Math.round(r.left) + '..' + Math.round(r.right));
}
return [out, document.documentElement.scrollWidth, document.body.innerText];
"""


def page_faults(path):
    """(overflowing elements, raw values in the text) of a page in Chromium at 1280 px."""
    from analysis import units
    d = browser()
    try:
        d.get("file://" + path)
        time.sleep(0.3)
        over, width, text = d.execute_script(OVERFLOW_JS)
    finally:
        d.quit()
    print(f"{path}: scroll width {width} px, {len(over)} element(s) past the page, {len(units.raw_values(text))} raw value(s)")
    return over + ([f"page scroll width {width}"] if width > 1280 else []), units.raw_values(text)


class ReportsFit(unittest.TestCase):
    """The three reports at 1280 px: nothing past the page, no raw value."""

    def test_the_sweep_page_fits_and_shows_no_raw_value(self):
        self.assertTrue(CHROMIUM and DRIVER, "chromium and chromium-driver are installed by ./afm setup")
        sys.path.insert(0, os.path.join(e2e_support.SRC, "tests", "py"))
        from test_units import sweep_points
        from analysis import sweep_report
        out = e2e_support.tmpdir("report-sweep")
        points, knobs = sweep_points(), [("firmware.adc_bits", [10, 12, 14])]
        effects = sweep_report.knob_effects(points, knobs)
        meta = {"scene_name": "short-push", "scene": "scenes/short.yaml", "ok": 3, "failed": 0, "repeat": 1,
                "build_id": "abc", "engine": "local"}
        plots = sweep_report.write_plots(out, points)
        self.assertTrue(plots, "some figure varies: its plot drawn")
        sweep_report.write_html(out, meta, points, knobs, plots, effects, sweep_report.best_buy(effects))
        over, raw = page_faults(os.path.join(out, "report.html"))
        self.assertEqual(over, [], "elements past the page's 1,000 px")
        self.assertEqual(raw, [], "raw values on the page")

    def test_the_paper_page_fits_and_shows_no_raw_value(self):
        self.assertTrue(CHROMIUM and DRIVER, "chromium and chromium-driver are installed by ./afm setup")
        sys.path.insert(0, os.path.join(e2e_support.SRC, "tests", "py"))
        from test_units import paper_results
        from analysis.paper import paper_report
        out = e2e_support.tmpdir("report-paper")
        paper_report.write(out, paper_results(out), "quick", 246.3)
        over, raw = page_faults(os.path.join(out, "report.html"))
        self.assertEqual(over, [], "elements past the page's 1,000 px")
        self.assertEqual(raw, [], "raw values on the page")


if __name__ == "__main__":
    e2e_support.main()
