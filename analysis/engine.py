"""The sweep's engine: Dask distributed, closed to anyone without the sweep's
credentials.

A Dask scheduler runs whatever a client submits, and its workers run it, as
the user who started them (root, on a bench set up as the README says). So:

- Every connection is TLS with mutual authentication: a scheduler, worker or
  client must present a certificate signed by the cluster's CA. The local
  cluster of a sweep makes its credentials for that sweep
  (Security.temporary(): in memory, never on disk) and binds 127.0.0.1.
  An existing cluster is reached with the files given by --tls-ca,
  --tls-cert and --tls-key; a plain tcp:// address is refused unless
  --insecure is given.
- No HTTP server listens: Dask's scheduler and workers open one even with
  the dashboard off (its health and metrics routes, port 8787 for the
  scheduler); QuietScheduler and QuietWorker open none.
- The sweep's client unpickles nothing its peers send of their own accord:
  it deserializes results with msgpack only (SAFE_DESERIALIZERS), a point's
  result comes back as JSON text (result_of, results_of), and anything else is refused;
  the client's own unpickling of a task's type, a task's exception and warn
  events is closed (harden_client). Dask's protocol layer still unpickles a
  message's pickled sub-frames and an RPC's error reply; those can come
  only from a peer that holds the cluster's TLS credentials.
  The one stated exception: workers unpickle the tasks that the
  credentialed client sends them.
- Who holds the key of a local cluster. Started as root, the sweep's root
  process makes the credentials (Security.temporary()) and hands them, as
  PEM text on an inherited pipe (read_credentials), to the client and
  scheduler, a uid leased for the sweep, and to each worker (a nanny and its
  worker), a uid leased for it (analysis/sweep_users.py). Each holds the key
  in its own memory, which no other uid can read; Dask loads it through a
  file of a temporary folder (0700) in the process's own TMPDIR, its scratch
  folder (0700, its uid's). It never lies in a file another uid can read,
  nor on a command line. Not root: every process is the caller.

`python -m analysis.cluster` starts a scheduler and workers of this kind on
other machines (docs/sweeps.md)."""
import concurrent.futures
import json
import os
import socket
import ssl
from urllib.parse import urlsplit

SAFE_DESERIALIZERS = ["msgpack", "error"]   # 'error' only raises; no pickle, no 'dask' (its headers are pickled)
# A --scheduler address is judged within 10 s of the command's start: the
# name resolved, the port connected, then Dask's handshake, each bounded.
RESOLVE_TIMEOUT_S = 2.0
TCP_TIMEOUT_S = 2.0
CLIENT_TIMEOUT_S = 5.0


class EngineError(Exception):
    """A cluster that cannot be used, named in one line."""


def _no_http_server(self, routes, dashboard_address, default_port=0, ssl_options=None):
    """Dask's start_http_server without the listening socket: the node keeps
    an HTTPServer object (its shutdown stops it) that never binds a port."""
    from distributed.http.routing import RoutingApplication
    from tornado.httpserver import HTTPServer
    self.http_application = RoutingApplication([])
    self.http_server = HTTPServer(self.http_application)


def _quiet_classes():
    from distributed import Scheduler, Worker

    class QuietScheduler(Scheduler):
        """A scheduler with no HTTP port (no dashboard, no health or metrics route)."""
        start_http_server = _no_http_server

    class QuietWorker(Worker):
        """A worker with no HTTP port."""
        start_http_server = _no_http_server

    return QuietScheduler, QuietWorker


QuietScheduler, QuietWorker = _quiet_classes()
QuietScheduler.__module__ = QuietWorker.__module__ = __name__   # importable by name in a worker's process
QuietScheduler.__qualname__, QuietWorker.__qualname__ = "QuietScheduler", "QuietWorker"


def security_from_files(ca, cert, key):
    """A Security requiring TLS with the given PEM files, each checked first
    (named when missing or unreadable)."""
    from distributed import Security
    for flag, path in (("--tls-ca", ca), ("--tls-cert", cert), ("--tls-key", key)):
        if not path:
            raise EngineError(f"{flag}: missing (a TLS cluster needs --tls-ca, --tls-cert and --tls-key)")
        try:
            with open(path, "rb") as f:
                head = f.read(64)
        except OSError as e:
            raise EngineError(f"{flag} {path}: {e.strerror}") from None
        if b"-----BEGIN" not in head:
            raise EngineError(f"{flag} {path}: not a PEM file")
    try:
        ssl.create_default_context(cafile=ca).load_cert_chain(cert, key)
    except (ssl.SSLError, ValueError) as e:
        raise EngineError(f"--tls-cert {cert} / --tls-key {key}: {e}") from None
    return Security(tls_ca_file=ca, tls_client_cert=cert, tls_client_key=key, tls_scheduler_cert=cert,
                    tls_scheduler_key=key, tls_worker_cert=cert, tls_worker_key=key, require_encryption=True)


def parse_address(address, insecure=False):
    """(scheme, host, port) of tls://HOST:PORT (tcp:// only with insecure);
    a malformed address is named."""
    if not isinstance(address, str) or "://" not in address:
        raise EngineError(f"--scheduler {address!r}: not an address of the form tls://HOST:PORT")
    try:
        u = urlsplit(address)
        port = u.port
    except ValueError as e:
        raise EngineError(f"--scheduler {address!r}: {e}") from None
    if u.scheme not in ("tls", "tcp"):
        raise EngineError(f"--scheduler {address!r}: the scheme must be tls:// (or tcp:// with --insecure)")
    if not u.hostname or port is None or u.path not in ("", "/") or u.query or u.username:
        raise EngineError(f"--scheduler {address!r}: not an address of the form tls://HOST:PORT")
    if u.scheme == "tcp" and not insecure:
        raise EngineError(f"--scheduler {address}: a plain tcp:// cluster runs code for anyone who reaches it; "
                          f"use tls:// with --tls-ca, --tls-cert and --tls-key, or say --insecure")
    return u.scheme, u.hostname, port


def _reachable(address, host, port):
    """Names an unknown host or a port that does not answer, within the timeout."""
    pool = concurrent.futures.ThreadPoolExecutor(1)
    try:
        infos = pool.submit(socket.getaddrinfo, host, port, type=socket.SOCK_STREAM).result(RESOLVE_TIMEOUT_S)
    except socket.gaierror as e:
        raise EngineError(f"--scheduler {address}: unknown host {host!r} ({e.strerror})") from None
    except concurrent.futures.TimeoutError:
        raise EngineError(f"--scheduler {address}: unknown host {host!r} (no answer from the resolver in "
                          f"{RESOLVE_TIMEOUT_S:.0f} s)") from None
    finally:
        pool.shutdown(wait=False)
    last = None
    for family, kind, proto, _, addr in infos[:2]:
        try:
            with socket.socket(family, kind, proto) as s:
                s.settimeout(TCP_TIMEOUT_S)
                s.connect(addr)
                return
        except OSError as e:
            last = e
    why = "no answer" if isinstance(last, socket.timeout) else (last.strerror or str(last))
    raise EngineError(f"--scheduler {address}: the scheduler does not answer ({why})")


def connect(address, tls_ca=None, tls_cert=None, tls_key=None, insecure=False):
    """A Client of an existing cluster, or EngineError in one line within 10 s."""
    from distributed import Client
    harden_client()
    scheme, host, port = parse_address(address, insecure)
    security = security_from_files(tls_ca, tls_cert, tls_key) if scheme == "tls" else None
    _reachable(address, host, port)
    try:
        kw = {"security": security} if security else {}
        return Client(address, timeout=CLIENT_TIMEOUT_S, deserializers=SAFE_DESERIALIZERS, **kw)
    except Exception as e:   # Dask raises OSError, TimeoutError, ssl and comm errors with long chains
        why = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise EngineError(f"--scheduler {address}: cannot connect: {why[:200]}") from None


def credentials_of(sec):
    """{"ca", "cert", "key"}: the PEM text of a Security made by
    Security.temporary(), to hand to a worker through a pipe."""
    return {"ca": sec.tls_ca_file, "cert": sec.tls_client_cert, "key": sec.tls_client_key}


def read_credentials(fd):
    """A Security requiring TLS with the PEM text read (as JSON, credentials_of's)
    from descriptor fd, which is closed: credentials that never lie in a file
    or on a command line."""
    from distributed import Security
    with os.fdopen(fd, "r") as f:
        try:
            d = json.load(f)
            ca, cert, key = (d[k] for k in ("ca", "cert", "key"))
        except (ValueError, KeyError, TypeError) as e:
            raise EngineError(f"the credentials on descriptor {fd} are not the cluster's ({type(e).__name__})") from None
    return Security(tls_ca_file=ca, tls_client_cert=cert, tls_client_key=key, tls_scheduler_cert=cert,
                    tls_scheduler_key=key, tls_worker_cert=cert, tls_worker_key=key, require_encryption=True)


def _scheduler_spec(sec):
    """A SpecCluster's scheduler: QuietScheduler on 127.0.0.1, TLS with `sec`, no dashboard."""
    return {"cls": QuietScheduler, "options": {"host": "127.0.0.1", "protocol": "tls://", "security": sec,
                                               "dashboard": False, "dashboard_address": None}}


def _client_of(cluster, sec):
    """(client, cluster): a client of `cluster` that deserializes nothing but
    SAFE_DESERIALIZERS; the cluster closed if the client cannot be made."""
    from distributed import Client
    try:
        client = Client(cluster, security=sec, deserializers=SAFE_DESERIALIZERS)
    except BaseException:
        cluster.close()
        raise
    return client, cluster


def scheduler_alone(sec):
    """(client, cluster): the scheduler of a local cluster on 127.0.0.1 in
    this process, TLS with `sec`, no worker and no HTTP port; the workers,
    started by whoever holds the same credentials, join it at
    cluster.scheduler_address (analysis/sweep_users.py)."""
    from distributed import SpecCluster
    harden_client()
    scheduler = _scheduler_spec(sec)
    cluster = SpecCluster(scheduler=scheduler, workers={}, security=sec, silence_logs=40)
    return _client_of(cluster, sec)


def local_cluster(n_workers):
    """(client, cluster): n single-threaded worker processes and a scheduler
    on 127.0.0.1, TLS with credentials made for this cluster alone, no HTTP
    port anywhere."""
    from distributed import Nanny, Security, SpecCluster
    harden_client()
    sec = Security.temporary()
    scheduler = _scheduler_spec(sec)
    worker = {"cls": Nanny, "options": {"host": "127.0.0.1", "protocol": "tls://", "security": sec, "nthreads": 1,
                                        "worker_class": QuietWorker, "dashboard": False, "dashboard_address": None,
                                        "silence_logs": 40}}
    cluster = SpecCluster(scheduler=scheduler, workers={i: worker for i in range(n_workers)}, worker=worker,
                          security=sec, silence_logs=40)
    return _client_of(cluster, sec)


def _answer_of(future):
    """A finished future's answer: JSON text, parsed. Anything else a worker
    sends back (a pickled object above all) is refused unread."""
    try:
        text = future.result()
    except Exception as e:
        raise EngineError(f"the worker's answer was refused: {str(e).splitlines()[0][:200] if str(e) else type(e).__name__}") \
            from None
    if not isinstance(text, str):
        raise EngineError(f"the worker's answer was refused: a {type(text).__name__}, not JSON text")
    try:
        return json.loads(text)
    except ValueError as e:
        raise EngineError(f"the worker's answer was refused: not JSON ({e})") from None


def result_of(future):
    """A point's record from its future: a JSON object (_answer_of)."""
    rec = _answer_of(future)
    if not isinstance(rec, dict):
        raise EngineError("the worker's answer was refused: not a JSON object")
    return rec


def results_of(future):
    """A batch's records from its future: a JSON list of objects, or one
    object (_answer_of)."""
    recs = _answer_of(future)
    recs = [recs] if isinstance(recs, dict) else recs
    if not isinstance(recs, list) or not all(isinstance(r, dict) for r in recs):
        raise EngineError("the worker's answer was refused: not a JSON object or a list of them")
    return recs


class _NoLoads:
    """The stdlib pickle module for distributed.client, less loads."""

    def __init__(self, real):
        self._real = real

    def __getattr__(self, name):
        if name in ("loads", "load", "Unpickler"):
            return _refuse_loads
        return getattr(self._real, name)


def _refuse_loads(*_args, **_kwargs):
    raise EngineError("refused to unpickle data received from the cluster")


def _opaque_exception(exception=None, traceback=None, **kwargs):
    """clean_exception for the client: a task's exception is named by the
    text the worker sent beside it (exception_text), never unpickled."""
    text = str(kwargs.get("exception_text") or "").strip()
    first = text.splitlines()[0][:300] if text else "its exception was sent pickled and is not read"
    return EngineError, EngineError(f"the task failed on its worker: {first}"), None


def harden_client():
    """Dask's client unpickles what the cluster sends it on three side paths
    besides results: a finished task's type (_handle_key_in_memory), a
    failed task's exception and traceback (clean_exception), and 'warn'
    events (_handle_warn). In this process they read as refused or as text.
    The scheduler and nannies of a local cluster, which share the process,
    keep their own imports and are untouched."""
    import distributed.client as dc
    dc.loads = _refuse_loads
    dc.clean_exception = _opaque_exception
    if not isinstance(dc.pickle, _NoLoads):
        dc.pickle = _NoLoads(dc.pickle)
