"""The sweep's engine on a SLURM cluster (./afm sweep --cluster slurm):
its workers are SLURM jobs started through dask-jobqueue's SLURMCluster, its
scheduler runs in the sweep's own process, closed as every engine of the
sweep is (analysis/engine.py): TLS with mutual authentication on every
connection, no HTTP port (QuietScheduler; each job's worker is a
QuietWorker), the client reading JSON answers only.

- The credentials. Given --tls-ca, --tls-cert and --tls-key (a lab's
  cluster: `python -m analysis.cluster certs DIR` on a file system every
  node sees, DIR 0700 and key.pem 0600, the sweeping user's), the jobs'
  workers are handed those paths. Without them the sweep makes credentials
  for itself alone (Security.temporary()) and dask-jobqueue writes them for
  the jobs into a folder of the output folder, `.tls-*` (0700, its files
  0600: the sweeping user's, who is also the jobs' user), removed when the
  cluster closes.
- The jobs. One single-threaded worker a job (`--workers N` jobs), each
  `sbatch -p PARTITION -A ACCOUNT -t TIME --mem MEM`, named
  afm-sweep-PID; their output in OUT/jobs/. The jobs are the user who runs
  the sweep. Started as root (as_job_user), the sweep's client and
  scheduler drop to the runs' user (run/run_user.sh: AFM_RUN_USER, or
  nobody), who needs an entry in /etc/passwd (slurmd starts a job as a
  named user), so root submits no job.
- A job that ends before the sweep does (its walltime reached: TIMEOUT,
  or a node lost) is replaced: a new job is submitted for it once its
  worker has left (SweepSLURMCluster), and the batch its worker was
  running is run again by another worker (Dask reschedules a lost worker's
  tasks; a point's half-written run is removed before its run,
  analysis/point.py).

docs/sweeps.md ("On a SLURM cluster") says how to run it on a lab's
cluster."""
import asyncio
import json
import os
import pwd
import shutil
import signal
import subprocess
import sys
import tempfile

from analysis import engine, paths

JOIN_TIMEOUT_S = 600.0   # the first job's worker joins within this (a queue's wait included)
LOST_WORKER_S = 1.0      # a worker gone this long is its job's end: the job is replaced
DEFAULT_MEM = "2GB"
STOP_GRACE_S = 30.0      # the sweep's user's process, told to stop, ends within this (its plots and report)
JOB_NAME_ENV = "AFM_SWEEP_JOB_NAME"   # root's name for the jobs of the sweep it starts as the runs' user
LOOPBACK = ("127.0.0.1", "localhost")


class SlurmError(Exception):
    """The SLURM engine cannot be used, named in one line."""


def _cluster_class():
    from dask_jobqueue import SLURMCluster
    from distributed.core import Status

    class SweepSLURMCluster(SLURMCluster):
        """SLURMCluster whose jobs are replaced when they end under it:
        dask-jobqueue forgets a lost worker's job (SpecCluster, after
        distributed.deploy.lost-worker-timeout) but submits no other until
        the cluster is scaled; here the spec's missing jobs are started
        again as soon as one is forgotten."""

        def _update_worker_status(self, op, msg):
            super()._update_worker_status(op, msg)
            if op == "remove":
                asyncio.get_running_loop().call_later(LOST_WORKER_S + 0.5, self._replace_lost)

        def _replace_lost(self):
            if self.status == Status.running and set(self.worker_spec) - set(self.workers):
                self._futures.add(asyncio.ensure_future(self._correct_state()))

        async def _close(self):
            try:
                await super()._close()
            finally:
                for name, f in list(vars(self).items()):   # dask-jobqueue's handles of the key's files: closed, removed
                    if name.startswith("_job_") and isinstance(f, tempfile._TemporaryFileWrapper):
                        f.close()
                tls = getattr(self, "afm_tls_dir", None)
                if tls:
                    shutil.rmtree(tls, ignore_errors=True)

    return SweepSLURMCluster


def security(a, out):
    """(Security, the folder dask-jobqueue writes a made key into, or None):
    the --tls-* files when given, else credentials made for this sweep."""
    from distributed import Security
    if a.tls_ca or a.tls_cert or a.tls_key:
        return engine.security_from_files(a.tls_ca, a.tls_cert, a.tls_key), None
    return Security.temporary(), tempfile.mkdtemp(prefix=".tls-", dir=out)   # mkdtemp: 0700


def worker_args(host):
    """The job's dask worker: a QuietWorker (no HTTP port), bound to the
    loopback when the scheduler is (a cluster of this machine), else to
    its node's address."""
    args = ["--worker-class", "analysis.engine.QuietWorker", "--no-dashboard"]
    return args + ["--host", host] if host in LOOPBACK else args


def _controller_answers():
    """SlurmError naming why, within 30 s, if slurmctld does not answer
    (no slurm.conf, a controller down): else the sweep would wait for
    jobs that never start."""
    try:
        p = subprocess.run(["squeue", "-h", "-o", "%i", "-u", str(os.getuid())], capture_output=True, text=True, timeout=30)
    except subprocess.TimeoutExpired:
        raise SlurmError("--cluster slurm: squeue had no answer from slurmctld in 30 s") from None
    if p.returncode != 0:
        why = (p.stderr.strip().splitlines() or [f"exit {p.returncode}"])[-1]
        raise SlurmError(f"--cluster slurm: SLURM does not answer: {why}")


def start(a, n_workers, out):
    """(client, cluster): n_workers SLURM jobs, each a TLS worker of this
    process's scheduler on --cluster-host (default 127.0.0.1); once the
    first has joined. SlurmError names what stops it."""
    import dask
    from distributed import Client
    engine.harden_client()
    if not shutil.which("sbatch"):
        raise SlurmError("--cluster slurm: sbatch is not on PATH (SLURM's client commands: Debian's slurm-client)")
    _controller_answers()
    dask.config.set({"distributed.deploy.lost-worker-timeout": f"{LOST_WORKER_S}s"})
    sec, tls_dir = security(a, out)
    host = a.cluster_host
    jobs = os.path.join(out, "jobs")
    os.makedirs(jobs, exist_ok=True)
    try:
        cluster = _cluster_class()(
            n_workers=0, cores=1, processes=1, memory=a.job_mem or DEFAULT_MEM, queue=a.partition, account=a.account,
            walltime=a.time, job_name=os.environ.get(JOB_NAME_ENV) or f"afm-sweep-{os.getpid()}", log_directory=jobs,
            python=sys.executable,
            security=sec, protocol="tls://", shared_temp_directory=tls_dir, scheduler_cls=engine.QuietScheduler,
            scheduler_options={"host": host, "dashboard": False, "dashboard_address": None},
            worker_extra_args=worker_args(host),
            job_directives_skip=[] if a.job_mem else ["--mem"], silence_logs=40)
    except Exception as e:   # dask-jobqueue's and Dask's errors, in one line
        if tls_dir:
            shutil.rmtree(tls_dir, ignore_errors=True)
        why = str(e).splitlines()[0][:200] if str(e) else type(e).__name__
        raise SlurmError(f"--cluster slurm: cannot start the scheduler: {why}") from None
    cluster.afm_tls_dir = tls_dir
    try:
        client = Client(cluster, security=sec, deserializers=engine.SAFE_DESERIALIZERS)
        cluster.scale(n_workers)
        _wait_first(client, cluster, jobs)
    except BaseException:
        cluster.close()
        raise
    return client, cluster


def _wait_first(client, cluster, jobs):
    """Returns once a job's worker has joined; SlurmError naming the jobs'
    state (squeue) and their output folder if none does in JOIN_TIMEOUT_S."""
    try:
        client.wait_for_workers(1, timeout=JOIN_TIMEOUT_S)
    except (TimeoutError, OSError):
        ids = [getattr(j, "job_id", None) for j in cluster.workers.values()]
        state = subprocess.run(["squeue", "-h", "-o", "%i %T %r", "-j", ",".join(i for i in ids if i)],
                               capture_output=True, text=True).stdout.strip().replace("\n", "; ") if any(ids) else ""
        raise SlurmError(f"--cluster slurm: no job's worker joined in {JOIN_TIMEOUT_S:.0f} s (jobs {state or 'not submitted'}; "
                         f"their output in {jobs})") from None


def as_job_user(argv, out, sizes):
    """Started as root: the sweep again as the runs' user (run/run_user.sh:
    AFM_RUN_USER, or nobody), with capabilities dropped (run/drop_caps.sh),
    so that its jobs are that user's; `out` is theirs for the sweep and given
    back after, the scratch folder (HOME, TMPDIR, Dask's) removed, and every
    job of the sweep cancelled. Returns the sweep's exit code."""
    p = subprocess.run([paths.RUN_USER, "id"], capture_output=True, text=True)
    if p.returncode != 0:
        raise SlurmError(p.stderr.strip().removeprefix("run_user: "))
    uid, gid = (int(v) for v in p.stdout.split())
    if uid == 0:
        raise SlurmError("--cluster slurm started as root: the jobs would be root's; set AFM_RUN_USER to a user of "
                         "/etc/passwd (default nobody)")
    try:
        name = pwd.getpwuid(uid).pw_name
    except KeyError:
        raise SlurmError(f"--cluster slurm: the runs' user, uid {uid}, has no entry in /etc/passwd, and slurmd starts "
                         f"jobs as named users only (AFM_RUN_USER names one)") from None
    give = subprocess.run([paths.RUN_USER, "give", "--reach", paths.ROOT, out], capture_output=True, text=True)
    if give.returncode != 0:
        raise SlurmError(give.stderr.strip().removeprefix("run_user: "))
    scratch = tempfile.mkdtemp(prefix="afm-sweep-slurm-")
    child = None
    try:
        for sub in ("home", "tmp", "dask"):
            os.makedirs(os.path.join(scratch, sub))
        subprocess.run([paths.RUN_USER, "give", scratch], capture_output=True, check=True)
        env = dict(os.environ, AFM_RUN_UID=str(uid), AFM_RUN_GID=str(gid), HOME=f"{scratch}/home",
                   TMPDIR=f"{scratch}/tmp", DASK_TEMPORARY_DIRECTORY=f"{scratch}/dask", USER=name, LOGNAME=name,
                   MPLCONFIGDIR=f"{scratch}/home/.matplotlib", XDG_CACHE_HOME=f"{scratch}/home/.cache",
                   AFM_SWEEP_ARM_SIZES=json.dumps(sizes))
        env[JOB_NAME_ENV] = job_name = f"afm-sweep-{os.getpid()}"
        child = subprocess.Popen([paths.DROP_CAPS, sys.executable, "-m", "analysis.sweep", *argv], env=env)
        code = child.wait()
        return 128 - code if code < 0 else code
    except KeyboardInterrupt:   # Ctrl-C reached the child too; SIGTERM (sweep.main: as Ctrl-C) did not
        if child is not None:
            child.send_signal(signal.SIGTERM)
            try:
                child.wait(timeout=STOP_GRACE_S)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
        return 130
    finally:
        if child is not None:
            subprocess.run(["scancel", "--user", str(uid), "--name", job_name], capture_output=True)
        subprocess.run([paths.RUN_USER, "take", out], capture_output=True)
        shutil.rmtree(scratch, ignore_errors=True)
