"""Issue 46, item 5: messages carry their sender's proof.

Before: with a raw socket in the run's namespace, a datagram sent with the
source port of a process of the run that publishes its channel passed the
check of senders (bus/senders.hpp): a `launcher stop` heartbeat from the
launcher's port ended the run and blamed sim_afm; a pose for block n + 1
from the operator's port made the run diverge and still end ok; a
HOST_OBJECT_FIX from the renderer's port dropped the real fix of particle 1.

Now every datagram of the run carries a MAC with the run's key
(bus/bus_key.hpp), which a forger outside the run does not hold: the
forgeries, sent by faults/forge.py --spoof PROGRAM from a raw socket with
that program's source port, change nothing (the run ends ok with the
undisturbed run's trajectories) and are counted by every receiver that
hears them (run.json: each process's rejected.unproven, the launcher's
unproven, by reason and channel).

The page of ./afm run --view takes VIEW_FRAME through afm_view_bridge, the
launcher's child holding the key: a VIEW_FRAME forged from the renderer's
port never reaches the page, and the bridge counts it (run.json
launcher.view_bridge, logs/view_bridge.log)."""
import asyncio
import json
import math
import os
import re
import subprocess
import sys
import time
import unittest

import e2e_support
from analysis import afmlog, paths

FORGE, DROP_CAPS = paths.FORGE, paths.DROP_CAPS
REPLAY = paths.REPLAY
PROCESSES = ("sim", "fw", "operator", "renderer")
CHANNELS = ["SIM_TRUTH", "AFM_CMD", "FW_STATE", "HAPTIC_POSE", "HAPTIC_FORCE"]


def run_with_spoofer(scene, out, what, program, mac=True):
    """The scene with faults/forge.py WHAT --spoof PROGRAM beside it (the
    forger keeps CAP_NET_RAW in the run's namespace, the launcher runs
    without it); returns (exit code, stderr, run.json, what was sent)."""
    sent = out.rstrip("/") + ".sent.json"
    script = ('"$PY" "$FORGE" "$WHAT" --spoof "$PROGRAM" --seconds 300 > "$SENT" & h=$!; '
              '"$DROP" "$LAUNCH" --scene "$SCENE" --out "$OUT" --quiet; rc=$?; kill -TERM $h; wait $h; exit $rc')
    env = dict(os.environ, PY=sys.executable, FORGE=FORGE, WHAT=what, PROGRAM=program, SENT=sent, DROP=DROP_CAPS,
               LAUNCH=e2e_support.LAUNCH, SCENE=scene, OUT=out, AFM_KEEP_CAPS="net_raw",
               AFM_RUN_WRITES=os.path.dirname(sent))
    if not mac:
        env["AFM_BUS_MAC"] = "off"
    p = subprocess.run([e2e_support.IN_NETNS, "sh", "-c", script], capture_output=True, text=True, timeout=400, env=env)
    rj = None
    if os.path.exists(os.path.join(out, "run.json")):
        with open(os.path.join(out, "run.json")) as f:
            rj = json.load(f)
    with open(sent) as f:
        said = json.load(f)
    os.remove(sent)
    return p.returncode, p.stderr, rj, said


def unproven(rj, channel):
    """{process: datagrams on `channel` it refused for want of proof}."""
    out = {p: rj[p]["rejected"]["unproven"]["by_channel"].get(channel, 0) for p in PROCESSES if p in rj}
    out["launcher"] = rj["launcher"]["unproven"]["by_channel"].get(channel, 0)
    return out


# Beside the launcher of a viewed run: the forger, ended by the launcher's
# end (its parent-death signal), and the launcher in the shell's place, so
# that the run's processes are the launcher's children as ./afm run --view
# makes them; the launcher's arguments follow the script.
VIEWED_WITH_FORGER = ('setpriv --pdeathsig TERM -- "$PY" "$FORGE" "$WHAT" --spoof "$PROGRAM" --seconds 300 > "$SENT" & '
                      'exec "$DROP" "$@"')


async def page_messages(port, token, seconds):
    """What a page of the live view is sent (the WebSocket, no browser):
    ([JSON messages], [binary messages]) until the "end" message or
    `seconds`."""
    import aiohttp
    texts, images = [], []
    async with aiohttp.ClientSession() as s:
        async with s.ws_connect(f"http://127.0.0.1:{port}/ws?token={token}", timeout=seconds) as ws:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                try:
                    m = await ws.receive(timeout=max(0.1, end - time.monotonic()))
                except asyncio.TimeoutError:
                    break
                if m.type == aiohttp.WSMsgType.TEXT:
                    texts.append(json.loads(m.data))
                    if texts[-1].get("type") == "end":
                        break
                elif m.type == aiohttp.WSMsgType.BINARY:
                    images.append(m.data)
                else:
                    break
    return texts, images


def viewed_with_spoofer(scene, out, what, program):
    """./afm run SCENE --view --wait as ./afm starts it (python -m
    analysis.view run: the page's server, the run in its namespace), with
    faults/forge.py WHAT --spoof PROGRAM beside the launcher; a page's
    WebSocket opens the stream. Returns (exit code, the server's stderr,
    run.json, what was sent, the page's JSON messages, its images)."""
    sent = out.rstrip("/") + ".sent.json"
    env = dict(os.environ, PY=sys.executable, FORGE=FORGE, WHAT=what, PROGRAM=program, SENT=sent, DROP=DROP_CAPS,
               AFM_KEEP_CAPS="net_raw", AFM_RUN_WRITES=os.path.dirname(sent))
    cmd = [sys.executable, "-m", "analysis.view", "run", "--out", out, "--wait", "--", "sh", "-c", VIEWED_WITH_FORGER, "sh",
           e2e_support.LAUNCH, "--scene", scene, "--out", out, "--view", "--quiet"]
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    try:
        line = p.stderr.readline()
        m = re.match(r"view: http://127\.0\.0\.1:(\d+)/\?token=(\S+)", line)
        assert m, "no page address printed: " + line
        texts, images = asyncio.run(page_messages(int(m.group(1)), m.group(2), e2e_support.limit(300)))
        err = p.stderr.read()
        code = p.wait(timeout=e2e_support.limit(60))
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    rj = None
    if os.path.exists(os.path.join(out, "run.json")):
        with open(os.path.join(out, "run.json")) as f:
            rj = json.load(f)
    deadline = time.monotonic() + e2e_support.limit(10)   # the forger says what it sent once the launcher is gone
    while not os.path.getsize(sent) and time.monotonic() < deadline:
        time.sleep(0.05)
    with open(sent) as f:
        said = json.load(f)
    os.remove(sent)
    return code, err, rj, said, texts, images


class EveryPublishGoesThroughTheBusLayer(unittest.TestCase):
    # the one owner of the trailer is the bus layer (afm::publish_raw): a
    # process that called liblcm's publish itself would send without proof
    ALLOWED = {"bus/bus.cpp",   # publish_raw itself
               "bench/host/bench_bus.cpp", "faults/linkprobe.cpp"}   # the benches' own channels, never a run's bus

    def test_no_publish_site_calls_liblcm_directly(self):
        pattern = re.compile(r"(\.|->)publish\(")
        found = []
        for top in ("common", "scene", "bus", "host", "sim_afm", "run", "faults", "tools", "bench"):
            for root, _, files in os.walk(os.path.join(e2e_support.SRC, top)):
                for name in files:
                    if not name.endswith((".cpp", ".hpp", ".h", ".c")):
                        continue
                    path = os.path.join(root, name)
                    rel = os.path.relpath(path, e2e_support.SRC)
                    with open(path, errors="replace") as f:
                        for i, line in enumerate(f, 1):
                            code = line.split("//", 1)[0]
                            if pattern.search(code) and rel not in self.ALLOWED:
                                found.append(f"{rel}:{i}: {line.strip()}")
        self.assertEqual(found, [])


class BusProof(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scene = e2e_support.short_scene_2s("proof-scene")
        cls.clean = e2e_support.tmpdir("calm")
        cls.code0, _, cls.err0, cls.rj0 = e2e_support.run(cls.scene, cls.clean)
        cls.log0 = afmlog.load(os.path.join(cls.clean, "bus.lcmlog"), channels=CHANNELS)
        cls.blocks = cls.rj0["sim"]["blocks"]

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.clean, os.path.dirname(cls.scene))

    def same_run(self, out):
        log = afmlog.load(os.path.join(out, "bus.lcmlog"), channels=CHANNELS)
        for ch, field in (("SIM_TRUTH", "seq"), ("AFM_CMD", "ack_seq"), ("FW_STATE", "seq"), ("HAPTIC_POSE", "seq"),
                          ("HAPTIC_FORCE", "seq")):
            calm, now = e2e_support.encoded_by_seq(self.log0[ch], self.blocks, field), e2e_support.encoded_by_seq(log[ch], self.blocks, field)
            self.assertEqual(sorted(calm), sorted(now), ch)
            differ = [q for q in calm if calm[q] != now[q]]
            self.assertEqual(differ, [], f"{ch}: blocks that differ from the undisturbed run: {differ[:5]}")

    def forged(self, what, program, channel):
        out = e2e_support.tmpdir(f"spoof-{what}")
        self.addCleanup(e2e_support.cleanup, out)
        code, err, rj, sent = run_with_spoofer(self.scene, out, what, program)
        self.assertIsNotNone(rj, err[-2000:])
        self.assertGreater(sent["total"], 5, sent)
        self.assertTrue(sent["spoofed_port"], sent)
        self.assertEqual(code, 0, err[-2000:])
        self.assertEqual(rj["status"], "ok")
        self.assertEqual(rj["sim"]["blocks"], self.blocks)
        self.same_run(out)
        return rj, sent

    def test_an_undisturbed_run_is_signed_and_refuses_nothing(self):
        self.assertEqual(self.code0, 0, self.err0)
        self.assertTrue(self.rj0["launcher"]["bus_mac"])
        for p in PROCESSES:
            self.assertEqual(self.rj0[p]["rejected"]["unproven"]["total"], 0, (p, self.rj0[p]["rejected"]["unproven"]))
            self.assertGreater(self.rj0[p]["rejected"]["proof_cost"]["signed"], 0, p)
            self.assertGreater(self.rj0[p]["rejected"]["proof_cost"]["checked"], 0, p)
        self.assertEqual(self.rj0["launcher"]["unproven"]["total"], 0, self.rj0["launcher"]["unproven"])
        # the launcher checked every message it recorded
        self.assertGreaterEqual(self.rj0["launcher"]["proof_cost"]["checked"], self.rj0["launcher"]["recorded_events"])

    def test_the_log_keeps_lcm_format_and_replays_identical(self):
        # the record holds each message as its sender encoded it, its
        # trailer checked and stripped: the log's format is LCM's and the
        # replay of the card reproduces it byte for byte
        p = subprocess.run([REPLAY, self.clean], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("identical", p.stdout + p.stderr)
        self.assertEqual(sum(self.log0.undecodable.values()), 0, self.log0.undecodable)

    def test_a_launcher_stop_from_the_launchers_port_changes_nothing(self):
        rj, _ = self.forged("stop", "afm_launch", "AFM_HEARTBEAT")
        n = unproven(rj, "AFM_HEARTBEAT")
        for p in ("sim", "fw", "operator", "renderer", "launcher"):
            self.assertGreater(n[p], 0, (p, n))
        self.assertGreater(rj["sim"]["rejected"]["unproven"]["by_reason"]["no_trailer"], 0)

    def test_a_pose_for_the_next_block_from_the_operators_port_changes_nothing(self):
        rj, _ = self.forged("pose", "operator", "HAPTIC_POSE")
        n = unproven(rj, "HAPTIC_POSE")
        self.assertGreater(n["fw"], 0.5 * self.blocks, n)
        self.assertGreater(n["launcher"], 0.5 * self.blocks, n)

    def test_an_object_fix_from_the_renderers_port_changes_nothing(self):
        rj, _ = self.forged("fix", "renderer", "HOST_OBJECT_FIX")
        n = unproven(rj, "HOST_OBJECT_FIX")
        self.assertGreater(n["fw"], 0, n)
        self.assertGreater(n["launcher"], 0, n)

    def test_without_the_key_the_spoofed_stop_ends_the_run(self):
        # what the MAC holds off: the same forgery on a run without a key
        # (AFM_BUS_MAC=off) passes the check of senders and stops the run
        out = e2e_support.tmpdir("spoof-stop-nokey")
        self.addCleanup(e2e_support.cleanup, out)
        code, err, rj, sent = run_with_spoofer(self.scene, out, "stop", "afm_launch", mac=False)
        self.assertGreater(sent["total"], 0, sent)
        self.assertNotEqual(code, 0, err[-2000:])
        if rj is not None:
            self.assertFalse(rj["launcher"]["bus_mac"])

    def test_a_heartbeat_that_names_another_process_is_foreign(self):
        # a heartbeat's name is tied to the program behind its source port
        # (Senders::vet), key or not: the launcher's "stop" from the
        # renderer's port, on a run without a key, is foreign everywhere
        out = e2e_support.tmpdir("spoof-stop-renderer")
        self.addCleanup(e2e_support.cleanup, out)
        code, err, rj, sent = run_with_spoofer(self.scene, out, "stop", "renderer", mac=False)
        self.assertGreater(sent["total"], 5, sent)
        self.assertEqual(code, 0, err[-2000:])
        self.assertEqual(rj["status"], "ok")
        self.same_run(out)
        for p in ("sim", "fw", "operator"):
            named = [who for who in rj[p]["rejected"]["foreign"].get("AFM_HEARTBEAT", {}) if "naming itself launcher" in who]
            self.assertTrue(named, (p, rj[p]["rejected"]["foreign"]))
            self.assertIn("renderer", named[0])


class ViewBridgeProof(unittest.TestCase):
    """A viewed run's page takes nothing without the run's proof."""

    def test_view_fd_without_view_is_refused_in_one_line(self):
        r, w = os.pipe()
        self.addCleanup(os.close, r)
        self.addCleanup(os.close, w)
        p = subprocess.run([e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out", "/nonexistent/run",
                            "--view-fd", str(w)], capture_output=True, text=True, pass_fds=(w,), timeout=60)
        self.assertEqual(p.returncode, 2)
        self.assertEqual(p.stderr, "afm_launch: --view-fd: goes with --view (it is the pipe to the page's server)\n")

    def test_a_view_frame_from_the_renderers_port_never_reaches_the_page(self):
        scene = e2e_support.short_scene_2s("view-proof-scene")
        out = os.path.join(e2e_support.tmpdir("spoof-view"), "run")
        self.addCleanup(e2e_support.cleanup, os.path.dirname(out), os.path.dirname(scene))
        code, err, rj, sent, texts, images = viewed_with_spoofer(scene, out, "view", "renderer")
        self.assertIsNotNone(rj, err[-2000:])
        self.assertEqual(code, 0, err[-2000:])
        self.assertEqual(rj["status"], "ok")
        self.assertGreater(sent["total"], 5, sent)
        self.assertTrue(sent["spoofed_port"], sent)
        frames = [t for t in texts if t.get("type") == "frame"]
        published = rj["renderer"]["view"]["published"]
        self.assertGreater(len(frames), 0, texts[-3:])
        # the page: only the renderer's frames (finite, real JPEGs), and the
        # server took from the bridge no more frames than the renderer made
        forged = [f for f in frames if not all(math.isfinite(v) for v in f["tip_nm"] + f["force_nN"])]
        self.assertEqual(forged, [], f"{len(forged)} forged frames reached the page")
        self.assertEqual([i for i in images if not i.startswith(b"\xff\xd8\xff")], [])
        end = [t for t in texts if t.get("type") == "end"][-1]
        self.assertLessEqual(end["frames_received"], published, (end, published))
        # the bridge counted what it refused: run.json and its log
        bridge = rj["launcher"]["view_bridge"]
        self.assertEqual(bridge["exit_code"], 0, bridge)
        refused = bridge["rejected"]["unproven"]
        self.assertGreater(refused["by_channel"].get("VIEW_FRAME", 0), 0, refused)
        self.assertGreater(refused["by_reason"]["no_trailer"], 0, refused)
        with open(os.path.join(out, "logs", "view_bridge.log")) as f:
            log = f.read()
        self.assertRegex(log, r"refused \d+ .*no_trailer \d+", log)


if __name__ == "__main__":
    e2e_support.main()
