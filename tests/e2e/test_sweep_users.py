"""A sweep's users (issue 46, item 2): started as root with its local
cluster, the sweep's client and scheduler are one leased uid of the runs'
range and each worker another, never nobody, so that no other uid can read
the cluster's TLS key from their memory (/proc/PID/mem) or from the folder
Dask writes it in for a moment (their TMPDIR), or enter their points'
namespaces. sweep.json names the scheduler's uid and, per point, the
uid of the worker that ran it. After the sweep no lease is held and no file
in /tmp is one of those uids', and every file of the sweep's folder is root's
again. The smallest sweep that shows it: two points of the short scene on
two workers, without callgrind."""
import json
import os
import subprocess
import sys
import time
import unittest

import e2e_support
from analysis import paths

ROOT = os.geteuid() == 0
RUN_UID = paths.RUN_UID
NOBODY = 65534


def uid_of(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("Uid:"):
                return int(line.split()[1])
    raise OSError(f"no Uid line for pid {pid}")


def sweep_processes(root_pid):
    """{"sweep": {pid: uid}, "worker": {pid: uid}}: the sweep's own Python
    processes that are not root (its client and scheduler) and the Dask
    worker processes (e2e_support.sweep_processes), with their uids."""
    seen = {"sweep": {}, "worker": {}}
    for kind, pids in e2e_support.sweep_processes(root_pid).items():
        for pid in pids:
            try:
                uid = uid_of(pid)
            except OSError:
                continue
            if kind == "worker" or uid != 0:
                seen[kind][pid] = uid
    return seen


def reads_memory(uid, pid):
    """True if a process of `uid` (no groups, no capability) reads a page
    of pid's memory: what the cluster's key lies in."""
    probe = ("import re,sys; pid=sys.argv[1]; m=open(f'/proc/{pid}/maps').readline(); "
             "a=int(m.split('-')[0],16); f=open(f'/proc/{pid}/mem','rb'); f.seek(a); f.read(64)")
    p = subprocess.run(["setpriv", f"--reuid={uid}", f"--regid={uid}", "--clear-groups", "--inh-caps=-all",
                        "--bounding-set=-all", sys.executable, "-c", probe, str(pid)], capture_output=True, text=True,
                       timeout=30)
    return p.returncode == 0


def scratch_of(pid):
    """The folders where `pid` keeps files (its TMPDIR: where Dask writes
    the in-memory key for the moment it loads it; HOME; Dask's temporary
    directory), from its environment; /tmp where TMPDIR is not set."""
    with open(f"/proc/{pid}/environ", "rb") as f:
        env = dict(v.split(b"=", 1) for v in f.read().split(b"\0") if b"=" in v)
    return [env.get(k, b"/tmp").decode() for k in (b"TMPDIR", b"HOME", b"DASK_TEMPORARY_DIRECTORY")]


def lists_folder(uid, folder):
    """True if a process of `uid` (no groups) lists `folder` and reads what
    it holds (a temporary folder of Dask's inside, for the key)."""
    probe = ("import os,sys; d=sys.argv[1]; os.listdir(d); "
             "[os.listdir(os.path.join(d, n)) for n in os.listdir(d) if os.path.isdir(os.path.join(d, n))]")
    p = subprocess.run(["setpriv", f"--reuid={uid}", f"--regid={uid}", "--clear-groups", sys.executable, "-c", probe,
                        folder], capture_output=True, text=True, timeout=30)
    return p.returncode == 0


@unittest.skipUnless(ROOT, "only a sweep started as root leases its users")
class SweepUsers(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        p = subprocess.run([RUN_UID, "range"], capture_output=True, text=True)
        if p.returncode == 3:
            raise unittest.SkipTest("no range of uids reserved for the runs (tools/setup.sh reserves afm-runs)")
        cls.first, cls.count = (int(x) for x in p.stdout.split())
        closed = e2e_support.closed_ancestor(e2e_support.BUILD)
        if closed:
            raise unittest.SkipTest(f"the checkout's build is under {closed}, which the runs' users cannot traverse")
        cls.tmp = e2e_support.tmpdir("sweep-users")
        cls.out = os.path.join(cls.tmp, "sweep")
        env = {k: v for k, v in os.environ.items() if k not in ("AFM_RUN_USER", "AFM_ALLOW_UID_0")}
        p = subprocess.Popen([sys.executable, "-m", "analysis.sweep", e2e_support.scene("short.yaml"), "--vary",
                              "firmware.adc_bits=12,16", "--workers", "2", "--no-callgrind", "--out", cls.out],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=e2e_support.SRC, env=env)
        cls.seen = {"sweep": {}, "worker": {}}
        cls.read = {}   # (who, pid, probe uid) -> read
        t0 = time.monotonic()
        while p.poll() is None and time.monotonic() - t0 < e2e_support.limit(240):
            for k, v in sweep_processes(p.pid).items():
                cls.seen[k].update(v)
            if len(cls.seen["worker"]) >= 2 and cls.seen["sweep"] and not cls.read:
                # a third uid: nobody (today's fallback) and one of the range the sweep does not hold
                held = set(cls.seen["sweep"].values()) | set(cls.seen["worker"].values())
                third = next(u for u in range(cls.first + 1, cls.first + cls.count) if u not in held)
                for who in ("sweep", "worker"):
                    for pid in cls.seen[who]:
                        for probe in (NOBODY, third):
                            try:
                                cls.read[(who, pid, probe)] = reads_memory(probe, pid)
                                for folder in scratch_of(pid):
                                    cls.read[(who, pid, probe, folder)] = folder == "/tmp" or lists_folder(probe, folder)
                            except OSError:
                                pass
            time.sleep(0.1)
        cls.so, cls.se = p.communicate(timeout=e2e_support.limit(300))
        cls.code = p.returncode
        try:
            with open(os.path.join(cls.out, "sweep.json")) as f:
                cls.record = json.load(f)
        except (OSError, ValueError):
            cls.record = None

    @classmethod
    def tearDownClass(cls):
        if hasattr(cls, "tmp"):
            e2e_support.cleanup(cls.tmp)

    def test_the_sweep_is_measured(self):
        self.assertEqual(self.code, 0, self.so + self.se)
        self.assertEqual([p["status"] for p in self.record["points"]], ["ok", "ok"])

    def test_the_scheduler_and_each_worker_are_a_uid_of_their_own_from_the_range(self):
        sched = set(self.seen["sweep"].values())
        workers = sorted(set(self.seen["worker"].values()))
        print(f"scheduler uid(s) {sorted(sched)}, worker uids {workers}")
        self.assertEqual(len(sched), 1, self.seen)
        self.assertEqual(len(workers), 2, f"two workers, two uids: {self.seen}")
        for uid in sched | set(workers):
            self.assertNotEqual(uid, NOBODY)
            self.assertTrue(self.first <= uid < self.first + self.count, uid)
        self.assertFalse(sched & set(workers), "the workers are not the scheduler's uid")

    def test_no_third_uid_reads_the_scheduler_or_a_worker(self):
        self.assertTrue(self.read, "the memory of the sweep's processes was not probed")
        read = [k for k, v in self.read.items() if v]
        self.assertEqual(read, [], "(process, pid, the probe's uid[, folder]) whose memory, or whose folder where the "
                                   "key is written for a moment (/tmp: shared with every uid), another uid read")

    def test_sweep_json_names_the_scheduler_and_each_points_worker(self):
        self.assertIsNotNone(self.record, self.se)
        users = self.record["users"]
        self.assertEqual(users["scheduler"], next(iter(self.seen["sweep"].values())))
        self.assertEqual(sorted(users["workers"]), sorted(set(self.seen["worker"].values())))
        for p in self.record["points"]:
            self.assertIn(p["worker_uid"], users["workers"], p)

    def test_afterwards_no_lease_is_held_and_no_file_in_tmp_is_theirs(self):
        users = self.record["users"]
        uids = [users["scheduler"], *users["workers"]]
        for uid in uids:
            lock = f"/run/afm/uid-{uid}.lock"
            self.assertFalse(os.path.exists(lock), f"{lock} is left: a lease removes its file as it ends")
            left = subprocess.run(["find", "/tmp", "-xdev", "(", "-uid", str(uid), "-o", "-gid", str(uid), ")", "-print"],
                                  capture_output=True, text=True).stdout
            self.assertEqual(left, "", f"uid {uid} left these in /tmp")
            self.assertEqual([pid for pid in os.listdir("/proc") if pid.isdigit() and _uid_or_none(pid) == uid], [],
                             f"a process of uid {uid} outlived the sweep")
        bad = []
        for top, dirs, files in os.walk(self.out):
            for n in [top] + [os.path.join(top, f) for f in dirs + files]:
                st = os.lstat(n)
                if (st.st_uid, st.st_gid) != (0, 0):
                    bad.append(f"{n} {st.st_uid}:{st.st_gid}")
        self.assertEqual(bad, [], "every file of the sweep ends root's")


def _uid_or_none(pid):
    try:
        return uid_of(pid)
    except OSError:
        return None


if __name__ == "__main__":
    e2e_support.main()
