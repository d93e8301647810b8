"""Nothing root does after a run follows what the run's user made (issue 46,
item 1; docs/design.md, "Least privilege"). Started as root, a run's folder
is the run's user's while it runs; this plants in it, as that user (the
run's own command, through tools/drop_caps.sh's setpriv, once the launcher
is done): links to a root-only file as outputs (report.html.tmp,
report.html), a link to a root-only stand-in for /etc/shadow as an input of
the report (video.mp4), directory links (frames/, compare/) to a root-only
folder, named pipes (contact_sheet.png, another) and a hard link to a file
of its own outside the folder. Then it does what root does after a run
(./afm run's report, ./afm replay --compare): the targets are untouched,
nothing blocks, and the give-back (tools/run_user.sh take) names what it
removed; a link root finds in a run folder all the same (left by an older
give-back) is refused and named by the report and by replay --compare. An
--out that is not a run's folder, or holds a third user's file, changes no
ownership at all."""
import os
import stat
import subprocess
import sys
import unittest

import benchtest

PY = sys.executable
AFM = os.path.join(benchtest.SRC, "afm")
ROOT = os.geteuid() == 0
SECRET = "root:$6$stand-in-for-shadow$not-a-real-hash:19000:0:99999:7:::\n"


def snapshot(top):
    """{path: (uid, gid, mode, bytes)} of everything under `top` (links not followed)."""
    out = {}
    for d, dirs, files in os.walk(top):
        for n in [d] + [os.path.join(d, f) for f in dirs + files]:
            st = os.lstat(n)
            data = None
            if stat.S_ISREG(st.st_mode):
                with open(n, "rb") as f:
                    data = f.read()
            out[n] = (st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode), data)
    return out


def left_behind(top):
    """What under `top` is neither a regular file with one link nor a folder."""
    bad = []
    for d, dirs, files in os.walk(top):
        for n in [os.path.join(d, f) for f in dirs + files]:
            st = os.lstat(n)
            if not (stat.S_ISDIR(st.st_mode) or (stat.S_ISREG(st.st_mode) and st.st_nlink == 1)):
                bad.append(n)
    return bad


# Run as the run's user, after the launcher ("$0" "$@"): OUT the run
# folder, VICTIM the root-only file, SHADOW the stand-in, ROOTDIR the
# root-only folder, OWN a file of the run's user outside the run.
PLANT = r'''set -e
"$0" "$@"
cd "$OUT"
ln -s "$VICTIM" report.html.tmp
ln -s "$VICTIM" report.html
rm -f video.mp4 video.webm video.avi; ln -s "$SHADOW" video.mp4
rm -rf frames; ln -s "$ROOTDIR" frames
ln -s "$ROOTDIR" compare
rm -f contact_sheet.png; mkfifo contact_sheet.png
mkfifo logs/pipe
echo "the run's user's" > "$OWN"
ln "$OWN" hard.txt
'''


@unittest.skipUnless(ROOT, "the run's user differs from the caller only when started as root")
class RootFollowsNothing(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        closed = benchtest.closed_ancestor(benchtest.BUILD)
        if closed:
            raise unittest.SkipTest(f"the build is under {closed}, which the run's user cannot traverse: no run drops to it")
        cls.top = benchtest.tmpdir("root-paths")
        cls.victim = os.path.join(cls.top, "root-only.txt")
        cls.shadow = os.path.join(cls.top, "shadow")
        cls.rootdir = os.path.join(cls.top, "root-only-folder")
        # a file the run's user makes outside the run (where it may: /tmp), then links into it
        cls.own = os.path.join("/tmp", f"afm-test-root-paths-own-{os.getpid()}")
        for path, text in ((cls.victim, "root's own, 0600\n"), (cls.shadow, SECRET)):
            with open(path, "w") as f:
                f.write(text)
            os.chmod(path, 0o600)
        os.mkdir(cls.rootdir, 0o700)
        with open(os.path.join(cls.rootdir, "kept.txt"), "w") as f:
            f.write("root's folder\n")
        cls.before = {p: snapshot(p) for p in (cls.victim, cls.shadow, cls.rootdir)}
        cls.out = os.path.join(cls.top, "run")
        cmd = [benchtest.IN_NETNS, "sh", "-c", PLANT, benchtest.LAUNCH, "--scene", benchtest.scene("short.yaml"), "--out", cls.out,
               "--quiet"]
        cls.p = subprocess.run(cmd, capture_output=True, text=True, timeout=300,
                               env=dict(os.environ, OUT=cls.out, VICTIM=cls.victim, SHADOW=cls.shadow, ROOTDIR=cls.rootdir, OWN=cls.own))
        cls.run_uid = os.stat(cls.own).st_uid if os.path.exists(cls.own) else None

    @classmethod
    def tearDownClass(cls):
        if os.path.exists(cls.own):
            os.unlink(cls.own)

    def untouched(self):
        for path, snap in self.before.items():
            self.assertEqual(snapshot(path), snap, f"{path} changed")
        st = os.stat(self.own)
        self.assertNotEqual(st.st_uid, 0, "the run's user's own file is still its own")
        self.assertEqual(st.st_nlink, 1, "and linked from the run no more")

    def test_1_the_give_back_removes_and_names_what_was_planted(self):
        self.assertEqual(self.p.returncode, 0, self.p.stderr)
        for name in ("report.html.tmp", "report.html", "video.mp4", "frames", "compare", "contact_sheet.png", "logs/pipe", "hard.txt"):
            self.assertIn(f"removed {os.path.join(self.out, name)} (", self.p.stderr)
        self.assertEqual(left_behind(self.out), [])
        self.assertEqual([n for n, s in snapshot(self.out).items() if s[:2] != (0, 0) or s[2] & 0o022], [],
                         "every file root's, none writable by others")
        self.untouched()

    def test_2_the_report_as_root_follows_nothing_and_never_blocks(self):
        p = subprocess.run([PY, "-m", "analysis.run_report", self.out], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(os.path.join(self.out, "report.html")) as f:
            page = f.read()
        self.assertNotIn("stand-in-for-shadow", page)
        self.untouched()

    def test_3_a_link_root_finds_all_the_same_is_refused_and_named(self):
        # as an older give-back left them: root's own links and pipe in a root-owned run folder
        d = benchtest.tmpdir("leftovers")
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
        self.assertNotIn("stand-in-for-shadow", page)
        self.assertFalse(os.path.islink(os.path.join(d, "report.html")))
        # ./afm replay --compare with compare/ a link into a root-only folder
        os.symlink(self.rootdir, os.path.join(d, "compare"))
        p = subprocess.run([AFM, "replay", d, "--compare"], capture_output=True, text=True, timeout=benchtest.limit(540))
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
        p = subprocess.run([AFM, "replay", self.out, "--compare"], capture_output=True, text=True, timeout=benchtest.limit(540))
        self.assertIn(p.returncode, (0, 1), p.stderr)
        cmp = os.path.join(self.out, "compare")
        self.assertFalse(os.path.islink(cmp))
        self.assertTrue(os.path.isfile(os.path.join(cmp, "compare.md")))
        self.untouched()


@unittest.skipUnless(ROOT, "only root hands folders over")
class ARefusedOutChangesNoOwnership(unittest.TestCase):
    def folder(self, tag, is_run):
        d = os.path.join(benchtest.tmpdir(tag), "out")
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
        p = subprocess.run([benchtest.IN_NETNS, benchtest.LAUNCH, "--scene", benchtest.scene("short.yaml"), "--out", d, "--quiet"],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"output folder {d} exists and holds something that is not a run", p.stderr)
        self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
        self.assertEqual(snapshot(d), before, "nothing changed hands")

    def test_a_run_folder_holding_a_third_users_file(self):
        d = self.folder("third-user", True)
        before = snapshot(d)
        p = subprocess.run([benchtest.IN_NETNS, "true", "--out", d], capture_output=True, text=True, timeout=60,
                           env={k: v for k, v in os.environ.items() if k != "AFM_ALLOW_UID_0"})
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"{d}/theirs.txt is uid 4321's", p.stderr)
        self.assertEqual(snapshot(d), before, "nothing changed hands")


if __name__ == "__main__":
    benchtest.main()
