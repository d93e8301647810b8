"""One run of the bench driven a step at a time (operator.mode env;
host/operator/env_input.hpp, docs/env.md).

The run is started as every run is: afm_launch in a network namespace of
its own (run/in_netns.sh), with --view so that the renderer publishes its
display (VIEW_FRAME) and afm_view_bridge passes it, with every process's
AFM_HEARTBEAT, out of the namespace on a pipe (the live view's own path:
analysis/view/live.py). The actions go to the operator on a named pipe
($AFM_HAND_FIFO, as a page's hand: a private folder, the pipe handed to the
run's user for the run's life through AFM_RUN_FILES).

Contract:
  - Session(scene_path, out_dir) starts the run and returns once the
    operator has said it is ready (its first "env: ready 0"), or raises
    SessionError naming what ended it.
  - act(line) sends one action line and waits for its "env: ready K";
    returns (ready fields, the display's frame at or before the card's
    block N as a view_frame_t). Messages are decoded with the generated LCM
    types (analysis.afmlog), the bridge's framing as the live view reads it.
  - end() sends END, waits for the run to exit and returns (exit code,
    run.json or None). close() stops a run still going (SIGTERM to its
    process group, then SIGKILL) and removes the pipe's folder.
"""
import json
import os
import shutil
import signal
import struct
import subprocess
import tempfile
import threading
import time

from analysis import afmlog, paths
from analysis.view import live

READY_WAIT_S = 60.0      # a run's start, or one action, at most (wall)
FRAME_WAIT_S = 15.0      # the display's frame after the card's block
END_WAIT_S = 120.0       # END to the run's exit (its fresh scan, run.json)


class SessionError(RuntimeError):
    pass


def parse_ready(detail):
    """The operator's "env: ready K seq=N ok=1 [k=v ...] [why=...]" as a dict."""
    words = detail.split()
    return dict(live.detail_fields(words, 3), k=int(words[2]))


class Session:
    def __init__(self, scene_path, out_dir, block_hz, frame_rate_hz):
        self.out_dir = out_dir
        self.blocks_per_frame = max(1, round(block_hz / frame_rate_hz))
        self._cv = threading.Condition()
        self._ready = {}         # K -> ready fields
        self._frames = []        # (seq, view_frame_t), newest last; the last few kept
        self._closed = False
        self._asked = 0
        self.proc = None
        self._dir = tempfile.mkdtemp(prefix="afm-env-")
        os.chmod(self._dir, 0o711)
        self.fifo = os.path.join(self._dir, "hand")
        os.mkfifo(self.fifo, 0o600)
        self._wfd = os.open(self.fifo, os.O_RDWR | os.O_NOFOLLOW)
        rfd, wfd = os.pipe()
        cmd = [paths.IN_NETNS, paths.LAUNCH, "--scene", scene_path, "--out", out_dir, "--quiet", "--no-verdict",
               "--view", "--view-fd", str(wfd)]
        env = dict(os.environ, AFM_HAND_FIFO=self.fifo, AFM_RUN_FILES=self.fifo)
        self._log = open(os.path.join(self._dir, "launch.log"), "w+")
        self.proc = subprocess.Popen(cmd, pass_fds=(wfd,), env=env, stdout=self._log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        os.close(wfd)
        self._reader = threading.Thread(target=self._read, args=(rfd,), daemon=True)
        self._reader.start()
        self.first = self._wait_ready(0)

    # --- the bridge's records (u32 channel length, channel, u32 size, payload)
    def _read(self, fd):
        with os.fdopen(fd, "rb", buffering=0) as f:
            def exactly(n):
                b = b""
                while len(b) < n:
                    c = f.read(n - len(b))
                    if not c:
                        raise EOFError
                    b += c
                return b
            try:
                while True:
                    (n,) = struct.unpack("<I", exactly(4))
                    if not 0 < n <= live.MAX_CHANNEL:
                        break
                    channel = exactly(n).decode("ascii", "replace")
                    (size,) = struct.unpack("<I", exactly(4))
                    if size > live.MAX_PAYLOAD:
                        break
                    self._take(channel, exactly(size))
            except EOFError:
                pass
        with self._cv:
            self._closed = True
            self._cv.notify_all()

    def _take(self, channel, data):
        tname = afmlog.CHANNELS.get(channel)
        try:
            m = getattr(afmlog.afm, tname).decode(data) if tname else None
        except (ValueError, struct.error, UnicodeDecodeError, MemoryError, OverflowError):
            return
        with self._cv:
            if channel == "VIEW_FRAME":
                self._frames = (self._frames + [(m.seq, m)])[-8:]
            elif channel == "AFM_HEARTBEAT" and m.name == "operator" and m.detail.startswith("env: ready "):
                r = parse_ready(m.detail)
                self._ready.setdefault(r["k"], r)
            else:
                return
            self._cv.notify_all()

    def _wait_ready(self, k):
        end = time.monotonic() + READY_WAIT_S
        with self._cv:
            while k not in self._ready:
                left = end - time.monotonic()
                if self._closed or left <= 0 or self.proc.poll() is not None:
                    raise SessionError(self._why_not(f"no 'env: ready {k}' from the operator"))
                self._cv.wait(min(left, 0.5))
            r = self._ready[k]
        return r, self._frame_for(r["seq"])

    def _frame_for(self, seq):
        """The display's newest frame at or before block seq (the run stands
        still there: none later can come)."""
        low = seq - self.blocks_per_frame
        end = time.monotonic() + FRAME_WAIT_S
        with self._cv:
            while True:
                fit = [m for s, m in self._frames if low < s <= seq]
                if fit or self._closed or time.monotonic() > end:
                    break
                self._cv.wait(0.05)
            if fit:
                return fit[-1]
            older = [m for s, m in self._frames if s <= seq]
            return older[-1] if older else None

    def _why_not(self, what):
        self._log.flush()
        self._log.seek(0)
        tail = self._log.read()[-600:].strip().replace("\n", " | ")
        code = self.proc.poll()
        return f"env: {what} (run {self.out_dir}, launcher {'running' if code is None else 'exit ' + str(code)}: {tail})"

    def act(self, line):
        self._asked += 1
        os.write(self._wfd, (line + "\n").encode())
        return self._wait_ready(self._asked)

    def end(self):
        """END: the run ends, its fresh scan judges it; (exit code, run.json)."""
        try:
            os.write(self._wfd, b"END\n")
        except OSError:
            pass
        try:
            code = self.proc.wait(timeout=END_WAIT_S)
        except subprocess.TimeoutExpired:
            self.close()
            code = self.proc.returncode
        try:
            with open(os.path.join(self.out_dir, "run.json")) as f:
                return code, json.load(f)
        except (OSError, ValueError):
            return code, None

    def close(self):
        if self.proc is not None and self.proc.poll() is None:
            for sig, wait in ((signal.SIGTERM, 10), (signal.SIGKILL, 5)):
                try:
                    os.killpg(self.proc.pid, sig)
                except ProcessLookupError:
                    break
                try:
                    self.proc.wait(timeout=wait)
                    break
                except subprocess.TimeoutExpired:
                    continue
        if self._wfd is not None:
            os.close(self._wfd)
            self._wfd = None
        self._log.close()
        shutil.rmtree(self._dir, ignore_errors=True)
