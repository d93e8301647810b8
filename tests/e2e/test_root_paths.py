"""Nothing root does after a run follows what the run's user made (issue 46,
item 1; docs/design.md, "Least privilege"). Started as root, a run's folder
is the run's user's while it runs; this plants in it, as that user (the
run's own command, through run/drop_caps.sh's setpriv, once the launcher
is done): links to a root-only file as outputs (report.html.tmp,
report.html), a link to a root-only stand-in for /etc/shadow as an input of
the report (video.mp4), directory links (frames/, compare/) to a root-only
folder, named pipes (contact_sheet.png, another) and a hard link to a file
of its own outside the folder. Then it does what root does after a run
(./afm run's report, ./afm replay --compare): the targets are untouched,
nothing blocks, and the give-back (run/run_user.sh take) names what it
removed; a link root finds in a run folder all the same (left by an older
give-back) is refused and named by the report and by replay --compare. An
--out that is not a run's folder, or holds a third user's file, changes no
ownership at all."""
import os
import subprocess
import sys
import unittest

import e2e_support
from analysis import paths

sys.path.insert(0, paths.FAULTS_DIR)
import plant  # noqa: E402  (faults/plant.py: what the run's user plants, and the check that nothing followed it)

PY = sys.executable
AFM = os.path.join(e2e_support.SRC, "afm")
ROOT = os.geteuid() == 0
snapshot = plant.snapshot


@unittest.skipUnless(ROOT, "the run's user differs from the caller only when started as root")
class RootFollowsNothing(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        closed = e2e_support.closed_ancestor(e2e_support.BUILD)
        if closed:
            raise unittest.SkipTest(f"the build is under {closed}, which the run's user cannot traverse: no run drops to it")
        cls.top = e2e_support.tmpdir("root-paths")
        cls.t = plant.targets(cls.top)
        cls.victim, cls.shadow, cls.rootdir, cls.own = (cls.t[k] for k in ("victim", "shadow", "rootdir", "own"))
        cls.out = os.path.join(cls.top, "run")
        cmd = [e2e_support.IN_NETNS, "sh", "-c", plant.SCRIPT, e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out", cls.out,
               "--quiet"]
        cls.p = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=plant.environ(cls.out, cls.t))
        cls.run_uid = os.stat(cls.own).st_uid if os.path.exists(cls.own) else None

    @classmethod
    def tearDownClass(cls):
        plant.forget(cls.t)

    def untouched(self):
        self.assertEqual(plant.untouched(self.t), [])
        self.assertTrue(os.path.exists(self.own), "the run's user made its own file")

    def test_1_the_give_back_removes_and_names_what_was_planted(self):
        self.assertEqual(self.p.returncode, 0, self.p.stderr)
        for name in plant.PLANTED:
            self.assertIn(f"removed {os.path.join(self.out, name)} (", self.p.stderr)
        self.assertEqual(plant.left_behind(self.out), [])
        self.assertEqual([n for n, s in snapshot(self.out).items() if s[:2] != (0, 0) or s[2] & 0o022], [],
                         "every file root's, none writable by others")
        self.untouched()

    def test_2_the_report_as_root_follows_nothing_and_never_blocks(self):
        p = subprocess.run([PY, "-m", "analysis.run_report", self.out], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(os.path.join(self.out, "report.html")) as f:
            page = f.read()
        self.assertNotIn(plant.SECRET_MARK, page)
        self.untouched()

    def test_3_a_link_root_finds_all_the_same_is_refused_and_named(self):
        # as an older give-back left them: root's own links and pipe in a root-owned run folder
        d = e2e_support.tmpdir("leftovers")
        for name in ("run.json", "bus.lcmlog", "scene.yaml"):
            with open(os.path.join(self.out, name), "rb") as src, open(os.path.join(d, name), "wb") as dst:
                dst.write(src.read())
        os.symlink(self.shadow, os.path.join(d, "video.mp4"))
        os.symlink(self.victim, os.path.join(d, "report.html"))
        os.mkfifo(os.path.join(d, "contact_sheet.png"))
        p = subprocess.run([PY, "-m", "analysis.run_report", d], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn(f"{d}/video.mp4: refused: a symbolic link", p.stderr)
        self.assertIn(f"{d}/contact_sheet.png: refused: a named pipe", p.stderr)
        with open(os.path.join(d, "report.html")) as f:   # the link replaced by the page, not followed
            page = f.read()
        self.assertIn("<h2>Refused</h2>", page)
        self.assertIn("video.mp4: refused: a symbolic link", page)
        self.assertNotIn(plant.SECRET_MARK, page)
        self.assertFalse(os.path.islink(os.path.join(d, "report.html")))
        # ./afm replay --compare with compare/ a link into a root-only folder
        os.symlink(self.rootdir, os.path.join(d, "compare"))
        p = subprocess.run([AFM, "replay", d, "--compare"], capture_output=True, text=True, timeout=e2e_support.limit(540))
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"{d}/compare: refused: a symbolic link", p.stderr)
        self.untouched()
        # and a run folder still held by the run's user (its give-back never ran) is not read as root
        os.chown(d, self.run_uid, self.run_uid)
        p = subprocess.run([PY, "-m", "analysis.run_report", d], capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{d}: a folder of uid {self.run_uid}", p.stderr)
        self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
        os.chown(d, 0, 0)

    def test_4_replay_compare_writes_in_a_compare_folder_of_its_own(self):
        p = subprocess.run([AFM, "replay", self.out, "--compare"], capture_output=True, text=True, timeout=e2e_support.limit(540))
        self.assertIn(p.returncode, (0, 1), p.stderr)
        cmp = os.path.join(self.out, "compare")
        self.assertFalse(os.path.islink(cmp))
        self.assertTrue(os.path.isfile(os.path.join(cmp, "compare.md")))
        self.untouched()


@unittest.skipUnless(ROOT, "only root hands folders over")
class ARefusedOutChangesNoOwnership(unittest.TestCase):
    def folder(self, tag, is_run):
        d = os.path.join(e2e_support.tmpdir(tag), "out")
        os.mkdir(d, 0o755)
        script = os.path.join(d, "tool.sh")
        with open(script, "w") as f:
            f.write("#!/bin/sh\necho root's script\n")
        os.chmod(script, 0o755)
        other = os.path.join(d, "theirs.txt")
        with open(other, "w") as f:
            f.write("another user's\n")
        os.chown(other, 4321, 4321)
        if is_run:
            with open(os.path.join(d, "run.json"), "w") as f:
                f.write("{}")
        return d

    def test_a_folder_that_is_not_a_run(self):
        d = self.folder("not-a-run", False)
        before = snapshot(d)
        p = subprocess.run([e2e_support.IN_NETNS, e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out", d, "--quiet"],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"output folder {d} exists and holds something that is not a run", p.stderr)
        self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
        self.assertEqual(snapshot(d), before, "nothing changed hands")

    def test_a_run_folder_holding_a_third_users_file(self):
        d = self.folder("third-user", True)
        before = snapshot(d)
        p = subprocess.run([e2e_support.IN_NETNS, "true", "--out", d], capture_output=True, text=True, timeout=60,
                           env={k: v for k, v in os.environ.items() if k != "AFM_ALLOW_UID_0"})
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"{d}/theirs.txt is uid 4321's", p.stderr)
        self.assertEqual(snapshot(d), before, "nothing changed hands")


if __name__ == "__main__":
    e2e_support.main()
