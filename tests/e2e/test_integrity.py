"""A recording altered after its run is found (issue 46, item 9): ./afm run
writes digests.json (analysis/safefs.py: the SHA-256 of each of the run's
files) once the folder is root's again, and ./afm replay checks bus.lcmlog,
run.json and scene.yaml against it first, and ./afm export bus.lcmlog and
run.json, naming the file and both digests in one line (exit 2). A run made before digests replays, said so."""
import json
import os
import subprocess
import unittest

import e2e_support

AFM = os.path.join(e2e_support.SRC, "afm")


class Integrity(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = os.path.join(e2e_support.tmpdir("integrity"), "run")
        p = subprocess.run([AFM, "run", e2e_support.scene("short.yaml"), "--out", cls.out, "--quiet"],
                           capture_output=True, text=True, timeout=e2e_support.limit(540))
        assert p.returncode == 0, p.stderr

    def replay(self):
        return subprocess.run([AFM, "replay", self.out, "--quiet"], capture_output=True, text=True, timeout=e2e_support.limit(540))

    def test_1_the_digests_are_roots_and_cover_the_log(self):
        path = os.path.join(self.out, "digests.json")
        st = os.lstat(path)
        self.assertEqual((st.st_uid, st.st_mode & 0o022), (os.geteuid(), 0))
        with open(path) as f:
            sums = json.load(f)["sha256"]
        for name in ("bus.lcmlog", "run.json", "scene.yaml"):
            self.assertRegex(sums[name], "^[0-9a-f]{64}$")
        p = self.replay()
        self.assertEqual(p.returncode, 0, p.stderr)

    def test_2_an_altered_log_is_named_before_anything_replays(self):
        log = os.path.join(self.out, "bus.lcmlog")
        with open(log, "r+b") as f:
            f.seek(os.path.getsize(log) // 2)
            b = f.read(1)
            f.seek(-1, os.SEEK_CUR)
            f.write(bytes([b[0] ^ 0x01]))
        p = self.replay()
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"{self.out}/bus.lcmlog: altered since the run: sha256 ", p.stderr)
        self.assertEqual(p.stdout, "", "nothing replayed")
        said = [l for l in p.stderr.splitlines() if l.strip() and not l.startswith("afm: building")]   # ./afm's own build line aside
        self.assertEqual(len(said), 1, p.stderr)

    def test_2b_an_altered_log_is_not_exported(self):
        # (test_2 altered the log) ./afm export checks it as replay does, before it reads a byte of it
        csv = os.path.join(e2e_support.tmpdir("integrity-csv"), "csv")
        p = subprocess.run([AFM, "export", self.out, "--csv", csv], capture_output=True, text=True, timeout=e2e_support.limit(300))
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"{self.out}/bus.lcmlog: altered since the run: sha256 ", p.stderr)
        self.assertFalse(os.path.exists(csv), "nothing exported")

    def test_3_a_run_without_digests_replays_and_says_so(self):
        d = os.path.join(e2e_support.tmpdir("integrity-old"), "run")
        code, _, err, _ = e2e_support.run(e2e_support.scene("short.yaml"), d)
        self.assertEqual(code, 0, err)
        p = subprocess.run([AFM, "replay", d, "--quiet"], capture_output=True, text=True, timeout=e2e_support.limit(540))
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("no digests.json (a run made before digests): not checked", p.stderr)


if __name__ == "__main__":
    e2e_support.main()
