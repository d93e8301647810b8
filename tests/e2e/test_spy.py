"""lcm-spy, headless under Xvfb, inside a run's namespace: it must find every
type of the project (one per lcmtypes/*.lcm) on the types jar, and a recorded
log must replay into it with lcm-logplayer (./afm spy); ./afm run --spy holds
a lockstep run's start until lcm-spy listens."""
import glob
import json
import os
import re
import select
import shutil
import subprocess
import time
import unittest

import e2e_support
from analysis import paths


def start_xvfb(wait_s=30):
    """Xvfb on a free display: (process, display number), once it accepts
    clients. -displayfd: Xvfb picks the display and writes its number on
    the pipe when it is ready, which is the readiness this waits for."""
    r, w = os.pipe()
    p = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                         pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    text, deadline = b"", time.monotonic() + e2e_support.limit(wait_s)
    try:
        while not text.endswith(b"\n") and time.monotonic() < deadline:
            if select.select([r], [], [], 0.5)[0]:
                chunk = os.read(r, 64)
                if not chunk:   # Xvfb ended without a display
                    break
                text += chunk
    finally:
        os.close(r)
    if not text.endswith(b"\n"):
        p.kill()
        raise RuntimeError(f"Xvfb gave no display within {wait_s} s (exit {p.wait()})")
    return p, int(text)


def headless_java_first(folder):
    """A PATH whose first java is a headless runtime: a java that runs the
    real one with java.awt.headless=true, in a home without libawt_xawt.so
    (what default-jdk-headless installs)."""
    real = shutil.which("java")
    if real is None:
        raise unittest.SkipTest("no java (./afm setup installs default-jre)")
    bin_dir = os.path.join(folder, "jre-headless", "bin")
    os.makedirs(bin_dir, exist_ok=True)
    shim = os.path.join(bin_dir, "java")
    with open(shim, "w") as f:
        f.write(f'#!/bin/sh\nexec {real} -Djava.awt.headless=true "$@"\n')
    os.chmod(shim, 0o755)
    for d in (folder, os.path.dirname(bin_dir), bin_dir):
        os.chmod(d, 0o755)   # the run's user runs it too
    return bin_dir + os.pathsep + os.environ.get("PATH", "")


class Spy(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not shutil.which("Xvfb"):
            raise unittest.SkipTest("Xvfb missing (./afm setup installs it)")
        cls.xvfb, cls.display = start_xvfb()
        cls.n_types = len(glob.glob(os.path.join(e2e_support.SRC, "lcmtypes", "*.lcm")))

    @classmethod
    def tearDownClass(cls):
        cls.xvfb.terminate()
        cls.xvfb.wait()

    def test_spy_finds_every_type_and_replays_a_log(self):
        self.replay(os.environ.get("PATH", ""))

    def test_spy_opens_its_window_with_a_headless_java_first_on_path(self):
        self.replay(headless_java_first(e2e_support.tmpdir("spy-headless")))

    def replay(self, path):
        out = e2e_support.tmpdir("spy")
        code, _, err, _ = e2e_support.run(e2e_support.scene("short.yaml"), out)
        self.assertEqual(code, 0, err)
        env = dict(os.environ, DISPLAY=f":{self.display}", AFM_SPY_EXIT_AFTER_REPLAY="1", PATH=path,
                   AFM_TYPES_JAR=os.path.join(e2e_support.BUILD, "lcmtypes", "afm_types.jar"))
        p = subprocess.run([e2e_support.IN_NETNS, paths.SPY_REPLAY,
                            os.path.join(out, "bus.lcmlog"), "5"], env=env, capture_output=True, text=True,
                           timeout=e2e_support.limit(180))
        text = p.stdout + p.stderr
        self.assertEqual(p.returncode, 0, text[-2000:])
        m = re.search(r"Found (\d+) LCM types", text)
        self.assertIsNotNone(m, text[-2000:])
        self.assertEqual(int(m.group(1)), self.n_types)
        self.assertIn("replay of", text)
        self.assertNotIn("HeadlessException", text)
        e2e_support.cleanup(out)


    def test_spy_holds_a_lockstep_run_until_it_listens(self):
        self.live(os.environ.get("PATH", ""))

    def test_a_runs_spy_opens_with_a_headless_java_first_on_path(self):
        self.live(headless_java_first(e2e_support.tmpdir("spy-live-headless")))

    def live(self, path):
        # --spy: the run starts only once lcm-spy's socket is bound on the
        # bus's port in the run's namespace (10 s at most), so a lockstep run
        # is not over before lcm-spy subscribes
        out = os.path.join(e2e_support.tmpdir("spy-live"), "run")
        env = dict(os.environ, DISPLAY=f":{self.display}", PATH=path)
        p = subprocess.Popen([e2e_support.IN_NETNS, e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out", out,
                              "--spy"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        lines = []
        try:
            for line in p.stderr:
                lines.append(line)
                if "close lcm-spy to finish" in line:
                    break
        finally:
            p.send_signal(2)   # SIGINT: the launcher closes lcm-spy and ends
            p.wait(timeout=e2e_support.limit(60))
        text = "".join(lines)
        self.assertIn("lcm-spy listens on the bus; the run starts", text)
        self.assertLess(text.index("lcm-spy listens"), text.index("close lcm-spy to finish"), text)
        with open(os.path.join(out, "run.json")) as f:
            self.assertEqual(json.load(f)["status"], "ok")
        e2e_support.cleanup(out)


if __name__ == "__main__":
    e2e_support.main()
