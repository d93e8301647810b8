"""The page's HTTP server (docs/view.md): static files from this package's
static/ folder, and one WebSocket (/ws) per page, all behind a random token.

Contract:
- It listens only on the socket it is given (127.0.0.1; the caller opened
  it: live.py, __main__.py) and answers 403 to any request without the
  token (query `token`, compared in constant time).
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
import hmac
import json
import os
import secrets
import time

from aiohttp import WSMsgType, web

STATIC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "static")
STATIC_FILES = {"/": ("index.html", "text/html"), "/view.js": ("view.js", "text/javascript"),
                "/view.css": ("view.css", "text/css")}
MAX_CLIENT_MESSAGE = 4096   # bytes: a page sends only small JSON messages
MAX_PAGE_FPS = 30           # frames a second sent to one page, at most (on average)
PAGE_BURST = 2              # frames the rate may run ahead by (_send_loop's bucket)


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
        self.clients = set()
        self.connected = asyncio.Event()   # a page with the right token opened its stream
        self.app = web.Application(middlewares=[self._check_token])
        for path in STATIC_FILES:
            self.app.router.add_get(path, self._static)
        self.app.router.add_get("/ws", self._ws)
        self.runner = None

    @web.middleware
    async def _check_token(self, request, handler):
        given = request.query.get("token", "")
        if not hmac.compare_digest(given.encode(), self.token.encode()):
            return web.Response(status=403, text="afm view: wrong or missing token\n")
        return await handler(request)

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
        self.runner = web.AppRunner(self.app, access_log=None, handle_signals=False)
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
    """A TCP socket listening on 127.0.0.1:port (0: any free port)."""
    import socket
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    s.bind(("127.0.0.1", port))
    s.listen(16)
    s.setblocking(False)
    return s


def url(sock, token):
    """The page's address, with its token."""
    return f"http://127.0.0.1:{sock.getsockname()[1]}/?token={token}"
