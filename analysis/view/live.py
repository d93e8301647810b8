"""A viewed run (./afm run SCENE --view [--wait]; docs/view.md).

The page's browser is in the caller's network namespace and cannot reach
the run's, so this process stays in the caller's: it opens the listening
socket (127.0.0.1, a port it prints, a random token) and serves the page
from here. The run goes into its own namespace as always
(run/in_netns.sh), and the launcher is handed the write end of a pipe
(afm_launch --view-fd N), which it hands in turn to afm_view_bridge
(host/view), its child holding the run's key: the bridge takes
VIEW_FRAME and AFM_HEARTBEAT off the bus, with the run's proof, and writes
them to the pipe this process reads. Nothing else crosses.

Contract: the run starts at once, or (--wait) once a page with the token
has opened its stream; Ctrl-C while waiting exits 130 before anything ran.
The server stops when the run ends, and this exits with the run's code.

In operator.mode browser (time_mode realtime) the page is also the hand:
its pointer, wheel, keys and buttons (the hand, a local scan and a planner
stroke it asks for) reach the operator through a named
pipe in a private folder ($AFM_HAND_FIFO: the folder this process's, 0711,
not handed to the run's user; the pipe, 0600, the run's user's for the
run's life (AFM_RUN_FILES), so that started as root the run drops to its
user like any other: issue 46), which
the operator alone reads
(host/operator/hand_input.hpp); the operator says on its heartbeat
that it takes them ("hand: browser"), and the page then shows its controls;
it says there too when a stroke starts and ends ("push: start ...", "push:
end ..."), which the page is told as {"type": "push", ...}.
The page publishes nothing on the bus.
"""
import asyncio
import json
import math
import os
import shutil
import signal
import struct
import sys
import tempfile
import time

from analysis import afmlog, paths
from analysis.view import frames, server

MAX_CHANNEL = 63            # LCM's longest channel name
MAX_PAYLOAD = 1 << 20       # bytes: far above a view frame (under 64 kB)
SERVER_NICE = 10            # once the run has started (main_async)


class LiveSource:
    """What the page is told about a live run: frames and heartbeats."""

    def __init__(self, out_dir):
        self.out_dir = out_dir
        self.processes = {}
        self.frames = 0
        self.hand = None          # operator.mode browser: {"load_nN": the scene's load}
        self.hand_fd = None       # the pipe to the operator (non-blocking write end)
        self.hand_sent = self.hand_dropped = self.hand_refused = 0

    def hello(self):
        return frames.hello("live", run_dir=os.path.abspath(self.out_dir), hand=self.hand)

    def on_message(self, msg):
        """A page's hand (operator.mode browser): to the operator's pipe."""
        if msg.get("type") in LINES and self.hand is not None and self.hand_fd is not None:
            line = LINES[msg["type"]](msg)
            if line is None:
                self.hand_refused += 1
                return None
            try:
                os.write(self.hand_fd, line)
                self.hand_sent += 1
            except (BlockingIOError, BrokenPipeError):
                self.hand_dropped += 1   # the operator is not reading (yet): the next one will do
        return None

    def on_record(self, view, channel, data):
        """A record from the bridge, to the pages."""
        tname = afmlog.CHANNELS.get(channel)
        try:
            m = getattr(afmlog.afm, tname).decode(data) if tname else None
        except (ValueError, struct.error, UnicodeDecodeError, MemoryError, OverflowError):
            m = None
        if m is None:
            return
        if channel == "VIEW_FRAME":
            self.frames += 1
            meta, image = frames.from_view_frame(m)
            meta["t_rx_ms"] = time.time() * 1e3   # ./afm bench view's stages: the server has it
            view.broadcast_frame(meta, image)
        elif channel == "AFM_HEARTBEAT":
            clocked = m.sim_utime > 0 or self.processes.get(m.name, {}).get("clocked", False)
            self.processes[m.name] = {"state": m.state, "sim_s": m.sim_utime * 1e-6, "seq": m.seq, "clocked": clocked}
            view.broadcast({"type": "status", "processes": self.processes})
            if m.name == "operator" and m.detail.startswith("hand: browser") and self.hand is None:
                self.hand = {"load_nN": _load_of(m.detail)}
                view.broadcast({"type": "hand", "hand": self.hand})
            elif m.name == "operator" and m.detail.startswith("push: "):
                view.broadcast(dict(push_news(m.detail), type="push", sim_s=m.sim_utime * 1e-6))


def _load_of(detail):
    """The load in the operator's "hand: browser load_nN=X" (None without one)."""
    for word in detail.split():
        if word.startswith("load_nN="):
            try:
                return float(word[8:])
            except ValueError:
                return None
    return None


def hand_line(msg):
    """The operator's command line for a page's {"type": "hand", "x_nm",
    "y_nm", "load_nN", "engaged"} (host/operator/hand_input.hpp), or
    None when a field is missing or not a finite number (the operator
    checks the ranges)."""
    try:
        x, y, load = (float(msg[k]) for k in ("x_nm", "y_nm", "load_nN"))
    except (KeyError, TypeError, ValueError):
        return None
    if not all(math.isfinite(v) for v in (x, y, load)) or not isinstance(msg.get("engaged"), bool):
        return None
    return f"HAND {x:.3f} {y:.3f} {load:.4f} {int(msg['engaged'])}\n".encode()


def scan_line(msg):
    """The operator's command line for a page's {"type": "scan", "x_nm",
    "y_nm", "size_nm"}: a local scan around (x, y), size_nm on a side
    (host/operator/hand_input.hpp), or None when a field is missing
    or not a finite number (the operator checks the ranges)."""
    try:
        x, y, size = (float(msg[k]) for k in ("x_nm", "y_nm", "size_nm"))
    except (KeyError, TypeError, ValueError):
        return None
    if not all(math.isfinite(v) for v in (x, y, size)):
        return None
    return f"SCAN {x:.3f} {y:.3f} {size:.3f}\n".encode()


def push_line(msg):
    """The operator's command line for a page's {"type": "push", "id", "x_nm",
    "y_nm"}: a planner stroke of particle id to (x, y) (hand_input.hpp), or
    None when the id is not a whole number >= 0 or a coordinate not a
    finite number (the operator checks the id and the ranges)."""
    pid = msg.get("id")
    if not isinstance(pid, int) or isinstance(pid, bool) or not 0 <= pid < 10 ** 9:
        return None
    try:
        x, y = (float(msg[k]) for k in ("x_nm", "y_nm"))
    except (KeyError, TypeError, ValueError):
        return None
    if not all(math.isfinite(v) for v in (x, y)):
        return None
    return f"PUSH {pid} {x:.3f} {y:.3f}\n".encode()


LINES = {"hand": hand_line, "scan": scan_line, "push": push_line}


def detail_fields(words, start):
    """The key=value words of an operator's heartbeat detail (its push and
    env lines, host/operator) from words[start] on, as a dict: a value as an
    int where it reads as one, else a float, else its text; why= takes the
    rest of the line."""
    out = {}
    for i, w in enumerate(words[start:], start):
        k, _, v = w.partition("=")
        if k == "why":
            out["why"] = " ".join([v] + words[i + 1:])
            break
        for number in (int, float):
            try:
                out[k] = number(v)
                break
            except ValueError:
                pass
        else:
            out[k] = v
    return out


def push_news(detail):
    """The operator's "push: start|end id=.. x_nm=.. y_nm=.. [placed=..
    error_nm=.. pushes=.. scans=.. why=...]" as a dict."""
    words = detail.split()
    return dict(detail_fields(words, 2), phase=words[1] if len(words) > 1 else "")


async def read_records(fd, on_record):
    """The bridge's records (afm_view_bridge: u32 channel length, channel,
    u32 payload length, payload) until the pipe closes or a record is
    malformed."""
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(limit=MAX_PAYLOAD + 1024)
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), os.fdopen(fd, "rb", buffering=0))
    try:
        while True:
            (n,) = struct.unpack("<I", await reader.readexactly(4))
            if not 0 < n <= MAX_CHANNEL:
                break
            channel = (await reader.readexactly(n)).decode("ascii", "replace")
            (size,) = struct.unpack("<I", await reader.readexactly(4))
            if size > MAX_PAYLOAD:
                break
            on_record(channel, await reader.readexactly(size))
    except asyncio.IncompleteReadError:
        pass


def run_status(out_dir):
    """run.json's status, or None."""
    try:
        with open(os.path.join(out_dir, "run.json")) as f:
            return json.load(f).get("status")
    except (OSError, ValueError):
        return None


async def wait_for_page(view):
    """--wait: until a page opens its stream; False on Ctrl-C."""
    print("view: waiting for the page to connect (--wait); Ctrl-C stops", file=sys.stderr, flush=True)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    loop.add_signal_handler(signal.SIGINT, stop.set)
    waits = [asyncio.ensure_future(view.connected.wait()), asyncio.ensure_future(stop.wait())]
    await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
    for w in waits:
        w.cancel()
    loop.remove_signal_handler(signal.SIGINT)
    return view.connected.is_set()


async def start_run(run_cmd, wfd, hand_fifo):
    """The run in its namespace, the pipe's write end handed to the launcher
    (--view-fd, after run_cmd's own arguments), which starts the bridge on
    it; the hand's named pipe is read by the operator in operator.mode
    browser ($AFM_HAND_FIFO)."""
    cmd = [paths.IN_NETNS] + run_cmd + ["--view-fd", str(wfd)]
    # the pipe the run's user's for the run's life (in_netns.sh, AFM_RUN_FILES), this process's before and after
    env = dict(os.environ, AFM_HAND_FIFO=hand_fifo, AFM_RUN_FILES=hand_fifo)
    return await asyncio.create_subprocess_exec(*cmd, pass_fds=(wfd,), env=env)


def hand_pipe():
    """(folder, path, write end) of the hand's named pipe: in a folder of
    this process's that others may pass through but not list or write
    (0711, a random name), the pipe 0600 (the run's user's for the run's
    life: run/in_netns.sh, AFM_RUN_FILES); opened
    read-write here so that it never waits for a reader and never fails for
    want of one; written without waiting."""
    folder = tempfile.mkdtemp(prefix="afm-view-hand-")
    os.chmod(folder, 0o711)
    path = os.path.join(folder, "hand")
    os.mkfifo(path, 0o600)
    return folder, path, os.open(path, os.O_RDWR | os.O_NONBLOCK | os.O_NOFOLLOW)


async def main_async(run_cmd, out_dir, wait, port):
    sock = server.listen(port)
    token = server.new_token()
    source = LiveSource(out_dir)
    view = server.ViewServer(token, source)
    await view.start(sock)
    print(f"view: {server.url(sock, token)}", file=sys.stderr, flush=True)
    if wait and not await wait_for_page(view):
        await view.stop(0)
        return 130
    rfd, wfd = os.pipe()
    hand_dir, hand_path, hand_w = hand_pipe()
    proc = await start_run(run_cmd, wfd, hand_path)
    os.close(wfd)
    source.hand_fd = hand_w
    # the server below the launcher, at the run's processes' nice level
    # (afm_launch's kBusProcessNice): serving a page never takes their CPU
    os.setpriority(os.PRIO_PROCESS, 0, max(os.getpriority(os.PRIO_PROCESS, 0), SERVER_NICE))
    loop = asyncio.get_running_loop()
    loop.add_signal_handler(signal.SIGINT, lambda: None)   # the launcher stops the run and says so
    reading = asyncio.ensure_future(read_records(rfd, lambda ch, d: source.on_record(view, ch, d)))
    code = await proc.wait()
    await asyncio.wait([reading], timeout=1.0)
    reading.cancel()
    view.broadcast({"type": "end", "exit_code": code, "status": run_status(out_dir), "frames_received": source.frames,
                    "hand": {"sent": source.hand_sent, "dropped": source.hand_dropped, "refused": source.hand_refused}})
    os.close(hand_w)
    shutil.rmtree(hand_dir, ignore_errors=True)
    await view.stop()
    return code


def main(run_cmd, out_dir, wait=False, port=0):
    """Runs `run_cmd` (afm_launch and its arguments, --view among them) in its
    namespace with the page served; returns its exit code."""
    return asyncio.run(main_async(run_cmd, out_dir, wait, port))
