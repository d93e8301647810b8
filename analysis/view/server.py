"""The page's HTTP server (docs/view.md): static files from this package's
static/ folder, and one WebSocket (/ws) per page, all behind a random token.

Contract:
- It listens only on the socket it is given (127.0.0.1; the caller opened
  it with listen(): live.py, __main__.py; a port that cannot be had is a
  ListenError in one line) and answers 403 to any request, HTTP or the
  WebSocket's, without the token (query `token`, compared in constant
  time), whose Host is not a loopback name with the page's port
  (127.0.0.1, localhost, [::1]: a DNS-rebound name is refused), or whose
  Origin, when it has one, is not the page's own (http:// and its Host):
  another site open in the same browser cannot reach the page.
- A malformed request gets aiohttp's 400 and one line on stderr, escaped
  (analysis/text.py), never a traceback.
- What it sends a page: JSON text messages, each frame's image as the binary
  message that follows its "frame" message. What it takes from a page:
  JSON text only ({"type": "seek", "index": K} in a recorded run); nothing
  from the network is unpickled or evaluated.
- A page gets the newest frame, at most MAX_PAGE_FPS a second on average
  (a token bucket of PAGE_BURST frames: a frame that comes early after a
  late one, the wall clock's jitter, goes at once): a frame that comes
  while the page's previous one is still being sent, or while the bucket is
  empty, replaces the one waiting, and is counted (`skipped_server`); the
  strip chart's samples of a skipped frame go with the next one. No page ever slows a source down. (A person sees no more;
  a lockstep run makes frames ten times faster than real time, and a
  browser that decoded and painted them all took the CPU the run's
  lockstep needed: docs/view.md.)
"""
import asyncio
import errno
import hmac
import json
import logging
import os
import secrets
import socket
import sys
import time

from aiohttp import WSMsgType, web

from analysis.text import printable

STATIC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "static")
STATIC_FILES = {"/": ("index.html", "text/html"), "/view.js": ("view.js", "text/javascript"),
                "/view.css": ("view.css", "text/css")}
MAX_CLIENT_MESSAGE = 4096   # bytes: a page sends only small JSON messages
MAX_PAGE_FPS = 30           # frames a second sent to one page, at most (on average)
PAGE_BURST = 2              # frames the rate may run ahead by (_send_loop's bucket)
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")   # the Host names a page may use, with the page's port


class ListenError(OSError):
    """The page's port cannot be had (its message, one line, says why)."""


class _OneLine(logging.Handler):
    """aiohttp's server log (a malformed request: a traceback with the
    request's own bytes) as one escaped line on stderr."""

    def emit(self, record):
        what = record.getMessage()
        if record.exc_info and record.exc_info[1] is not None:
            what += ": " + " ".join(str(record.exc_info[1]).split())
        print(f"view: {printable(what)[:300]}", file=sys.stderr, flush=True)


def _server_log():
    log = logging.getLogger("afm.view.server")
    if not log.handlers:
        log.addHandler(_OneLine())
        log.propagate = False
    return log


def new_token():
    """A random token for the page's URL (128 bits, URL-safe)."""
    return secrets.token_urlsafe(16)


class Client:
    """One page: what waits to be sent to it, newest frame only."""

    def __init__(self, ws):
        self.ws = ws
        self.messages = []        # JSON messages, in order
        self.frame = None         # (meta, image bytes): the newest frame not yet sent
        self.samples = []         # the samples of frames replaced before they were sent
        self.skipped = 0
        self.wake = asyncio.Event()

    def put_frame(self, meta, image):
        if self.frame is not None:
            self.skipped += 1
            self.samples.append(self.frame[0].get("samples"))
        self.frame = (meta, image)
        self.wake.set()

    def put(self, message):
        self.messages.append(message)
        self.wake.set()

    def take_frame(self):
        meta, image = self.frame
        self.frame = None
        if self.samples:
            meta = dict(meta, samples=merge_samples(self.samples + [meta.get("samples")]))
            self.samples = []
        return dict(meta, skipped_server=self.skipped), image


def merge_samples(parts):
    """Sample series {name: [..]} joined in order (None parts left out)."""
    out = {}
    for p in parts:
        for k, v in (p or {}).items():
            out.setdefault(k, []).extend(v)
    return out


class ViewServer:
    """The aiohttp application of the page, fed by a source (live or
    recorded) through broadcast_* and answering pages with source.hello()
    and source.on_message()."""

    def __init__(self, token, source):
        self.token = token
        self.source = source
        self.port = None                   # the page's port, once start() has its socket
        self.clients = set()
        self.connected = asyncio.Event()   # a page with the right token opened its stream
        self.app = web.Application(middlewares=[self._check_token])
        for path in STATIC_FILES:
            self.app.router.add_get(path, self._static)
        self.app.router.add_get("/ws", self._ws)
        self.runner = None

    @web.middleware
    async def _check_token(self, request, handler):
        refused = self.refusal(request.headers.get("Host"), request.headers.get("Origin"), request.query.get("token", ""))
        if refused:
            return web.Response(status=403, text=f"afm view: {refused}\n")
        return await handler(request)

    def refusal(self, host, origin, token):
        """Why a request with these Host, Origin (None: none) and token is
        refused, or None (the module's contract)."""
        if not hmac.compare_digest(token.encode(), self.token.encode()):
            return "wrong or missing token"
        own = {f"{name}:{self.port}" for name in LOOPBACK_NAMES}
        if host is None or host.lower() not in own:
            return "wrong Host (the page answers to 127.0.0.1, localhost or [::1] with its port)"
        if origin is not None and origin.lower() != "http://" + host.lower():
            return "wrong Origin (only the page itself may ask)"
        return None

    async def _static(self, request):
        name, ctype = STATIC_FILES[request.path]
        with open(os.path.join(STATIC, name), "rb") as f:
            body = f.read()
        if name == "index.html":   # its script and style sheet carry the token too
            body = body.replace(b"@TOKEN@", self.token.encode())
        return web.Response(body=body, content_type=ctype, headers={"Cache-Control": "no-store"})

    async def _ws(self, request):
        ws = web.WebSocketResponse(max_msg_size=MAX_CLIENT_MESSAGE, heartbeat=10)
        await ws.prepare(request)
        client = Client(ws)
        client.put(self.source.hello())
        self.clients.add(client)
        self.connected.set()
        sender = asyncio.ensure_future(self._send_loop(client))
        try:
            async for msg in ws:
                if msg.type == WSMsgType.TEXT:
                    await self._on_text(client, msg.data)
                elif msg.type == WSMsgType.BINARY:
                    break   # a page sends no binary
        finally:
            self.clients.discard(client)
            sender.cancel()
        return ws

    async def _on_text(self, client, text):
        try:
            msg = json.loads(text)
        except ValueError:
            return
        if isinstance(msg, dict):
            reply = self.source.on_message(msg)
            if reply is not None:
                client.put_frame(*reply)

    async def _send_loop(self, client):
        loop = asyncio.get_running_loop()
        credit, credit_t = float(PAGE_BURST), loop.time()   # the frames the page may have now, and when counted
        try:
            while not client.ws.closed:
                await client.wake.wait()
                client.wake.clear()
                while client.messages:
                    await client.ws.send_str(json.dumps(client.messages.pop(0)))
                if client.frame is None:
                    continue
                now = loop.time()
                credit, credit_t = min(float(PAGE_BURST), credit + (now - credit_t) * MAX_PAGE_FPS), now
                if credit < 1:   # too soon: the newest frame when the bucket has one
                    loop.call_at(now + (1 - credit) / MAX_PAGE_FPS, client.wake.set)
                    continue
                credit -= 1
                meta, image = client.take_frame()
                meta["t_tx_ms"] = time.time() * 1e3   # ./afm bench view's stages: sent
                await client.ws.send_str(json.dumps(meta))
                await client.ws.send_bytes(image)
        except (ConnectionResetError, RuntimeError):
            pass

    def broadcast(self, message):
        for c in list(self.clients):
            c.put(message)

    def broadcast_frame(self, meta, image):
        for c in list(self.clients):
            c.put_frame(meta, image)

    async def start(self, sock):
        """Serves on the listening socket `sock` (already bound)."""
        self.port = sock.getsockname()[1]
        self.runner = web.AppRunner(self.app, access_log=None, handle_signals=False, logger=_server_log())
        await self.runner.setup()
        await web.SockSite(self.runner, sock).start()

    async def stop(self, linger_s=0.5):
        """Lets the pages take what waits (at most linger_s), then closes."""
        end = asyncio.get_running_loop().time() + linger_s
        while any(c.messages or c.frame for c in self.clients) and asyncio.get_running_loop().time() < end:
            await asyncio.sleep(0.05)
        for c in list(self.clients):
            await c.ws.close()
        if self.runner:
            await self.runner.cleanup()


def listen(port=0):
    """A TCP socket listening on 127.0.0.1:port (0: any free port);
    ListenError, one line, when that port cannot be had (not a port number,
    held by another process, or below 1024 without the right)."""
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ListenError(f"view: --port {printable(str(port))}: a port is a whole number from 0 (any free one) to 65535")
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind(("127.0.0.1", port))
        s.listen(16)
    except OSError as e:
        s.close()
        held = " (another process, perhaps another user's, listens there)" if e.errno == errno.EADDRINUSE else ""
        raise ListenError(f"view: --port {port}: cannot listen on 127.0.0.1:{port}: {e.strerror}{held}") from None
    s.setblocking(False)
    return s


def url(sock, token):
    """The page's address, with its token."""
    return f"http://127.0.0.1:{sock.getsockname()[1]}/?token={token}"
