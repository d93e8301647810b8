"""./afm sweep --cluster slurm on a real SLURM (issue 49, item 6): Debian's
munged, slurmctld and `slurmd -D` started on this machine by the test
(proctrack/linuxproc, a slurm.conf, munge key, state and logs all in the
test's own folder, nothing written to /etc), a sweep of four points of
scenes/short.yaml through dask-jobqueue's SLURMCluster on one job, its
client, scheduler and jobs the runs' user (nobody), never root.

One job is killed at its walltime mid-point: while its worker runs a
point, the test, as the cluster's administrator, moves the job's end to
now (`scontrol update EndTime`: the sweep asked for 5 minutes, and SLURM's
time limits are whole minutes, checked every 30 s from slurmctld's start)
and holds that point's processes stopped, so that the walltime surely
finds it running. slurmctld ends the job as TIMEOUT (its job-completion
log; `sacct` needs slurmdbd and a database); the sweep submits a job in
its place, whose worker runs that point again and the rest (one job at a
time: the sweep can finish only on the replacement). Every
error column of sweep.csv, its verdict and status, are those of a local
sweep of the same points, run meanwhile. Every daemon is stopped when the
test ends, passed or failed.

Started as another user than root the test is skipped, as the suite's
root-only tests are; without SLURM's or munge's programs it fails, naming
what `./afm setup` installs."""
import csv
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import unittest

import e2e_support
from analysis import pareto

ROOT = os.geteuid() == 0
PROGRAMS = ["munged", "slurmctld", "slurmd", "sbatch", "scontrol", "squeue", "scancel", "sinfo"]
KNOBS = ["--vary", "firmware.adc_bits=10,12,14,16", "--no-callgrind"]
ERROR_COLUMNS = ["label", "status", "verdict"] + [e[0] for e in pareto.ERRORS] + [
    "force_rms_pct_fs", "force_worst_pct_fs", "display_rms_height_nm", "blocks"]
SWEEP_S = 100   # the SLURM sweep's end, from the test's start (43 s here)


def free_ports(n):
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


CONF = """ClusterName=afmtest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={d_port}
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={d}/sock/munge.sock
StateSaveLocation={d}/state
SlurmdSpoolDir={d}/spool
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
SlurmctldLogFile={d}/log/slurmctld.log
SlurmdLogFile={d}/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc={d}/log/jobcomp.txt
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
KillWait=2
MinJobAge=300
MpiDefault=none
MailProg=/bin/true
NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 RealMemory=4000 State=UNKNOWN
PartitionName=afm Nodes=localhost Default=YES MaxTime=INFINITE State=UP
"""


class Slurm:
    """munged, slurmctld and slurmd -D of a folder of their own; stop()
    cancels every job and ends the three (each by its pid), whatever state
    they are in."""

    def __init__(self, d):
        self.d, self.procs = d, []
        for sub in ("munge", "sock", "state", "spool", "log"):
            os.makedirs(os.path.join(d, sub), mode=0o700 if sub == "munge" else 0o755)
        os.chmod(os.path.join(d, "sock"), 0o755)   # the jobs' user reaches munged's socket
        key = os.path.join(d, "munge", "munge.key")
        with open(os.open(key, os.O_WRONLY | os.O_CREAT, 0o600), "wb") as f:
            f.write(os.urandom(128))
        ctld_port, d_port = free_ports(2)
        self.conf = os.path.join(d, "slurm.conf")
        with open(self.conf, "w") as f:
            f.write(CONF.format(d=d, ctld_port=ctld_port, d_port=d_port))
        self.env = dict(os.environ, SLURM_CONF=self.conf)

    def _start(self, cmd, name):
        out = open(os.path.join(self.d, "log", name + ".out"), "w")
        self.procs.append(subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, env=self.env))

    def start(self):
        d = self.d
        self._start(["munged", "-F", "-f", f"--key-file={d}/munge/munge.key", f"--socket={d}/sock/munge.sock",
                     f"--pid-file={d}/munge/munged.pid", f"--seed-file={d}/munge/seed", f"--log-file={d}/log/munged.log"],
                    "munged")
        for _ in range(50):
            if os.path.exists(f"{d}/sock/munge.sock"):
                break
            time.sleep(0.1)
        self.ctld_started = time.time()
        self._start(["slurmctld", "-D", "-i", "-f", self.conf], "slurmctld")
        self._start(["slurmd", "-D", "-f", self.conf, "-N", "localhost"], "slurmd")
        t0 = time.monotonic()
        while time.monotonic() - t0 < e2e_support.limit(30):
            p = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True, env=self.env)
            if p.stdout.strip() == "idle":
                return
            if any(x.poll() is not None for x in self.procs):
                break
            time.sleep(0.2)
        raise AssertionError(f"SLURM did not come up (sinfo: {p.stdout.strip() or p.stderr.strip()}); its logs in {d}/log")

    def run(self, *cmd):
        return subprocess.run(list(cmd), capture_output=True, text=True, env=self.env)

    def jobs(self):
        """{job id: state} of every job slurmctld knows, finished ones too."""
        out = self.run("squeue", "-h", "-t", "all", "-o", "%i %T").stdout.split()
        return dict(zip(out[0::2], out[1::2]))

    def completed(self):
        """{job id: (state, user)} from the job-completion log."""
        done = {}
        try:
            with open(os.path.join(self.d, "log", "jobcomp.txt")) as f:
                for line in f:
                    kv = dict(w.split("=", 1) for w in line.split() if "=" in w)
                    done[kv.get("JobId")] = (kv.get("JobState"), kv.get("UserId"))
        except OSError:
            pass
        return done

    def stop(self):
        self.run("scancel", "--full", "--state", "pending,running")
        t0 = time.monotonic()
        while time.monotonic() - t0 < 10 and any(s in ("RUNNING", "COMPLETING", "PENDING") for s in self.jobs().values()):
            time.sleep(0.2)
        for p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in reversed(self.procs):
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def environ_of(pid):
    try:
        with open(f"/proc/{pid}/environ", "rb") as f:
            return dict(v.split(b"=", 1) for v in f.read().split(b"\0") if b"=" in v)
    except OSError:
        return {}


def point_runs():
    """{job id: [pid of afm_launch]}: the points SLURM jobs' workers are running."""
    runs = {}
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/cmdline", "rb") as f:
                cmd = f.read().split(b"\0")
        except OSError:
            continue
        if cmd and cmd[0].endswith(b"afm_launch") and b"--out" in cmd:
            job = environ_of(d).get(b"SLURM_JOB_ID")
            if job:
                runs.setdefault(job.decode(), []).append(int(d))
    return runs


def out_of(pid):
    with open(f"/proc/{pid}/cmdline", "rb") as f:
        cmd = [x.decode() for x in f.read().split(b"\0")]
    return cmd[cmd.index("--out") + 1]


def hold(pid):
    """SIGSTOP to pid and every process below it, until none is left running."""
    for _ in range(3):
        for p in [pid] + e2e_support.descendants(pid):
            try:
                os.kill(p, signal.SIGSTOP)
            except ProcessLookupError:
                pass
        time.sleep(0.05)


def rows(out):
    with open(os.path.join(out, "sweep.csv")) as f:
        return list(csv.DictReader(f))


@unittest.skipUnless(ROOT, "SLURM's daemons and a job of another user are started by root alone")
class SweepOnSlurm(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        missing = [p for p in PROGRAMS if not shutil.which(p)]
        if missing:
            raise AssertionError(f"{', '.join(missing)} not found: ./afm setup installs Debian's slurm-wlm and munge")
        closed = e2e_support.closed_ancestor(e2e_support.BUILD)
        if closed:
            raise unittest.SkipTest(f"the checkout's build is under {closed}, which the jobs' user cannot traverse")
        cls.tmp = e2e_support.tmpdir("slurm")
        cls.slurm = Slurm(os.path.join(cls.tmp, "slurm"))
        try:
            cls._run()
        except BaseException:
            cls.slurm.stop()
            raise
        cls.slurm.stop()

    @classmethod
    def _run(cls):
        t0 = time.monotonic()
        cls.slurm.start()
        cls.up_s = time.monotonic() - t0
        env = {k: v for k, v in cls.slurm.env.items() if k not in ("AFM_RUN_USER", "AFM_ALLOW_UID_0")}
        cls.out, cls.local = os.path.join(cls.tmp, "slurm-sweep"), os.path.join(cls.tmp, "local-sweep")
        sweep = [sys.executable, "-m", "analysis.sweep", e2e_support.scene("short.yaml"), *KNOBS]
        p = subprocess.Popen(sweep + ["--cluster", "slurm", "--workers", "1", "--time", "5", "--out", cls.out], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, cwd=e2e_support.SRC, env=env)
        local = subprocess.Popen(sweep + ["--workers", "2", "--out", cls.local], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                 cwd=e2e_support.SRC, env=env)
        cls.victim, cls.held, cls.users = None, None, set()
        while p.poll() is None and time.monotonic() - t0 < e2e_support.limit(SWEEP_S):
            if cls.victim is None:
                cls._kill_one_at_walltime()
            time.sleep(0.1)
        cls.unfinished = p.poll() is None
        if cls.unfinished:   # ended as Ctrl-C ends it: its jobs cancelled, its folder given back
            p.terminate()
        cls.so, cls.se = p.communicate(timeout=e2e_support.limit(60))
        cls.code, cls.slurm_s = p.returncode, time.monotonic() - t0
        cls.local_so, cls.local_se = local.communicate(timeout=e2e_support.limit(120))
        cls.local_code = local.returncode
        cls.completed = cls.slurm.completed()
        cls.total_s = time.monotonic() - t0
        print(f"SLURM up in {cls.up_s:.1f} s; the SLURM sweep done at {cls.slurm_s:.1f} s; both sweeps at "
              f"{cls.total_s:.1f} s; jobs {cls.completed}", file=sys.stderr)

    @classmethod
    def _kill_one_at_walltime(cls):
        """The first job seen running a point: its end moved to now, the
        point's processes held stopped until slurmctld's next check of time
        limits ends the job."""
        for job, pids in point_runs().items():
            when = time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(time.time() + 1))
            r = cls.slurm.run("scontrol", "update", f"JobId={job}", f"EndTime={when}")
            if r.returncode != 0:
                raise AssertionError(f"scontrol update JobId={job} EndTime={when}: {r.stderr.strip()}")
            cls.held = os.path.dirname(out_of(pids[0]))   # the point's folder, OUT/points/HASH
            hold(pids[0])
            cls.victim = job
            return

    def test_the_sweep_is_measured_on_slurm_jobs_of_an_unprivileged_user(self):
        self.assertFalse(self.unfinished, f"the SLURM sweep had not finished {SWEEP_S} s after the test's start "
                                          f"(jobs: {self.completed}): {self.se[-2000:]}")
        self.assertEqual(self.code, 0, self.so + self.se)
        with open(os.path.join(self.out, "sweep.json")) as f:
            rec = json.load(f)
        self.assertIn("SLURM", rec["engine"])
        self.assertEqual([p["status"] for p in rec["points"]], ["ok"] * 4)
        for p in rec["points"]:
            self.assertNotEqual(p["worker_uid"], 0, p)
            self.assertIn("slurm_job_id", p)
        users = {u for _, u in self.completed.values()}
        self.assertTrue(users and not any(u.startswith("root") for u in users), users)

    def test_a_job_killed_at_its_walltime_is_replaced_and_its_point_run_again(self):
        self.assertIsNotNone(self.victim, "no job was seen running a point")
        self.assertEqual(self.completed.get(self.victim, (None,))[0], "TIMEOUT", self.completed)
        later = [j for j in self.completed if int(j) > int(self.victim)]
        self.assertTrue(later, f"no job was submitted in the killed job's place: {self.completed}")
        with open(os.path.join(self.held, "point.json")) as f:
            point = json.load(f)
        self.assertEqual(point["status"], "ok", point)
        self.assertNotEqual(point["slurm_job_id"], self.victim, "the held point was not run again by another job")

    def test_every_error_column_is_the_local_sweeps(self):
        self.assertEqual(self.local_code, 0, self.local_so + self.local_se)
        self.assertEqual(self.code, 0, self.so + self.se)
        mine, theirs = rows(self.out), rows(self.local)
        self.assertEqual(len(mine), 4)
        for col in ERROR_COLUMNS:
            self.assertIn(col, mine[0], col)
            self.assertEqual([r[col] for r in mine], [r[col] for r in theirs], col)

    def test_no_daemon_or_job_outlives_the_test(self):
        left = [p.args[0] for p in self.slurm.procs if p.poll() is None]
        self.assertEqual(left, [], "daemons still running")
        conf = self.slurm.conf.encode()
        ours = [pid for pid in os.listdir("/proc") if pid.isdigit() and environ_of(pid).get(b"SLURM_CONF") == conf]
        self.assertEqual(ours, [], "processes of the test's SLURM (its sweeps, its jobs' workers) still running")
        self.assertEqual([d for d in os.listdir(self.out) if d.startswith(".tls-")], [], "the jobs' credentials are removed")


if __name__ == "__main__":
    e2e_support.main()
