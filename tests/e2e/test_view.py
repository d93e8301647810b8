"""The live view in a real browser (docs/view.md): Debian's chromium,
headless, driven by Selenium through chromium-driver, from the caller's
network namespace, as a person's browser would be.

- A short lockstep scene run with --view --wait (held until the page
  connects): frames arrive on the page, the force chart moves, the last
  frame the page shows is the run's last file, and a screenshot is kept.
- The page loads with no network: every resource comes from the server, and
  with every host name but 127.0.0.1 unresolvable it still works.
- A wrong token is refused (the page, a static file, the stream), and the
  server listens on 127.0.0.1 only.
- ./afm view's page plays the recorded run with its scrubber.
- --spy without DISPLAY is refused at once, naming DISPLAY.
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

import benchtest

CHROMIUM = shutil.which("chromium")
DRIVER = shutil.which("chromedriver")
PY = sys.executable
# Kept after the test (the runs' folder is removed when every test passes).
SHOT_DIR = os.path.join(benchtest.BUILD, "test-output", "view")


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
        cls.out = os.path.join(benchtest.tmpdir("view"), "run")
        cls.server, cls.url, cls.port, cls.token = start_server(
            ["run", "--out", cls.out, "--wait", "--", benchtest.LAUNCH, "--scene", benchtest.scene("short.yaml"),
             "--out", cls.out, "--view", "--quiet"])
        cls.driver = browser(block_network=True)

    @classmethod
    def tearDownClass(cls):
        cls.driver.quit()
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
        finally:
            p.terminate()
            p.wait(timeout=10)

    def test_4_spy_without_display_refused(self):
        env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
        t0 = time.time()
        r = subprocess.run([benchtest.LAUNCH, "--scene", benchtest.scene("short.yaml"), "--out",
                            os.path.join(benchtest.tmpdir("spy"), "run"), "--spy"], env=env, capture_output=True,
                           text=True, timeout=30)
        self.assertEqual(r.returncode, 2)
        self.assertIn("DISPLAY", r.stderr)
        self.assertLess(time.time() - t0, 5)


if __name__ == "__main__":
    benchtest.main()
