"""The live view in a real browser (docs/view.md): Debian's chromium,
headless, driven by Selenium through chromium-driver, from the caller's
network namespace, as a person's browser would be.

- A short lockstep scene run with --view --wait (held until the page
  connects): frames arrive on the page, the force chart moves, the last
  frame the page shows is the run's last file, and a screenshot is kept.
- The page loads with no network: every resource comes from the server, and
  with every host name but 127.0.0.1 unresolvable it still works.
- A wrong token is refused (the page, a static file, the stream), and so is
  another site's Host or Origin with the token right; the server listens on
  127.0.0.1 only.
- ./afm view's page plays the recorded run with its scrubber.
- --spy without DISPLAY is refused at once, naming DISPLAY.
- operator.mode browser (realtime): the test drags the pointer over the
  image with the tip engaged, and the particle in its way moves, in
  SIM_TRUTH and on the page.
- A planner stroke from the page: the stroke button, a click on a particle,
  a click on its target; the particle ends within the planner's tolerance
  of the target in SIM_TRUTH, and the page shows the stroke's outcome.
"""
import json
import os
import re
import shutil
import subprocess
import sys
import time
import unittest
import urllib.error
import urllib.request

import e2e_support

CHROMIUM = shutil.which("chromium")
DRIVER = shutil.which("chromedriver")
PY = sys.executable
# Kept after the test (the runs' folder is removed when every test passes).
SHOT_DIR = os.path.join(e2e_support.BUILD, "test-output", "view")


def browser(block_network=False):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,900",
              "--no-first-run", "--disable-background-networking", "--disable-component-update"):
        opts.add_argument(a)
    if block_network:   # no name resolves but the page's own address
        opts.add_argument("--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1")
    return webdriver.Chrome(service=Service(DRIVER), options=opts)


_driver = []


def shared_browser():
    """The file's one browser (block_network: every page here is the
    server's own), started at the first test that needs it and quit after
    the last (tearDownModule): each test loads its page anew."""
    if not _driver:
        _driver.append(browser(block_network=True))
    return _driver[0]


def tearDownModule():
    while _driver:
        _driver.pop().quit()


def start_server(args):
    """A `python -m analysis.view` process and the page's URL it prints."""
    p = subprocess.Popen([PY, "-m", "analysis.view"] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = []
    deadline = time.time() + 30
    while time.time() < deadline:
        line = p.stderr.readline()
        if not line:
            break
        lines.append(line)
        m = re.match(r"view: (http://127\.0\.0\.1:(\d+)/\?token=(\S+))", line)
        if m:
            return p, m.group(1), int(m.group(2)), m.group(3)
    p.kill()
    raise AssertionError("no page address printed: " + "".join(lines) + p.stderr.read())


def page_state(driver):
    return driver.execute_script("return window.afmView")


def wait_for(driver, cond, timeout, what):
    deadline = time.time() + timeout
    while time.time() < deadline:
        s = page_state(driver)
        if s and cond(s):
            return s
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}: {page_state(driver)}")


def http_status(url):
    try:
        with urllib.request.urlopen(url, timeout=5) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


def status_with(port, path, headers):
    """The status of GET path on the page with exactly these headers (Host included)."""
    import http.client
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
    c.putrequest("GET", path, skip_host=True, skip_accept_encoding=True)
    for k, v in headers.items():
        c.putheader(k, v)
    c.endheaders()
    try:
        return c.getresponse().status
    finally:
        c.close()


def listening_on_loopback_only(port):
    """/proc/net/tcp: every socket listening (state 0A) on `port` is bound to 127.0.0.1."""
    found = []
    for path in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(path) as f:
            for line in f.readlines()[1:]:
                local, state = line.split()[1], line.split()[3]
                ip, p = local.rsplit(":", 1)
                if int(p, 16) == port and state == "0A":
                    found.append(ip)
    return found == ["0100007F"], found


@unittest.skipUnless(CHROMIUM and DRIVER, "chromium or chromedriver missing (./afm setup installs them)")
class View(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = os.path.join(e2e_support.tmpdir("view"), "run")
        cls.server, cls.url, cls.port, cls.token = start_server(
            ["run", "--out", cls.out, "--wait", "--", e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"),
             "--out", cls.out, "--view", "--quiet"])
        cls.driver = shared_browser()

    @classmethod
    def tearDownClass(cls):
        if cls.server.poll() is None:
            cls.server.kill()
            cls.server.wait()

    def test_1_wrong_token_refused_and_loopback_only(self):
        ok, found = listening_on_loopback_only(self.port)
        self.assertTrue(ok, f"listening on {found}")
        base = f"http://127.0.0.1:{self.port}"
        self.assertEqual(http_status(f"{base}/?token=wrong"), 403)
        self.assertEqual(http_status(f"{base}/view.js"), 403)
        self.assertEqual(http_status(f"{base}/ws?token={self.token}x"), 403)
        # the token right, but another site's Host (DNS rebinding) or Origin: refused too (issue 46 item 10;
        # every case: test_hostile_input's ThePage)
        for path in ("/", "/ws"):
            for headers in ({"Host": f"evil.example:{self.port}"},
                            {"Host": f"127.0.0.1:{self.port}", "Origin": "http://evil.example"}):
                self.assertEqual(status_with(self.port, f"{path}?token={self.token}", headers), 403, (path, headers))
        self.assertEqual(status_with(self.port, f"/view.js?token={self.token}",
                                     {"Host": f"localhost:{self.port}", "Origin": f"http://localhost:{self.port}"}), 200)
        self.assertEqual(self.server.poll(), None, "a refused request must not start the run (--wait)")
        self.assertFalse(os.path.exists(os.path.join(self.out, "run.json")))

    def test_2_live_frames_and_chart(self):
        d = self.driver
        d.get(self.url)
        first = wait_for(d, lambda s: s["framesShown"] >= 1 or s["ended"], 60, "a first frame")
        self.assertIsNone(first["ended"], f"the run ended before a frame: {first}")
        ends = {tuple(first["chartT"])}
        s = first
        deadline = time.time() + 60
        while s["ended"] is None and time.time() < deadline:
            s = page_state(d)
            if s["chartT"][1] is not None:
                ends.add(tuple(s["chartT"]))
            time.sleep(0.02)
        s = wait_for(d, lambda s: s["ended"] is not None, 30, "the run's end")
        self.assertEqual(self.server.wait(timeout=30), 0, self.server.stderr.read()[-2000:])
        self.assertEqual(s["ended"]["exit_code"], 0, s)
        run = json.load(open(os.path.join(self.out, "run.json")))
        self.assertEqual(run["status"], "ok")
        self.assertEqual(s["ended"]["status"], "ok")
        # frames came from the renderer: the last one the page shows is the run's last
        self.assertGreaterEqual(s["framesShown"], 2, s)
        self.assertEqual(s["lastIndex"], run["frames"] - 1, s)
        self.assertTrue(os.path.exists(os.path.join(self.out, "frames", "frame_%05d.png" % s["lastIndex"])))
        view = run["renderer"]["view"]
        self.assertEqual(view["published"] + view["skipped"] + view["too_large"], run["frames"], view)
        self.assertEqual(view["too_large"], 0, view)
        # the force chart moves: samples came and its window advanced
        self.assertGreater(s["chartSamples"], 50, s)
        self.assertGreaterEqual(len({e[1] for e in ends if e[1] is not None}), 2, ends)
        # its edges are labelled with their own times: the window is 5 s wide,
        # starts at 0 s until the run reaches 5 s, and holds the samples drawn
        lo, hi = s["chartEdges"]
        self.assertAlmostEqual(hi - lo, 5.0, places=6, msg=s["chartEdges"])
        self.assertGreaterEqual(lo, 0.0, s["chartEdges"])
        self.assertEqual(s["chartLabels"], [f"{lo:.1f} s", f"{hi:.1f} s"], s)
        self.assertTrue(lo <= s["chartT"][0] <= s["chartT"][1] <= hi, (s["chartT"], s["chartEdges"]))
        # a process with no simulated clock (the launcher, the operator) shows
        # none, not 0.00 s; the simulator's time is shown
        procs = d.find_element("id", "procs").text
        for name, p in s["procs"].items():
            line = next(x for x in procs.splitlines() if x.startswith(name))
            if p["clocked"]:
                self.assertRegex(line, r"\d+\.\d\d s$", line)
            else:
                self.assertNotIn("0.00 s", line)
        self.assertTrue(any(p["clocked"] for p in s["procs"].values()), s["procs"])
        # nothing came from anywhere but the server (and nothing else resolves)
        hosts = d.execute_script("return performance.getEntriesByType('resource').map(e => new URL(e.name).host)")
        self.assertTrue(hosts and all(h == f"127.0.0.1:{self.port}" for h in hosts), hosts)
        os.makedirs(SHOT_DIR, exist_ok=True)
        shot = os.path.join(SHOT_DIR, "live.png")
        d.save_screenshot(shot)
        print(f"test_view: screenshot of the live page: {shot}", file=sys.stderr)
        self.assertGreater(os.path.getsize(shot), 10000)

    def test_3_recorded_run_with_scrubber(self):
        if not os.path.exists(os.path.join(self.out, "run.json")):
            self.skipTest("the live run did not finish")
        p, url, _, _ = start_server(["play", self.out])
        try:
            d = self.driver
            d.get(url)
            s = wait_for(d, lambda s: s["framesShown"] >= 1 and s["mode"] == "recorded", 30, "the recorded run's first frame")
            self.assertEqual(s["lastIndex"], 0)
            total = s["framesTotal"]
            d.execute_script("const r = document.getElementById('pos'); r.value = arguments[0];"
                             "r.dispatchEvent(new Event('input'));", total - 1)
            s = wait_for(d, lambda s: s["lastIndex"] == total - 1, 20, "the scrubber's last frame")
            self.assertGreater(s["chartT"][2], 0, s)
            d.save_screenshot(os.path.join(SHOT_DIR, "recorded.png"))
            # the gamepad's mapping (view.js padStep, rumble), fed a fake pad:
            # no pad exists headless, and a real one's rumble is checked by hand
            a, b, dead, r = d.execute_script(
                "const v = window.afmView, h = {target_nm: [0, 0], load_nN: 5, engaged: false, padA: false};"
                "const pad = {axes: [1, -1], buttons: [{pressed: true, value: 1}, {}, {}, {}, {}, {}, {value: 0}, {value: 1}]};"
                "const a = v.padStep(h, pad, 0.1, null);"
                "const b = v.padStep(Object.assign({}, h, a, {padA: a.a}), pad, 0.1, null);"
                "const dead = v.padStep(h, {axes: [0.05, -0.05], buttons: []}, 0.1, null);"
                "return [a, b, dead, [v.rumble([0.1, 0]), v.rumble([1, 1]), v.rumble([0, 0])]];")
            self.assertAlmostEqual(a["target_nm"][0], 80.0)    # full right stick, 0.1 s at 800 nm/s
            self.assertAlmostEqual(a["target_nm"][1], 80.0)    # stick up: +y
            self.assertAlmostEqual(a["load_nN"], 5.5)          # right trigger: 5 nN/s
            self.assertTrue(a["engaged"])                      # A pressed: engaged
            self.assertTrue(b["engaged"], "A held down must not toggle again")
            self.assertAlmostEqual(b["target_nm"][0], 160.0)
            self.assertFalse(dead["moved"], "inside the dead zone the target stays")
            self.assertEqual(r, [0.5, 1, 0])
        finally:
            p.terminate()
            p.wait(timeout=10)

    def test_3b_recorded_run_without_frame_files_plays_the_bus_frames(self):
        # outputs.png: false leaves no frames/*.png; a run made with --view
        # still has the JPEGs the page was sent (VIEW_FRAME) in its record
        if not os.path.exists(os.path.join(self.out, "run.json")):
            self.skipTest("the live run did not finish")
        bare = os.path.join(os.path.dirname(self.out), "no-frame-files")
        shutil.copytree(self.out, bare, ignore=shutil.ignore_patterns("frame_*.png"))
        sent = json.load(open(os.path.join(self.out, "run.json")))["renderer"]["view"]["published"]
        p, url, _, _ = start_server(["play", bare])
        try:
            d = self.driver
            d.get(url)
            s = wait_for(d, lambda s: s["framesShown"] >= 1 and s["mode"] == "recorded", 30, "the bus's first frame")
            self.assertEqual(s["framesTotal"], sent, s)
            d.execute_script("const r = document.getElementById('pos'); r.value = arguments[0];"
                             "r.dispatchEvent(new Event('input'));", sent - 1)
            s = wait_for(d, lambda s: s["framesShown"] >= 2, 20, "the scrubber's last frame")
            self.assertGreater(s["lastIndex"], 0, s)
        finally:
            p.terminate()
            p.wait(timeout=10)
        # neither frame files nor VIEW_FRAMEs (an empty record): refused, naming both
        empty = os.path.join(os.path.dirname(self.out), "empty-run")
        os.makedirs(os.path.join(empty, "frames"))
        open(os.path.join(empty, "bus.lcmlog"), "wb").close()
        from analysis.view import recorded
        with self.assertRaises(recorded.RunError) as e:
            recorded.RecordedSource(empty)
        self.assertIn("no frame files", str(e.exception))
        self.assertIn("no VIEW_FRAME", str(e.exception))

    def test_4_spy_without_display_refused(self):
        env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
        t0 = time.time()
        r = subprocess.run([e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out",
                            os.path.join(e2e_support.tmpdir("spy"), "run"), "--spy"], env=env, capture_output=True,
                           text=True, timeout=30)
        self.assertEqual(r.returncode, 2)
        self.assertIn("DISPLAY", r.stderr)
        self.assertLess(time.time() - t0, 5)


BROWSER_SCENE = """
name: browser-test
seed: 7
duration_s: 10.0   # realtime: the page's first frame, the click and a 3.5 s drag must fit (a loaded CI machine ended a 6 s run mid-drag)
time_mode: realtime
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [bending_offset, adhesion, photodiode_noise, tip_convolution]
sample:
  substrate: glass
  field_nm: 2000
  tip_substrate: {mu: 0.0865, adhesion_nN: 1.0}
  particle_substrate: {mu: 0.3, adhesion_nN: 3.0}
objects:
  particles:
    - {id: 1, x_nm: 0, y_nm: -300, radius_nm: 50}
operator:
  mode: browser
  load_nN: 5
  path_nm: [[0, -700]]
outputs:
  image_px: 128
  video: none
"""


def canvas_offset(d, x_nm, y_nm):
    """Where the point (x_nm, y_nm) of the field is drawn on the page's image,
    from the canvas's centre in CSS px (the page's own meta: field and size)."""
    return d.execute_script(
        "const m = window.afmView.meta, c = document.getElementById('image'), r = c.getBoundingClientRect();"
        "const [x0, y0, side] = m.field_nm, pitch = side / m.width, k = r.width / m.width;"
        "return [(arguments[0] - x0) / pitch * k - r.width / 2, (m.height - (arguments[1] - y0) / pitch) * k - r.height / 2];",
        x_nm, y_nm)


def particle(ps, pid):
    return next(p for p in ps if p[0] == pid)


@unittest.skipUnless(CHROMIUM and DRIVER, "chromium or chromedriver missing (./afm setup installs them)")
class BrowserHand(unittest.TestCase):
    def test_dragging_the_pointer_pushes_a_particle(self):
        from selenium.webdriver.common.action_chains import ActionChains
        scene = e2e_support.write_scene(BROWSER_SCENE, "browser")
        out = os.path.join(e2e_support.tmpdir("browser"), "run")
        # a person's push in real time: its display may end off the fresh
        # scan (the run's verdict), which is not this test's point
        srv, url, _, _ = start_server(["run", "--out", out, "--wait", "--", e2e_support.LAUNCH, "--scene", scene,
                                       "--out", out, "--view", "--quiet", "--no-verdict"])
        d = shared_browser()
        try:
            d.get(url)
            s = wait_for(d, lambda s: s["hand"] and s["framesShown"] >= 1, 60, "the hand's controls and a frame")
            start_y = particle(s["particles"], 1)[2]
            canvas = d.find_element("id", "image")

            def offset(x_nm, y_nm):
                return canvas_offset(d, x_nm, y_nm)
            # two local scans the person asks for: a right-click on particle 1
            # (around it), then the button (around the tip)
            p1 = particle(s["particles"], 1)
            px, py = offset(p1[1], p1[2])
            ActionChains(d).move_to_element_with_offset(canvas, int(px), int(py)).context_click().perform()
            d.find_element("id", "scan").click()
            d.find_element("id", "engage").click()
            x, y = offset(0, -700)
            drag = ActionChains(d, duration=50).move_to_element_with_offset(canvas, int(x), int(y)).click_and_hold()
            steps = 40
            for i in range(1, steps + 1):   # 600 nm in about 2 s, then held there
                nx, ny = offset(0, -700 + 600 * i / steps)
                drag.move_to_element_with_offset(canvas, int(nx), int(ny)).pause(0.05)
            drag.pause(1.5).release().perform()
            s = wait_for(d, lambda s: s["ended"] is not None, 60, "the run's end")
            self.assertEqual(srv.wait(timeout=30), 0, srv.stderr.read()[-2000:])
            self.assertEqual(s["ended"]["status"], "ok", s["ended"])
            self.assertGreater(s["ended"]["hand"]["sent"], 10, s["ended"])
            # on the page: the card's model of particle 1 moved along the push
            end_y = particle(s["particles"], 1)[2]
            self.assertGreater(end_y - start_y, 50, (start_y, end_y))
            # in the truth
            log = e2e_support.afmlog.load(os.path.join(out, "bus.lcmlog"), channels={"SIM_TRUTH"})
            whole = e2e_support.afmlog.whole_objects(log["SIM_TRUTH"], lambda m: m.objects)
            y0 = next(p.y_nm for p in whole[0][1].particles if p.id == 1)
            y1 = next(p.y_nm for p in whole[-1][1].particles if p.id == 1)
            self.assertGreater(y1 - y0, 50, (y0, y1))
            rep = json.load(open(os.path.join(out, "operator_report.json")))
            self.assertGreater(rep["browser"]["commands"], 10, rep.get("browser"))
            self.assertEqual(rep["browser"]["refused"], 0)
            self.check_page_scans(out, rep, p1, s)
            os.makedirs(SHOT_DIR, exist_ok=True)
            d.save_screenshot(os.path.join(SHOT_DIR, "browser_hand.png"))
        finally:
            if srv.poll() is None:
                srv.kill()
                srv.wait()

    def check_page_scans(self, out, rep, p1, s):
        """The person's two local scans: asked by the operator (its req_ids,
        kPageScanReqBase 20000 and up), served, and pasted by the renderer."""
        self.assertEqual((rep["browser"]["scans_asked"], rep["browser"]["scans"]), (2, 2), rep["browser"])
        log = e2e_support.afmlog.load(os.path.join(out, "bus.lcmlog"), channels={"AFM_SCAN_REQ", "AFM_SCAN_LINE"})
        reqs = {m.req_id: m for m in log["AFM_SCAN_REQ"] if m.req_id >= 20000}
        self.assertEqual(sorted(reqs), [20001, 20002])
        pitch = 2000 / 128
        first = reqs[20001]   # around particle 1, where the page showed it
        self.assertLessEqual(abs(first.x0_nm + first.width_nm / 2 - p1[1]), pitch, (first, p1))
        self.assertLessEqual(abs(first.y0_nm + first.height_nm / 2 - p1[2]), pitch, (first, p1))
        self.assertEqual((first.nx, first.ny), (32, 32))   # 500 nm at the display's pitch
        lines = {(m.req_id, m.line) for m in log["AFM_SCAN_LINE"] if m.req_id >= 20000}
        self.assertEqual(len(lines), 64)
        ren = json.load(open(os.path.join(out, "renderer_report.json")))
        self.assertEqual(ren["page_scans_pasted"], 2)
        self.assertEqual(s["ended"]["hand"]["refused"], 0)


PLAN_TOLERANCE_NM = 15.0          # the scene's operator.plan.tolerance_nm (the default is 25), which a stroke takes
STROKE_SCENE = BROWSER_SCENE.replace("name: browser-test", "name: browser-stroke").replace(
    "duration_s: 10.0   #", "duration_s: 9.0   # the stroke (about 3 simulated s) after the first frame;").replace(
    "  path_nm: [[0, -700]]\n", f"  path_nm: [[0, -700]]\n  plan: {{tolerance_nm: {PLAN_TOLERANCE_NM}, speed_nm_per_s: 2500}}\n")
STROKE_TARGET_NM = (0.0, 150.0)   # 450 nm along +y from particle 1, across the lever's axis (x)


@unittest.skipUnless(CHROMIUM and DRIVER, "chromium or chromedriver missing (./afm setup installs them)")
class BrowserStroke(unittest.TestCase):
    def test_click_particle_then_target_places_it(self):
        from selenium.webdriver.common.action_chains import ActionChains
        scene = e2e_support.write_scene(STROKE_SCENE, "stroke")
        out = os.path.join(e2e_support.tmpdir("stroke"), "run")
        srv, url, _, _ = start_server(["run", "--out", out, "--wait", "--", e2e_support.LAUNCH, "--scene", scene,
                                       "--out", out, "--view", "--quiet", "--no-verdict"])
        d = shared_browser()
        try:
            d.get(url)
            s = wait_for(d, lambda s: s["hand"] and s["framesShown"] >= 1, 60, "the hand's controls and a frame")
            canvas = d.find_element("id", "image")

            def click_at(x_nm, y_nm):
                x, y = canvas_offset(d, x_nm, y_nm)
                ActionChains(d).move_to_element_with_offset(canvas, int(x), int(y)).click().perform()
            p1 = particle(s["particles"], 1)
            d.find_element("id", "stroke").click()
            click_at(p1[1], p1[2])
            self.assertEqual(page_state(d)["stroke"]["phase"], "target")
            self.assertEqual(page_state(d)["stroke"]["id"], 1)   # the pending selection
            click_at(*STROKE_TARGET_NM)
            s = wait_for(d, lambda s: any(n["phase"] == "end" for n in s["stroke"]["news"]) or s["ended"], 60, "the stroke's end")
            news = s["stroke"]["news"]
            phases = [n["phase"] for n in news]
            self.assertEqual((phases[0], phases[-1]), ("start", "end"), news)
            progress = [n for n in news[1:-1] if n["phase"] == "progress"]
            self.assertEqual(len(progress), len(news) - 2, news)
            self.assertGreaterEqual(len(progress), 1, news)   # 3 scans of 0.3 s at least: over 0.5 s
            self.assertEqual([n["pushes"] for n in progress], sorted(n["pushes"] for n in progress), news)
            end = news[-1]
            self.assertEqual((end["id"], end["placed"]), (1, 1), end)
            self.assertIn("placed", d.find_element("id", "strokemsg").text)
            s = wait_for(d, lambda s: s["ended"] is not None, 60, "the run's end")
            self.assertEqual(srv.wait(timeout=30), 0, srv.stderr.read()[-2000:])
            self.assertEqual(s["ended"]["status"], "ok", s["ended"])
            # the target the page sent is the one clicked, within a CSS pixel's rounding
            pitch = 2000 / 128
            self.assertLessEqual(abs(end["x_nm"] - STROKE_TARGET_NM[0]), pitch, end)
            self.assertLessEqual(abs(end["y_nm"] - STROKE_TARGET_NM[1]), pitch, end)
            # in the truth: within the planner's tolerance of the target the page sent
            log = e2e_support.afmlog.load(os.path.join(out, "bus.lcmlog"), channels={"SIM_TRUTH"})
            whole = e2e_support.afmlog.whole_objects(log["SIM_TRUTH"], lambda m: m.objects)
            t = next(p for p in whole[-1][1].particles if p.id == 1)
            miss = ((t.x_nm - end["x_nm"]) ** 2 + (t.y_nm - end["y_nm"]) ** 2) ** 0.5
            self.assertLessEqual(miss, PLAN_TOLERANCE_NM, (t.x_nm, t.y_nm, end))
            rep = json.load(open(os.path.join(out, "operator_report.json")))["browser"]
            self.assertEqual((rep["pushes_asked"], rep["refused"], len(rep["strokes"])), (1, 0, 1), rep)
            self.assertTrue(rep["strokes"][0]["placed"], rep)
            self.assertGreaterEqual(rep["stroke_planner"]["local_scans"], 2, rep)
            settings = rep["stroke_planner"]["settings"]   # the scene's, not the defaults
            self.assertEqual((settings["tolerance_nm"], settings["speed_nm_per_s"]), (PLAN_TOLERANCE_NM, 2500), settings)
            self.assertNotIn("plan", json.load(open(os.path.join(out, "operator_report.json"))))   # no automatic plan ran
            print(f"test_view: stroke: particle 1 {miss:.1f} nm from the clicked target in SIM_TRUTH, "
                  f"{rep['strokes'][0]['pushes']} pushes, {rep['strokes'][0]['ended_sim_s'] - rep['strokes'][0]['started_sim_s']:.2f} "
                  f"simulated s", file=sys.stderr)
            os.makedirs(SHOT_DIR, exist_ok=True)
            d.save_screenshot(os.path.join(SHOT_DIR, "browser_stroke.png"))
        finally:
            if srv.poll() is None:
                srv.kill()
                srv.wait()


if __name__ == "__main__":
    e2e_support.main()
