"""Who a sweep's processes are when it is started as root with its local
cluster (issue 46, item 2; docs/design.md, "Least privilege").

Root (this module, in the sweep's first process) leases uids of the runs'
range through the one owner of leases, run/run_uid.sh lease: one for the
client and scheduler, one per worker. It then starts, each through
run/drop_caps.sh (no capability, no_new_privs, rlimits):

- the client and scheduler: `python -m analysis.sweep ARGS` again, as the
  first uid, whose scheduler (analysis/engine.py, scheduler_alone) binds
  127.0.0.1 and says its address back on a pipe;
- each worker: `python -m analysis.cluster worker tls://127.0.0.1:PORT
  --tls-fd FD`, a Dask nanny and the worker it spawns, as a uid of its own,
  with the scheduler's gid as its one supplementary group (so that it may
  write its points into the sweep's folder, `points/` being that group's,
  setgid, group-writable; umask 002).

The cluster's TLS credentials (Security.temporary(), made here) reach each
of them as JSON text on an inherited pipe, read once and closed: they never
lie in a file, nor on a command line. Who holds the key: root's process,
the client and scheduler, each nanny and its worker, each in its own memory,
which no other uid may read (/proc/PID/mem needs the same uid); Dask loads
the in-memory key through a file of a 0700 folder of the process's own
(TMPDIR: its scratch below).

Each process has a scratch folder of its own (0700, its uid's: HOME, TMPDIR,
Dask's temporary directory) under one root folder (0711); a worker's points
run with HOME and TMPDIR in `point/` of it, emptied before and removed after
each point (analysis/point.py). Points go through run/in_netns.sh as the
worker's uid (not root: a user namespace of that uid's own).

When the client ends, however (its exit, Ctrl-C, SIGTERM or SIGHUP to root,
which passes them on), the workers are stopped, every process left of the
leased uids is killed, the sweep's folder is given back (run/run_user.sh
take), the scratch removed, and then the lease ended. Without a range
reserved, or with AFM_RUN_USER set, every process is that one user
(nobody unless AFM_RUN_USER names another: the documented fallback, said in
one line when it is not asked for)."""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from analysis import engine, paths, point

RUN_UID = paths.RUN_UID
STOP_GRACE_S = 10.0
USERS_ENV = "AFM_SWEEP_USERS"      # the client's: {"scheduler", "workers", "lease"}
TLS_FD_ENV = "AFM_SWEEP_TLS_FD"    # the client's: its credentials' descriptor
ADDRESS_FD_ENV = "AFM_SWEEP_ADDRESS_FD"   # the client's: where it writes its scheduler's address


class UsersError(Exception):
    """The sweep's users cannot be had, named in one line."""


class Lease:
    """n uids leased through run/run_uid.sh lease, held until release()
    (or until this process dies: the holder's input ends)."""

    def __init__(self, n):
        self.proc = subprocess.Popen([RUN_UID, "lease", str(n)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self.uids = [int(x) for x in self.proc.stdout.read().split()]
        if len(self.uids) != n:
            err = self.proc.stderr.read().strip()
            self.proc.wait()
            raise UsersError(err or f"run/run_uid.sh lease {n}: exit {self.proc.returncode}")
        self.range = subprocess.run([RUN_UID, "range"], capture_output=True, text=True).stdout.split()

    def release(self):
        self.proc.stdin.close()
        self.proc.wait()


def choose(n_workers):
    """(lease or None, [(uid, gid)] of the scheduler and each worker, the
    fallback's line or None); None for the list when that user is root."""
    if not os.environ.get("AFM_RUN_USER") and subprocess.run([RUN_UID, "range"], capture_output=True).returncode == 0:
        lease = Lease(1 + n_workers)
        return lease, [(u, u) for u in lease.uids], None
    p = subprocess.run([paths.RUN_USER, "id"], capture_output=True, text=True)
    if p.returncode != 0:
        raise UsersError(p.stderr.strip())
    uid, gid = (int(v) for v in p.stdout.split())
    if uid == 0:
        return None, None, None
    said = None if os.environ.get("AFM_RUN_USER") else (
        f"sweep: no range of uids reserved for runs (tools/setup.sh): the scheduler and every worker are uid {uid}, "
        f"the documented fallback (docs/design.md, \"Least privilege\")")
    return None, [(uid, gid)] * (1 + n_workers), said


def _give(folder, uid, gid):
    p = subprocess.run([paths.RUN_USER, "give", folder], capture_output=True, text=True,
                       env=dict(os.environ, AFM_RUN_USER=f"{uid}:{gid}"))
    if p.returncode != 0:
        raise UsersError(p.stderr.strip().removeprefix("run_user: "))


def make_scratch(users):
    """The scratch root (0711) and a folder of each user's (0700, theirs):
    home/, tmp/, dask/ in each. Returns (root, [folder])."""
    root = tempfile.mkdtemp(prefix="afm-sweep-")
    os.chmod(root, 0o711)
    folders = []
    for i, (uid, gid) in enumerate(users):
        d = os.path.join(root, "scheduler" if i == 0 else f"worker-{i - 1}")
        for sub in ("home", "tmp", "dask"):
            os.makedirs(os.path.join(d, sub))
        os.chmod(d, 0o700)
        _give(d, uid, gid)
        folders.append(d)
    return root, folders


def open_points(out, sched):
    """`out` the scheduler's, its points/ also writable by the workers
    (their supplementary group: the scheduler's gid), setgid so that what
    they make there stays that group's."""
    points = os.path.join(out, "points")
    os.makedirs(points, exist_ok=True)
    _give(out, *sched)
    for top, dirs, files in os.walk(points):
        os.chmod(top, 0o2775)
        for f in files:
            path = os.path.join(top, f)
            if not os.path.islink(path):
                os.chmod(path, os.stat(path).st_mode & 0o777 | 0o060)


def env_of(folder, uid, gid, groups=None, **extra):
    env = dict(os.environ, AFM_RUN_UID=str(uid), AFM_RUN_GID=str(gid), HOME=f"{folder}/home", TMPDIR=f"{folder}/tmp",
               DASK_TEMPORARY_DIRECTORY=f"{folder}/dask", MPLCONFIGDIR=f"{folder}/home/.matplotlib",
               XDG_CACHE_HOME=f"{folder}/home/.cache", USER=f"afm-run-{uid}", LOGNAME=f"afm-run-{uid}", **extra)
    env.pop("AFM_RUN_GROUPS", None)
    if groups:
        env["AFM_RUN_GROUPS"] = groups
    return env


def _pipe_with(text):
    """The read end of a pipe that holds `text` (written and closed here)."""
    r, w = os.pipe()
    with os.fdopen(w, "w") as f:
        f.write(text)
    return r


def start_client(argv, folder, user, users_rec, creds, sizes, n_workers):
    """The client and scheduler as the scheduler's uid; (process, address
    pipe's read end)."""
    tls_r = _pipe_with(json.dumps(creds))
    addr_r, addr_w = os.pipe()
    env = env_of(folder, *user, **{USERS_ENV: json.dumps(users_rec), TLS_FD_ENV: str(tls_r), ADDRESS_FD_ENV: str(addr_w),
                                   "AFM_SWEEP_ARM_SIZES": json.dumps(sizes), "AFM_SWEEP_WORKERS": str(n_workers)})
    try:
        proc = subprocess.Popen([paths.DROP_CAPS, sys.executable, "-m", "analysis.sweep", *argv], env=env,
                                pass_fds=(tls_r, addr_w))
    finally:
        os.close(tls_r)
        os.close(addr_w)
    return proc, addr_r


def start_worker(address, folder, user, group, creds):
    tls_r = _pipe_with(json.dumps(creds))
    env = env_of(folder, *user, groups=str(group) if group != user[1] else None,
                 **{point.POINT_SCRATCH_ENV: f"{folder}/point", "DASK_LOGGING__DISTRIBUTED": "critical"})
    try:
        return subprocess.Popen([paths.DROP_CAPS, sys.executable, "-m", "analysis.cluster", "worker", address,
                                 "--host", "127.0.0.1", "--tls-fd", str(tls_r)], env=env, pass_fds=(tls_r,),
                                stdout=subprocess.DEVNULL, umask=0o002, cwd=paths.ROOT)
    finally:
        os.close(tls_r)


def read_address(addr_r, client):
    """The scheduler's address, as the client writes it; '' if the client
    ended first."""
    with os.fdopen(addr_r) as f:
        line = f.readline().strip()
    return line if line.startswith("tls://127.0.0.1:") and client.poll() is None else ""


def stop(procs, uids):
    """SIGTERM to each process, SIGKILL after STOP_GRACE_S; then SIGKILL to
    every process left of `uids` (leased: none but the sweep's), until none."""
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    t0 = time.monotonic()
    for p in procs:
        try:
            p.wait(timeout=max(0.1, STOP_GRACE_S - (time.monotonic() - t0)))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    for _ in range(50):
        left = [pid for pid in _pids_of(uids)]
        if not left:
            return
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        time.sleep(0.1)


def _pids_of(uids):
    """The pids whose real, effective, saved or filesystem uid is one of `uids`."""
    out = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/status") as f:
                for line in f:
                    if line.startswith("Uid:"):
                        if set(int(x) for x in line.split()[1:]) & uids:
                            out.append(int(d))
                        break
        except OSError:
            continue
    return out


def run(argv, n_workers, out, sizes):
    """The sweep as its users (the module's contract): returns the client's
    exit code, or None when the sweep goes on as root (the run's user is
    root, or cannot reach the checkout or `out`: said on stderr)."""
    lease, users, said = choose(n_workers)
    if users is None:
        return None
    if said:
        print(said, file=sys.stderr)
    scratch, procs = None, []
    for sig in (signal.SIGTERM, signal.SIGHUP):   # passed on; the sweep then ends as below
        signal.signal(sig, lambda s, _f: [p.send_signal(s) for p in procs if p.poll() is None])
    signal.signal(signal.SIGINT, lambda _s, _f: None)   # Ctrl-C reaches every process of the terminal's group
    try:
        p = subprocess.run([paths.RUN_USER, "reach", paths.ROOT, os.getcwd(), sys.executable], capture_output=True,
                           text=True, env=dict(os.environ, AFM_RUN_USER="%d:%d" % users[0]))
        if p.returncode != 0:
            print(f"sweep: warning: the sweep and its workers stay root: {p.stderr.strip().removeprefix('run_user: ')}",
                  file=sys.stderr)
            return None
        os.makedirs(out, exist_ok=True)
        try:
            open_points(out, users[0])
            scratch, folders = make_scratch(users)
        except UsersError as e:
            print(f"sweep: warning: the sweep and its workers stay root: {e}", file=sys.stderr)
            return None
        return _serve(argv, n_workers, users, folders, lease, sizes, procs)
    finally:
        stop(procs, {u for u, _ in users} if lease else set())
        subprocess.run([paths.RUN_USER, "take", out], capture_output=True)
        if scratch:
            shutil.rmtree(scratch, ignore_errors=True)
        if lease:
            lease.release()


def _serve(argv, n_workers, users, folders, lease, sizes, procs):
    """Starts the client and scheduler, then the workers once the scheduler
    has said its address (each appended to procs); the client's exit code."""
    from distributed import Security
    creds = engine.credentials_of(Security.temporary())
    rec = {"scheduler": users[0][0], "workers": [u for u, _ in users[1:]],
           "lease": ":".join(lease.range) if lease else None}
    client, addr_r = start_client(argv, folders[0], users[0], rec, creds, sizes, n_workers)
    procs.append(client)
    address = read_address(addr_r, client)
    if address:
        for user, folder in zip(users[1:], folders[1:]):
            procs.append(start_worker(address, folder, user, users[0][1], creds))
    code = client.wait()
    return 128 - code if code < 0 else code   # a signal's end as a shell says it


# The client's side: started by run() above, as the scheduler's uid.
WORKERS_JOIN_S = 120.0


def serve_scheduler(n_workers):
    """(client, cluster): the scheduler, in this process, TLS with the
    credentials root handed over on TLS_FD_ENV; its address written on
    ADDRESS_FD_ENV; once n_workers have joined. EngineError if they do not
    within WORKERS_JOIN_S."""
    sec = engine.read_credentials(int(os.environ.pop(TLS_FD_ENV)))
    client, cluster = engine.scheduler_alone(sec)
    try:
        with os.fdopen(int(os.environ.pop(ADDRESS_FD_ENV)), "w") as f:
            f.write(cluster.scheduler_address + "\n")
        client.wait_for_workers(n_workers, timeout=WORKERS_JOIN_S)
    except (TimeoutError, OSError) as e:
        client.close()
        cluster.close()
        raise engine.EngineError(f"the {n_workers} worker(s) did not join the sweep's scheduler in {WORKERS_JOIN_S:.0f} s "
                                 f"({type(e).__name__})") from None
    return client, cluster


def record(points, remote):
    """sweep.json "users": the uid of the scheduler (None: a remote
    cluster's), of each worker, and the lease's range ("FIRST:COUNT", or
    None when the uids were not leased)."""
    if USERS_ENV in os.environ:
        return json.loads(os.environ[USERS_ENV])
    workers = sorted({p["worker_uid"] for p in points if p.get("worker_uid") is not None})
    return {"scheduler": None if remote else os.getuid(), "workers": workers, "lease": None}
