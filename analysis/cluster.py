"""A Dask cluster for ./afm sweep across machines, closed as the sweep's own
local cluster is (analysis/engine.py): TLS with mutual authentication, no
HTTP port, the project's package importable from the venv.

usage: .venv/bin/python -m analysis.cluster certs DIR
       .venv/bin/python -m analysis.cluster scheduler --host ADDR [--port P] --tls-dir DIR
       .venv/bin/python -m analysis.cluster worker tls://HOST:PORT [--host ADDR] [--nworkers N] --tls-dir DIR

  certs      writes the cluster's credentials into DIR (made 0700): ca.pem,
             cert.pem and key.pem (0600). Whoever holds key.pem is a member of
             the cluster and can run code as its workers' user: copy DIR only
             to the cluster's machines and to the users who run sweeps.
  scheduler  serves on tls://ADDR:PORT (default port 8786) and prints its
             address; ADDR is an address of this machine (127.0.0.1 when the
             cluster is one machine).
  worker     joins the scheduler with N single-threaded worker processes
             (default 1). A worker's machine needs this checkout, built, at
             the same path as the sweep's (the points run its programs).

  --tls-dir DIR            the folder certs wrote; or each file:
  --tls-ca, --tls-cert, --tls-key FILE
  --tls-fd FD              or the credentials as JSON text ({"ca", "cert",
                           "key"}: PEM) on an inherited descriptor, which a
                           started-as-root sweep hands each worker it starts
                           as a user of its own (analysis/sweep_users.py)

The sweep then runs with
  ./afm sweep SCENE --vary ... --scheduler tls://HOST:PORT \\
      --tls-ca DIR/ca.pem --tls-cert DIR/cert.pem --tls-key DIR/key.pem
Stop the scheduler and workers with Ctrl-C or SIGTERM."""
import argparse
import asyncio
import os
import signal
import sys

from analysis import engine


def write_certs(folder):
    """The cluster's CA, certificate and key (one self-signed identity, as
    Dask's Security.temporary makes), the key readable by its owner only."""
    from distributed import Security
    sec = Security.temporary()
    os.makedirs(folder, mode=0o700, exist_ok=True)
    os.chmod(folder, 0o700)
    files = {"ca.pem": sec.tls_ca_file, "cert.pem": sec.tls_client_cert, "key.pem": sec.tls_client_key}
    for name, text in files.items():
        path = os.path.join(folder, name)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.fchmod(fd, 0o600)   # before writing: an existing file keeps its old mode through O_CREAT
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.chmod(path, 0o600)
    return [os.path.join(folder, n) for n in files]


def tls_files(a):
    if a.tls_dir:
        return tuple(os.path.join(a.tls_dir, n) for n in ("ca.pem", "cert.pem", "key.pem"))
    return a.tls_ca, a.tls_cert, a.tls_key


async def _serve(node):
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    async with node:
        print(f"cluster: {type(node).__name__.lower().replace('quiet', '')} at {node.address}", flush=True)
        done = asyncio.ensure_future(node.finished())
        halt = asyncio.ensure_future(stop.wait())
        await asyncio.wait([done, halt], return_when=asyncio.FIRST_COMPLETED)
        for t in (done, halt):
            t.cancel()


async def _scheduler(host, port, sec):
    await _serve(engine.QuietScheduler(host=host, port=port, protocol="tls://", security=sec, dashboard=False,
                                       dashboard_address=None))


async def _workers(address, host, n, sec):
    from distributed import Nanny
    nannies = [Nanny(address, host=host, protocol="tls://", security=sec, nthreads=1,
                     worker_class=engine.QuietWorker, dashboard=False, dashboard_address=None) for _ in range(n)]
    await asyncio.gather(*(_serve(n) for n in nannies))


def parse(argv):
    p = argparse.ArgumentParser(prog="python -m analysis.cluster", usage=__doc__, add_help=False)
    p.add_argument("role", nargs="?", choices=["certs", "scheduler", "worker"])
    p.add_argument("where", nargs="?")
    p.add_argument("--host")
    p.add_argument("--port", type=int, default=8786)
    p.add_argument("--nworkers", type=int, default=1)
    p.add_argument("--tls-dir")
    p.add_argument("--tls-ca")
    p.add_argument("--tls-cert")
    p.add_argument("--tls-key")
    p.add_argument("--tls-fd", type=int)
    p.add_argument("-h", "--help", action="store_true")
    a = p.parse_args(argv)
    if a.help or not a.role:
        print(__doc__)
        sys.exit(0 if a.help else 2)
    return a


def main(argv):
    a = parse(argv)
    try:
        if a.role == "certs":
            if not a.where:
                raise engine.EngineError("certs: which folder?")
            for path in write_certs(a.where):
                print(f"cluster: wrote {path}")
            return 0
        sec = engine.read_credentials(a.tls_fd) if a.tls_fd is not None else engine.security_from_files(*tls_files(a))
        if a.role == "scheduler":
            if not a.host:
                raise engine.EngineError("scheduler: --host ADDR (an address of this machine) is needed")
            asyncio.run(_scheduler(a.host, a.port, sec))
        else:
            if not a.where:
                raise engine.EngineError("worker: the scheduler's address (tls://HOST:PORT) is needed")
            engine.parse_address(a.where)
            if a.nworkers < 1:
                raise engine.EngineError(f"--nworkers {a.nworkers}: at least 1")
            asyncio.run(_workers(a.where, a.host, a.nworkers, sec))
    except engine.EngineError as e:
        print(f"cluster: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
