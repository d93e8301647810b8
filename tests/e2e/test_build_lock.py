"""The build lock (issue 46, item 4; docs/design.md, "Least privilege"):
./afm builds one at a time per user, its lock in a folder only the caller
can write (/run/afm for root), opened without truncation and without
following a link; a lock another process holds is named (pid and command)
and waited on for AFM_BUILD_LOCK_WAIT_S seconds at most, never forever."""
import os
import signal
import stat
import subprocess
import time
import unittest

import e2e_support

AFM = os.path.join(e2e_support.SRC, "afm")


def build(**env):
    return subprocess.run([AFM, "build"], capture_output=True, text=True, timeout=e2e_support.limit(540), env=dict(os.environ, **env))


class BuildLock(unittest.TestCase):
    def test_run_without_a_scene_asks_for_it_before_building(self):
        for args in ([], ["--spy"], ["--out", "x"]):
            p = subprocess.run([AFM, "run", *args], capture_output=True, text=True, timeout=e2e_support.limit(60))
            self.assertEqual(p.returncode, 2, args)
            self.assertIn("run: which scene?", p.stderr, args)
            self.assertNotIn("building", p.stderr, args)

    def test_a_link_as_the_lock_is_refused_and_its_target_untouched(self):
        d = e2e_support.tmpdir("lock-link")
        target = os.path.join(d, "precious.txt")
        with open(target, "w") as f:
            f.write("not to be truncated\n")
        link = os.path.join(d, "build.lock")
        os.symlink(target, link)
        p = build(AFM_BUILD_LOCK=link)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"build lock: {link} is a symbolic link", p.stderr)
        with open(target) as f:
            self.assertEqual(f.read(), "not to be truncated\n")

    def test_a_held_lock_is_named_and_not_waited_on_forever(self):
        lock = os.path.join(e2e_support.tmpdir("lock-held"), "build.lock")
        with open(lock, "w") as f:
            f.write("kept\n")
        # its own process group, killed whole: flock's `sleep` would otherwise
        # outlive it holding ctest's output pipe, and ctest wait out its 60 s
        holder = subprocess.Popen(["flock", lock, "sleep", "60"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  start_new_session=True)
        try:
            time.sleep(0.5)
            t0 = time.monotonic()
            p = build(AFM_BUILD_LOCK=lock, AFM_BUILD_LOCK_WAIT_S="2")
            waited = time.monotonic() - t0
        finally:
            os.killpg(holder.pid, signal.SIGKILL)
            holder.wait()
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"waiting for another build on this machine: pid {holder.pid} (flock {lock} sleep 60", p.stderr)
        self.assertIn(f"pid {holder.pid} (flock {lock} sleep 60) still holds {lock} after 2 s", p.stderr)
        self.assertLess(waited, 60, "it gave up after AFM_BUILD_LOCK_WAIT_S")
        with open(lock) as f:
            self.assertEqual(f.read(), "kept\n", "opened without truncation")

    def test_the_holder_names_itself_and_roots_lock_lies_in_run_afm(self):
        lock = os.path.join(e2e_support.tmpdir("lock-kept"), "build.lock")
        p = build(AFM_BUILD_LOCK=lock)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(lock) as f:
            self.assertRegex(f.read(), r"^[0-9]+\n$", "the pid of the build that held it")
        if os.geteuid() != 0:
            return
        env = {k: v for k, v in os.environ.items() if k != "AFM_BUILD_LOCK"}
        p = subprocess.run([AFM, "build"], capture_output=True, text=True, timeout=e2e_support.limit(540), env=env)
        self.assertEqual(p.returncode, 0, p.stderr)
        st = os.lstat("/run/afm")
        self.assertTrue(stat.S_ISDIR(st.st_mode))
        self.assertEqual((st.st_uid, stat.S_IMODE(st.st_mode) & 0o022), (0, 0))
        st = os.lstat("/run/afm/build.lock")
        self.assertTrue(stat.S_ISREG(st.st_mode))
        self.assertEqual(st.st_uid, 0)


if __name__ == "__main__":
    e2e_support.main()
