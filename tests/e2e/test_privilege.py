"""Least privilege (issue 35): a run's processes need no root. Once their
namespace exists (run/in_netns.sh) they run through run/drop_caps.sh:
/proc/PID/status shows CapEff, CapPrm, CapBnd and CapAmb 0 and NoNewPrivs 1
for the launcher and each of its children (the card's board under QEMU and
the renderer's ffmpeg too), and a non-zero uid: started as root, the run's
user (run/run_user.sh, nobody unless AFM_RUN_USER says otherwise), else
the caller's own. Started as root, the run's folder is handed to that user
for the run and given back after: every file ends owned by the caller. A
sweep's scheduler and Dask workers drop too (each a uid of its own:
test_sweep_users.py). The link and fault helper alone
keeps CAP_NET_ADMIN and CAP_NET_RAW (AFM_KEEP_CAPS), and a command it starts
through drop_caps.sh again has none. A run whose folder the run's user cannot
reach is refused in one line, whatever stderr is; allowed (AFM_ALLOW_UID_0=1,
./afm run --allow-uid-0), it keeps uid 0, still without capabilities. A
viewed run (./afm run --view) drops like any other (issue 46)."""
import json
import os
import shutil
import subprocess
import sys
import time
import unittest

import e2e_support
from analysis import paths

DROP = paths.DROP_CAPS
NET_ADMIN_RAW = (1 << 12) | (1 << 13)
RUN = {"afm_launch", "sim_afm", "fw_node", "operator", "renderer"}
CAPS = ("CapEff", "CapPrm", "CapBnd", "CapAmb")
ROOT = os.geteuid() == 0


def status(pid):
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            k, _, v = line.partition(":")
            out[k] = v.strip()
    return out


def watch(p, names, want, timeout_s=120):
    """{name: status} of the processes under Popen `p` whose Name is in
    `names` (the last status seen of each), polled until `want` of them have
    been seen or `p` ends."""
    seen = {}
    t0 = time.monotonic()
    while p.poll() is None and time.monotonic() - t0 < timeout_s and not want <= set(seen):
        for pid in [p.pid, *e2e_support.descendants(p.pid)]:   # p.pid: the launcher itself when in_netns.sh exec'd it (not root)
            try:
                st = status(pid)
            except OSError:
                continue
            if st["Name"] in names:   # not in_netns.sh's shell, which stays root (started as root) to give the folder back
                seen[st["Name"]] = st
        time.sleep(0.05)
    return seen


def not_the_callers(folder):
    """The files under `folder` that the caller does not own."""
    me = os.getuid(), os.getgid()
    bad = []
    for top, dirs, files in os.walk(folder):
        for n in [top] + [os.path.join(top, f) for f in dirs + files]:
            st = os.lstat(n)
            if (st.st_uid, st.st_gid) != me:
                bad.append(f"{n} {st.st_uid}:{st.st_gid}")
    return bad


class LeastPrivilege(unittest.TestCase):
    def unprivileged(self, seen, caps=CAPS, no_new_privs=True):
        for name, st in seen.items():
            for cap in caps:
                self.assertEqual(int(st[cap], 16), 0, f"{name}: {cap} {st[cap]}")
            if no_new_privs:
                self.assertEqual(st["NoNewPrivs"], "1", name)
            uids = st["Uid"].split()
            self.assertNotIn("0", uids, f"{name}: Uid {st['Uid']} (real, effective, saved, fs)")
            self.assertNotIn("0", st["Gid"].split(), f"{name}: Gid {st['Gid']}")
            print(f"{name}: Uid {uids[0]}, Gid {st['Gid'].split()[0]}, CapEff {st['CapEff']}, CapBnd {st['CapBnd']}, "
                  f"NoNewPrivs {st['NoNewPrivs']}")

    def run_watched(self, tag, names, want, *extra):
        closed = e2e_support.closed_ancestor(e2e_support.BUILD) if ROOT else None
        if closed:
            self.skipTest(f"the checkout's build {e2e_support.BUILD} is under {closed} (mode "
                          f"{oct(os.stat(closed).st_mode & 0o777)}), which the run's user cannot traverse: the run keeps "
                          "uid 0 without capabilities, as the suite allows there (test_a_folder_the_runs_user_cannot_reach...)")
        out = os.path.join(e2e_support.tmpdir(tag), "run")
        p = subprocess.Popen([e2e_support.IN_NETNS, e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out", out,
                              "--quiet", *extra], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        seen = watch(p, names, want)
        _, err = p.communicate(timeout=180)
        self.assertEqual(p.returncode, 0, err)
        self.assertNotIn("keeps uid 0", err)
        self.assertEqual(set(seen) & RUN, RUN, seen.keys())
        self.unprivileged(seen)
        self.assertEqual(not_the_callers(out), [], "every file of the run ends the caller's")
        return out, seen

    def test_a_runs_processes_hold_no_capability_and_no_root(self):
        # ffmpeg when the renderer writes its video through it (run.json renderer.video says which)
        out, seen = self.run_watched("privilege", RUN | {"ffmpeg"}, RUN | ({"ffmpeg"} if shutil.which("ffmpeg") else set()))
        with open(os.path.join(out, "run.json")) as f:
            video = json.load(f)["renderer"]["video"]
        if video["encoder"].startswith("ffmpeg"):
            self.assertIn("ffmpeg", seen, video)

    def test_the_cards_board_under_qemu_holds_none_either(self):
        _, seen = self.run_watched("privilege-qemu", RUN | {"qemu-system-arm"}, RUN | {"qemu-system-arm"}, "--firmware", "qemu")
        self.assertIn("qemu-system-arm", seen)

    def test_a_sweeps_workers_hold_none_either(self):
        closed = e2e_support.closed_ancestor(e2e_support.BUILD) if ROOT else None
        if closed:
            self.skipTest(f"the checkout's build is under {closed}, which the run's user cannot traverse")
        out = os.path.join(e2e_support.tmpdir("privilege-sweep"), "sweep")
        p = subprocess.Popen([sys.executable, "-m", "analysis.sweep", e2e_support.scene("short.yaml"), "--vary", "firmware.adc_bits=12",
                              "--workers", "1", "--no-callgrind", "--out", out], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             text=True, cwd=e2e_support.SRC, env=dict(os.environ, AFM_BUILD=e2e_support.BUILD))
        # started as root, the sweep's client and scheduler run again as a
        # leased uid, and each worker (a nanny and the Python process it
        # spawns, multiprocessing) as another
        seen = {}
        t0 = time.monotonic()
        while p.poll() is None and time.monotonic() - t0 < 180 and "worker" not in seen:
            for kind, pids in e2e_support.sweep_processes(p.pid).items():
                for pid in pids:
                    try:
                        st = status(pid)
                    except OSError:
                        continue
                    if kind == "worker" or ROOT:
                        seen[kind] = st
            time.sleep(0.1)
        _, err = p.communicate(timeout=300)
        self.assertEqual(p.returncode, 0, err)
        self.assertNotIn("stay root", err)
        self.assertEqual(set(seen), {"worker", "sweep"} if ROOT else {"worker"}, "the sweep as the run's user, its Dask worker")
        # not root, the sweep is the caller's own (its runs drop all through in_netns.sh)
        self.unprivileged(seen, CAPS if ROOT else ("CapEff", "CapPrm"), no_new_privs=ROOT)
        self.assertEqual(not_the_callers(out), [], "every file of the sweep ends the caller's")

    @unittest.skipUnless(ROOT, "the run's user differs from the caller only when started as root")
    def test_a_folder_the_runs_user_cannot_reach_is_refused_unless_uid_0_is_allowed(self):
        closed = e2e_support.tmpdir("closed")
        os.chmod(closed, 0o700)
        out = os.path.join(closed, "run")
        if e2e_support.closed_ancestor(DROP):
            self.skipTest(f"the checkout itself is under {e2e_support.closed_ancestor(DROP)}: the run's user is stopped there first")
        cmd = [e2e_support.IN_NETNS, "sh", "-c", "id -u; grep CapEff /proc/self/status", "sh", "--out", out]
        env = {k: v for k, v in os.environ.items() if k not in ("AFM_ALLOW_UID_0", "AFM_PRIVILEGE_WARNINGS")}
        # not allowed: refused in one line on any stderr (a pipe here), nothing run, nothing left
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=30, env=env)
        self.assertEqual((p.returncode, p.stdout), (2, ""), p.stderr)
        self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
        self.assertIn("refused: the run would keep uid 0: the run's user (uid ", p.stderr)
        self.assertIn(f"cannot reach {out}: {closed} is mode 700", p.stderr)
        self.assertFalse(os.path.exists(out), "the folder made for it is removed again")
        self.assertEqual(not_the_callers(closed), [])
        # allowed (./afm run --allow-uid-0): uid 0 without capabilities, and why, when asked
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=30,
                           env=dict(env, AFM_ALLOW_UID_0="1", AFM_PRIVILEGE_WARNINGS="1"))
        self.assertEqual(p.returncode, 0, p.stderr)
        uid, eff = p.stdout.split()[0], int(p.stdout.split()[2], 16)
        self.assertEqual((uid, eff), ("0", 0), p.stdout)
        self.assertIn("keeps uid 0 (without capabilities, as AFM_ALLOW_UID_0=1 allows): the run's user", p.stderr)
        self.assertEqual(not_the_callers(closed), [])
        # allowed, not asked, and not a terminal: nothing said beyond the command's own output
        p = subprocess.run([e2e_support.IN_NETNS, "sh", "-c", "id -u", "sh", "--out", out], capture_output=True, text=True,
                           timeout=30, env=dict(env, AFM_ALLOW_UID_0="1"))
        self.assertEqual((p.returncode, p.stdout.strip(), p.stderr), (0, "0", ""))

    @unittest.skipUnless(ROOT, "the run's user differs from the caller only when started as root")
    def test_a_viewed_run_drops_to_the_runs_user_too(self):
        closed = e2e_support.closed_ancestor(e2e_support.BUILD)
        if closed:
            self.skipTest(f"the checkout's build is under {closed}, which the run's user cannot traverse")
        out = os.path.join(e2e_support.tmpdir("privilege-view"), "run")
        env = {k: v for k, v in os.environ.items() if k != "AFM_ALLOW_UID_0"}
        p = subprocess.run([sys.executable, "-m", "analysis.view", "run", "--out", out, "--",
                            e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out", out, "--view", "--quiet"],
                           capture_output=True, text=True, timeout=300, cwd=e2e_support.SRC, env=env)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(os.path.join(out, "run.json")) as f:
            netns = json.load(f)["netns"]
        self.assertRegex(netns, r"^(user|root):[1-9][0-9]* ", "the view's run is the run's user's, not uid 0's")
        self.assertEqual(not_the_callers(out), [])

    @unittest.skipUnless(ROOT, "only root leases a uid for a run")
    def test_each_run_leases_a_uid_of_its_own_with_limits(self):
        run_uid = paths.RUN_UID
        p = subprocess.run([run_uid, "range"], capture_output=True, text=True)
        if p.returncode == 3:
            self.skipTest("no range of uids reserved for the runs (tools/setup.sh reserves afm-runs in /etc/subuid)")
        first, count = (int(x) for x in p.stdout.split())
        if e2e_support.closed_ancestor(DROP):
            self.skipTest(f"the checkout is under {e2e_support.closed_ancestor(DROP)}: the run's user cannot reach it")
        # never a uid a process holds or that owns a file where a run writes
        held_file = f"/tmp/afm-test-held-{os.getpid()}"
        open(held_file, "w").close()
        os.chown(held_file, first + 5, first + 5)
        holder = subprocess.Popen(["setpriv", f"--reuid={first + 6}", f"--regid={first + 6}", "--clear-groups", "sleep", "60"])
        try:
            time.sleep(0.3)
            # a file root chowned into the range is seen once the record is walked anew
            subprocess.run([run_uid, "rescan"], check=True)
            free = set(subprocess.run([run_uid, "free", str(count)], capture_output=True, text=True, check=True).stdout.split())
            # a uid leased and given back stays out of the free ones without a walk (its run may have left files)
            lease = subprocess.Popen([run_uid, "lease", "1"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
            leased = lease.stdout.readline().strip()
            lease.stdin.close()
            self.assertEqual(lease.wait(timeout=30), 0)
            state = subprocess.run([run_uid, "state-dir"], capture_output=True, text=True, check=True).stdout.strip()
            with open(os.path.join(state, "uids-used")) as f:
                used = f.read().split()
        finally:
            holder.kill()
            holder.wait()
            os.unlink(held_file)
        self.assertNotIn(str(first + 5), free, "a uid that owns a file in /tmp")
        self.assertNotIn(str(first + 6), free, "a uid a process holds")
        self.assertGreater(len(free), count - 100)
        self.assertRegex(leased, r"^[1-9][0-9]*$")
        self.assertIn(leased, used, "a uid leased stays in the record of uids that may own files until a walk")
        # two runs at once: two uids of the range, HOME a scratch folder of theirs (removed after), the limits named
        show = 'id -u; echo "$HOME"; echo "$AFM_NETNS_MODE"; grep -E "^Max (processes|file size|data size)" /proc/self/limits; sleep 1'
        runs = [subprocess.Popen([e2e_support.IN_NETNS, "sh", "-c", show], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                 env={k: v for k, v in os.environ.items() if k != "AFM_RUN_USER"}) for _ in range(2)]
        outs = [r.communicate(timeout=60) for r in runs]
        for r, (out, err) in zip(runs, outs):
            self.assertEqual(r.returncode, 0, err)
        uids = [int(out.split()[0]) for out, _ in outs]
        self.assertNotEqual(uids[0], uids[1], "each run its own uid")
        for (out, _), uid in zip(outs, uids):
            lines = out.splitlines()
            self.assertTrue(first <= uid < first + count, uid)
            self.assertTrue(lines[1].startswith("/tmp/afm-run-home-") or "afm-run-home-" in lines[1], lines[1])
            self.assertFalse(os.path.exists(lines[1]), "the run's HOME is removed after it")
            self.assertEqual(lines[2], f"user:{uid} lease:{first}:{count} limits:nproc=4096,fsize={16 << 30},data={16 << 30}")
            self.assertRegex(out, r"Max processes +4096 +4096")
            self.assertRegex(out, rf"Max file size +{16 << 30} +{16 << 30}")
        # nobody stays the documented fallback
        p = subprocess.run([e2e_support.IN_NETNS, "id", "-u"], capture_output=True, text=True, timeout=60,
                           env=dict(os.environ, AFM_RUN_USER="nobody"))
        self.assertEqual((p.returncode, p.stdout.strip()), (0, "65534"), p.stderr)

    def test_the_fault_helper_alone_keeps_net_admin_and_net_raw(self):
        cmd = [e2e_support.IN_NETNS, "sh", "-c",
               f"id -u; grep CapEff /proc/self/status; '{DROP}' sh -c 'id -u; grep CapEff /proc/self/status'"]
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=30, env=dict(os.environ, AFM_KEEP_CAPS="net_admin,net_raw"))
        self.assertEqual(p.returncode, 0, p.stderr)
        words = p.stdout.split()
        helper_uid, helper, after_uid, after = words[0], int(words[2], 16), words[3], int(words[5], 16)
        self.assertEqual(helper, NET_ADMIN_RAW)
        self.assertEqual(after, 0)
        if ROOT and not e2e_support.closed_ancestor(DROP):   # the helper is the run's user too: its capabilities are its only privilege
            self.assertNotEqual(helper_uid, "0")
            self.assertEqual(after_uid, helper_uid)
        p = subprocess.run([e2e_support.IN_NETNS, "grep", "CapEff", "/proc/self/status"], capture_output=True, text=True, timeout=30)
        self.assertEqual(int(p.stdout.split()[1], 16), 0, "without AFM_KEEP_CAPS nothing is kept")


if __name__ == "__main__":
    e2e_support.main()
