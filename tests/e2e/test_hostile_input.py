"""Hostile input (issue 46, item 8), each attack as the issue found it:
a GSF substrate whose header had finite but huge extents (XReal = 1e300)
passed ./afm check and segfaulted sim_afm; `include:` of a root-only file
printed its content (a password hash) as the value that was not a mapping;
escape sequences in scene keys, GSF header lines and file names reached the
terminal raw. Now: every number of a GSF header is held to its range
(common/gsf.hpp kGsfRanges) before anything runs; an included file is never
quoted; every C0 and C1 control byte comes out escaped (common/text.hpp) on
each of those paths, in one line, exit 2. And the page (./afm view) refuses
a port it cannot have, and malformed HTTP, in one line each."""
import os
import re
import socket
import subprocess
import sys
import time
import unittest

import e2e_support

SHORT = open(e2e_support.scene("short.yaml")).read()
# Every C0 control but NUL (no file name or argument holds one; the unit tests
# of the escapers take it), DEL, and every C1 control as UTF-8.
CONTROLS = [bytes([b]) for b in range(1, 0x20)] + [b"\x7f"] + [bytes([0xC2, c]) for c in range(0x80, 0xA0)]
RAW_CONTROL = re.compile(rb"[\x00-\x1f\x7f]|\xc2[\x80-\x9f]")
SECRET = "AFMTESTSECRET0123456789"   # in the root-only stand-ins for /etc/shadow


def escaped(raw):
    """What common/text.hpp makes of a control's bytes: \\xHH each."""
    return "".join("\\x%02X" % c for c in raw).encode()


def yaml_escape(raw):
    """The control as a YAML double-quoted escape (a C1 control: its code point)."""
    return "\\x%02x" % (raw[0] if len(raw) == 1 else raw[1])


def check(path):
    """afm_launch --check of a scene path (bytes or str): (exit code, stderr bytes)."""
    p = subprocess.run([e2e_support.LAUNCH.encode(), b"--check", b"--scene", os.fsencode(path)], capture_output=True, timeout=60)
    return p.returncode, p.stderr


def write_gsf(path, fields, extra=b""):
    """A GSF file: these header fields, extra header bytes, XRes x YRes zeros."""
    head = b"Gwyddion Simple Field 1.0\n" + "".join(f"{k} = {v}\n" for k, v in fields.items()).encode()
    head += b"XYUnits = m\nZUnits = m\n" + extra
    head += b"\0" * (4 - len(head) % 4)
    with open(path, "wb") as f:
        f.write(head + b"\0" * (4 * int(fields["XRes"]) * int(fields["YRes"])))
    return path


GOOD_MAP = {"XRes": 4, "YRes": 4, "XReal": "1e-5", "YReal": "1e-5", "XOffset": "-5e-6", "YOffset": "-5e-6"}


class TestCase(unittest.TestCase):
    def setUp(self):
        self.dir = e2e_support.tmpdir("hostile-input")
        self.addCleanup(e2e_support.cleanup, self.dir)

    def scene(self, text, name="scene.yaml"):
        path = os.path.join(os.fsencode(self.dir), os.fsencode(name))
        with open(path, "wb") as f:
            f.write(text.encode() if isinstance(text, str) else text)
        return path

    def assert_one_escaped_line(self, code, stderr, *wants):
        self.assertEqual(code, 2, stderr)
        self.assertEqual(stderr.count(b"\n"), 1, stderr)
        self.assertTrue(stderr.endswith(b"\n"), stderr)
        self.assertIsNone(RAW_CONTROL.search(stderr[:-1]), stderr)
        stderr.decode("utf-8")   # valid UTF-8
        for w in wants:
            self.assertIn(w, stderr)


class GsfRanges(TestCase):
    def test_a_huge_finite_extent_is_refused_before_anything_runs(self):
        gsf = write_gsf(os.path.join(self.dir, "huge.gsf"),
                        dict(GOOD_MAP, XReal="1e300", YReal="1e300", XOffset="-1e299", YOffset="-1e299"))
        path = self.scene(SHORT.replace("substrate: glass", f"substrate: {{gsf: {gsf}}}"))
        code, err = check(path)
        self.assert_one_escaped_line(code, err, b"sample.substrate.gsf", gsf.encode(),
                                     b"GSF header XReal must be a number in [1e-10, 1], got '1e300'")
        out = os.path.join(self.dir, "out")
        code, _, stderr, _ = e2e_support.run(path.decode(), out, timeout=120)   # sim_afm exited 139 here
        self.assertEqual(code, 2, stderr)
        self.assertNotIn("exit code 139", stderr)
        self.assertFalse(os.path.exists(out), "nothing may start for a bad substrate")

    def test_each_range_is_held_through_the_scene(self):
        for key, bad in (("XRes", "4097"), ("YRes", "1"), ("XReal", "1.5"), ("YReal", "1e-11"), ("XOffset", "-1.5"),
                         ("YOffset", "2")):
            gsf = write_gsf(os.path.join(self.dir, f"{key}.gsf"), dict(GOOD_MAP, **{key: bad}))
            code, err = check(self.scene(SHORT.replace("substrate: glass", f"substrate: {{gsf: {gsf}}}")))
            self.assert_one_escaped_line(code, err, f"GSF header {key} must be".encode(), f"got '{bad}'".encode())


class Includes(TestCase):
    """Root-only stand-ins for /etc/shadow (never the real one)."""

    def standin(self, name, text):
        path = os.path.join(self.dir, name)
        with open(path, "w") as f:
            f.write(text)
        os.chmod(path, 0o600)
        return path

    def test_an_included_file_is_never_quoted(self):
        cases = {
            "shadow": f"root:$6${SECRET}:19000:0:99999:7:::\ndaemon:*:19000:0:99999:7:::\n",
            "mapping": f"{SECRET}: {SECRET}\n",
            "nested": f"probe: {{{SECRET}: 1}}\n",
            "value": f"probe: {SECRET}\n",
            "number": f"probe: {{tip_radius_nm: {SECRET}}}\n",
            "list": f"- {SECRET}\n",
        }
        for name, text in cases.items():
            inc = self.standin(name, text)
            code, err = check(self.scene(SHORT + f"include: {inc}\n", name + ".yaml"))
            self.assertEqual(code, 2, (name, err))
            self.assertEqual(err.count(b"\n"), 1, (name, err))
            self.assertNotIn(SECRET.encode(), err, name)
            self.assertIn(b"included file", err, name)

    def test_an_include_takes_regular_files_only(self):
        fifo = os.path.join(self.dir, "fifo")
        os.mkfifo(fifo)
        for target, words in ((fifo, b"it is a FIFO"), (self.dir, b"it is a directory"), ("/dev/zero", b"it is a device")):
            code, err = check(self.scene(SHORT + f"include: {target}\n"))
            self.assert_one_escaped_line(code, err, words)


class ControlCharacters(TestCase):
    """Every C0 and C1 control byte through each path to the terminal."""

    def test_in_a_scene_key_and_value(self):
        for raw in CONTROLS:
            e = yaml_escape(raw)
            code, err = check(self.scene(SHORT.replace("duration_s: 0.6", f'duration_s: 0.6\n"k{e}x": 1')))
            self.assert_one_escaped_line(code, err, b"k" + escaped(raw) + b"x: unknown key")
            code, err = check(self.scene(SHORT.replace("duration_s: 0.6", f'duration_s: "0{e}6"')))
            self.assert_one_escaped_line(code, err, b"duration_s: must be a number, got '0" + escaped(raw) + b"6'")

    def test_in_a_scene_string_that_run_json_and_the_report_would_carry(self):
        # text a run writes into run.json (JSON) and report.html (HTML) must be printable UTF-8: refused, not quoted
        for raw in CONTROLS:
            code, err = check(self.scene(SHORT.replace("name: short-push", f'name: "a{yaml_escape(raw)}b"')))
            self.assert_one_escaped_line(code, err, b"name: must be printable UTF-8 text")

    def test_in_a_gsf_header_line(self):
        for raw in CONTROLS:
            if raw == b"\n":
                continue   # a line break ends a header line
            gsf = write_gsf(os.path.join(self.dir, "esc.gsf"), GOOD_MAP, b"bad" + raw + b"line\n")
            code, err = check(self.scene(SHORT.replace("substrate: glass", f"substrate: {{gsf: {gsf}}}")))
            self.assert_one_escaped_line(code, err, b"GSF header line without '=': 'bad" + escaped(raw) + b"line'")

    def test_in_file_names(self):
        for raw in CONTROLS:
            if raw == b"/":
                continue
            folder = os.path.join(os.fsencode(self.dir), b"dir" + raw)
            os.makedirs(folder, exist_ok=True)
            path = os.path.join(folder, b"scene.yaml")
            with open(path, "w") as f:
                f.write(SHORT.replace("duration_s: 0.6", "durration_s: 0.6"))
            code, err = check(path)
            self.assert_one_escaped_line(code, err, b"dir" + escaped(raw) + b"/scene.yaml: durration_s: unknown key")
            code, err = check(self.scene(SHORT + f'include: "missing{yaml_escape(raw)}.yaml"\n'))
            self.assert_one_escaped_line(code, err, b"missing" + escaped(raw) + b".yaml: cannot open")


class ThePagesPort(unittest.TestCase):
    """./afm view RUN --port: a port that is no port, or one another process
    holds, is one line and exit 2 (a traceback before)."""

    def view(self, *args):
        return subprocess.run([sys.executable, "-m", "analysis.view", "play", *args], capture_output=True, text=True,
                              timeout=60)

    def test_a_port_out_of_range_or_held_is_one_line(self):
        run = e2e_support.tmpdir("view-port")
        self.addCleanup(e2e_support.cleanup, run)
        open(os.path.join(run, "bus.lcmlog"), "wb").close()   # (the port is refused first, before the record is read)
        held = socket.socket()
        held.bind(("127.0.0.1", 0))
        held.listen(1)
        self.addCleanup(held.close)
        for port, words in (("99999", "a port is a whole number from 0"), ("-1", "a port is a whole number from 0"),
                            (str(held.getsockname()[1]), "in use")):
            p = self.view(run, "--port", port)
            lines = p.stderr.strip().splitlines()
            self.assertEqual(p.returncode, 2, p.stderr)
            self.assertEqual(len(lines), 1, p.stderr)
            self.assertIn(f"--port {port}", lines[0])
            self.assertIn(words, lines[0])
            self.assertNotIn("Traceback", p.stderr)


class CorruptLog(TestCase):
    """./afm export of a bit-flipped log: a channel name no longer UTF-8
    (LCM's reader raised UnicodeDecodeError: 4 tracebacks in 80 random
    flips of a run's log) or a negative timestamp (MCAP's writer raised
    struct.error) is one line, exit 2; and any flip is either read or that."""
    LOG = os.path.join(e2e_support.SRC, "fuzz", "corpus", "lcmlog", "run_start.lcmlog")   # a real run's start

    def export(self, data, mode):
        run = os.path.join(self.dir, "run")
        os.makedirs(run, exist_ok=True)
        with open(os.path.join(run, "bus.lcmlog"), "wb") as f:
            f.write(data)
        target = os.path.join(run, "out.mcap" if mode == "--mcap" else "csv")
        p = subprocess.run([sys.executable, "-m", "analysis.export", run, mode, target], capture_output=True, timeout=120)
        return p.returncode, p.stderr

    def test_a_flipped_bit_is_read_or_one_line(self):
        with open(self.LOG, "rb") as f:
            raw = f.read()
        self.assertEqual(raw[28:41], b"AFM_HEARTBEAT")   # the first event's channel (LCM's event header is 28 bytes)
        name = bytearray(raw)
        name[28] = 0xC1
        code, err = self.export(bytes(name), "--csv")
        self.assert_one_escaped_line(code, err, b"bus.lcmlog: corrupt: an event's channel name is not UTF-8 text")
        when = bytearray(raw)
        when[12] |= 0x80   # the first event's timestamp (int64, big-endian) negative
        code, err = self.export(bytes(when), "--mcap")
        self.assert_one_escaped_line(code, err, b"log time", b"outside MCAP's range")
        import random
        rng = random.Random(46)
        for k in range(16):
            b = bytearray(raw)
            for _ in range(rng.choice((1, 8))):
                i = rng.randrange(len(b))
                b[i] ^= 1 << rng.randrange(8)
            code, err = self.export(bytes(b), ("--csv", "--mcap")[k % 2])
            self.assertNotIn(b"Traceback", err, k)
            if code != 0:
                self.assert_one_escaped_line(code, err)


# The page's server alone (analysis/view/server.py) with a source that says
# hello and nothing else, in its own process: its stderr is what a person sees.
SERVE = """
import asyncio, sys
from analysis.view import server
class Source:
    def hello(self): return {"type": "hello"}
    def on_message(self, m): return None
async def main():
    sock = server.listen(0)
    view = server.ViewServer("tok", Source())
    await view.start(sock)
    print(sock.getsockname()[1], flush=True)
    await asyncio.sleep(600)
asyncio.run(main())
"""
WS_UPGRADE = {"Upgrade": "websocket", "Connection": "Upgrade", "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
              "Sec-WebSocket-Version": "13"}


class ThePage(unittest.TestCase):
    """The page checks Host (loopback names with its port) and Origin (its
    own) as well as the token, on HTTP and the WebSocket (issue 46 item 10);
    malformed HTTP is aiohttp's 400 and one escaped line, not a traceback."""

    @classmethod
    def setUpClass(cls):
        cls.p = subprocess.Popen([sys.executable, "-c", SERVE], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        cls.port = int(cls.p.stdout.readline())

    @classmethod
    def tearDownClass(cls):
        cls.p.kill()
        cls.p.wait()
        cls.p.stdout.close()
        cls.p.stderr.close()

    def status(self, path, headers):
        """The status of GET path with exactly these headers (Host too)."""
        import http.client
        c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=5)
        c.putrequest("GET", path, skip_host=True, skip_accept_encoding=True)
        for k, v in headers.items():
            c.putheader(k, v)
        c.endheaders()
        status = c.getresponse().status
        c.close()
        return status

    def test_host_and_origin_are_checked_with_the_token_right(self):
        own = [f"127.0.0.1:{self.port}", f"localhost:{self.port}", f"[::1]:{self.port}", f"LOCALHOST:{self.port}"]
        for host in own:
            self.assertEqual(self.status("/?token=tok", {"Host": host}), 200, host)
            self.assertEqual(self.status("/view.js?token=tok", {"Host": host, "Origin": f"http://{host}"}), 200, host)
        wrong_hosts = [None, "", "127.0.0.1", f"127.0.0.1:{self.port + 1}", f"evil.example:{self.port}",
                       f"127.0.0.1.evil.example:{self.port}", f"localhost.:{self.port}", f"0.0.0.0:{self.port}",
                       f"127.0.0.2:{self.port}", f"[::ffff:127.0.0.1]:{self.port}", "evil.example"]
        for host in wrong_hosts:
            headers = {} if host is None else {"Host": host}
            refused = (400, 403) if host is None else (403,)   # no Host at all: aiohttp's own 400 comes first
            self.assertIn(self.status("/?token=tok", headers), refused, host)
            self.assertIn(self.status("/ws?token=tok", dict(headers, **WS_UPGRADE)), refused, host)
        host = f"127.0.0.1:{self.port}"
        for origin in ("null", "http://evil.example", f"http://evil.example:{self.port}", f"https://{host}",
                       f"http://localhost:{self.port}", f"http://{host}.evil.example", f"http://{host}/x"):
            self.assertEqual(self.status("/?token=tok", {"Host": host, "Origin": origin}), 403, origin)
            self.assertEqual(self.status("/ws?token=tok", dict({"Host": host, "Origin": origin}, **WS_UPGRADE)), 403, origin)
        self.assertEqual(self.status("/?token=bad", {"Host": host}), 403)

    def test_malformed_http_is_one_escaped_line_each(self):
        bad = [b"GET / HTTP/1.1\r\nHost: x\r\nContent-Length: -5\r\n\r\n", b"GET /\x1b[2J\xc2\x9b HTTP/1.1\r\n\r\n",
               b"GET / HTTP/1.1\r\nHost: " + b"a" * 100000 + b"\r\n\r\n", b"\x16\x03\x01\x02\x00\x01" + b"\0" * 60,
               b"GET / HTTP/1.1\r\nX\x1b[31m: y\r\n\r\n"]
        for raw in bad:
            with socket.create_connection(("127.0.0.1", self.port), timeout=5) as c:
                c.sendall(raw)
                self.assertTrue(c.recv(100).startswith(b"HTTP/1."), raw[:40])
        time.sleep(0.5)
        self.p.kill()
        err = self.p.stderr.read()
        lines = err.splitlines()
        self.assertGreaterEqual(len(lines), 4, err)
        self.assertNotIn(b"Traceback", err)
        for line in lines:
            self.assertTrue(line.startswith(b"view: "), line)
            self.assertIsNone(RAW_CONTROL.search(line), line)
        self.assertIn(b"\\\\x1b[2J\\\\xc2\\\\x9b", err)   # aiohttp quotes the bytes as repr does (\\x1b); escaped once more


if __name__ == "__main__":
    e2e_support.main()
