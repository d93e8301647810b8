"""Issue 46, items 6 and 7: no datagram loses a run, and the run dies with
its launcher.

- A single LCM datagram on a channel whose name is not UTF-8 (b"\\xffX"),
  from a plain socket in the run's namespace, aborted the launcher at the
  end (nlohmann type_error.316 when run.json was dumped: exit 134, no
  run.json, no report). The run must end ok, with run.json naming the
  channel escaped (afm::printable: "\\xFFX").
- SIGKILL of afm_launch left its four children running, re-parented to
  init, holding the namespace. Every process of the run must go with it
  (by pid, and nothing left in the run's network namespace), and the next
  launcher on that folder must say, in one line, that the run there was
  interrupted."""
import json
import os
import signal
import subprocess
import sys
import time
import unittest

import e2e_support

# One LCM short datagram ("LC02", a sequence number, the channel's name and
# its NUL, a payload), sent from a plain UDP socket inside the run's
# namespace, a few times from before the run's processes start to after.
SEND_BAD_CHANNEL = r'''
import socket, struct, sys, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
pkt = struct.pack(">II", 0x4c433032, 1) + b"\xffX\x00" + b"payload"
n = 0
t0 = time.monotonic()
while time.monotonic() - t0 < float(sys.argv[1]):
    s.sendto(pkt, ("239.255.76.67", 7667)); n += 1
    time.sleep(0.05)
print(n)
'''

RUN_PROGRAMS = ("afm_launch", "sim_afm", "fw_node", "operator", "renderer", "ffmpeg", "qemu-system-arm")


def exe_of(pid):
    try:
        return os.path.basename(os.readlink(f"/proc/{pid}/exe"))
    except OSError:
        return ""


def netns_of(pid):
    try:
        return os.readlink(f"/proc/{pid}/ns/net")
    except OSError:
        return ""


def ppid_of(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return int(f.read().rsplit(")", 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return -1


def all_pids():
    return [int(p) for p in os.listdir("/proc") if p.isdigit()]


def descendants(root):
    kids = {}
    for p in all_pids():
        kids.setdefault(ppid_of(p), []).append(p)
    out, todo = [], [root]
    while todo:
        p = todo.pop()
        for c in kids.get(p, []):
            out.append(c)
            todo.append(c)
    return out


def alive(pid):
    """True when pid is a live process (not a zombie)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


class NoDatagramLosesARun(unittest.TestCase):
    def test_a_channel_name_that_is_not_utf8_is_counted_escaped(self):
        out = e2e_support.tmpdir("bad-channel")
        self.addCleanup(e2e_support.cleanup, out)
        script = ('"$PY" -c "$SEND" 4 > /dev/null & h=$!; '
                  '"$LAUNCH" --scene "$SCENE" --out "$OUT" --quiet; rc=$?; wait $h; exit $rc')
        env = dict(os.environ, PY=sys.executable, SEND=SEND_BAD_CHANNEL, LAUNCH=e2e_support.LAUNCH,
                   SCENE=e2e_support.scene("short.yaml"), OUT=out, AFM_RUN_WRITES=out)
        p = subprocess.run([e2e_support.IN_NETNS, "sh", "-c", script], capture_output=True, text=True, timeout=400, env=env)
        self.assertEqual(p.returncode, 0, p.stderr[-2000:])
        with open(os.path.join(out, "run.json"), "rb") as f:
            raw = f.read()
        raw.decode("utf-8")   # the whole file is UTF-8
        rj = json.loads(raw)
        self.assertEqual(rj["status"], "ok")
        # the launcher hears every channel: the datagram is foreign (no
        # process of the run sent it), counted under its name escaped
        foreign = rj["launcher"]["foreign"]
        self.assertIn("\\xFFX", foreign, foreign)
        self.assertGreater(sum(foreign["\\xFFX"].values()), 0, foreign)
        self.assertFalse(any("\ufffd" in k or "\xff" in k for k in foreign), foreign)


class TheRunDiesWithItsLauncher(unittest.TestCase):
    def test_sigkill_of_the_launcher_leaves_nothing_running(self):
        out = e2e_support.tmpdir("killed")
        self.addCleanup(e2e_support.cleanup, out)
        with open(e2e_support.scene("short.yaml")) as f:
            text = f.read().replace("duration_s: 0.6", "duration_s: 120.0")
        scene = e2e_support.write_scene(text, "long-scene")
        self.addCleanup(e2e_support.cleanup, os.path.dirname(scene))
        p = subprocess.Popen([e2e_support.IN_NETNS, e2e_support.LAUNCH, "--scene", scene, "--out", out, "--quiet"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            launcher, kids = None, []
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline:
                found = [q for q in descendants(p.pid) if exe_of(q) == "afm_launch"]
                if found:
                    launcher = found[0]
                    kids = [q for q in descendants(launcher) if exe_of(q) in RUN_PROGRAMS]
                    names = {exe_of(q) for q in kids}
                    # every process up, the renderer's encoder too (it starts
                    # after the renderer's first scan, before the loop)
                    if {"sim_afm", "fw_node", "operator", "renderer", "ffmpeg"} <= names:
                        break
                time.sleep(0.1)
            self.assertIsNotNone(launcher, "no afm_launch under in_netns.sh")
            self.assertTrue({"sim_afm", "fw_node", "operator", "renderer", "ffmpeg"} <= {exe_of(q) for q in kids},
                            {exe_of(q) for q in kids})
            ns = netns_of(launcher)
            self.assertTrue(ns)
            os.kill(launcher, signal.SIGKILL)
            p.wait(timeout=60)
            # every process of the run goes with it (ffmpeg finishes its
            # file when its input ends: a moment)
            left, in_ns = [], []
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                left = [q for q in kids + [launcher] if alive(q)]
                in_ns = [q for q in all_pids() if netns_of(q) == ns and alive(q)]
                if not left and not in_ns:
                    break
                time.sleep(0.1)
            self.assertEqual(left, [], [(q, exe_of(q)) for q in left])
            self.assertEqual(in_ns, [], [(q, exe_of(q)) for q in in_ns])
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        self.assertFalse(os.path.exists(os.path.join(out, "run.json")))
        # the next command on that folder says the run there was interrupted
        code, _, err, rj = e2e_support.run(e2e_support.scene("short.yaml"), out)
        said = [line for line in err.splitlines() if "interrupted" in line]
        self.assertEqual(len(said), 1, err)
        self.assertIn("the last run in", said[0])
        self.assertIn("left no run.json", said[0])
        self.assertEqual(code, 0, err)
        self.assertEqual(rj["status"], "ok")
        # and a run that ended says nothing of the kind
        code, _, err, _ = e2e_support.run(e2e_support.scene("short.yaml"), out)
        self.assertEqual(code, 0, err)
        self.assertNotIn("interrupted", err)


if __name__ == "__main__":
    e2e_support.main()
