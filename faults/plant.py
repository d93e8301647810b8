"""A hostile run's user (issue 46, item 1; docs/design.md, "Least
privilege"): what it plants in its run folder for root to follow after the
run, and how to tell that root followed nothing. One owner for
tests/e2e/test_root_paths.py and ./afm faults' planted:link row.

Started as root, a run's folder is the run's user's while it runs. SCRIPT
runs as that user, in the run's own command (after the launcher: "$0"
"$@"), and plants, in OUT: links to a root-only file as outputs
(report.html.tmp, report.html), a link to a root-only stand-in for
/etc/shadow as an input of the report (video.mp4), directory links (frames/,
compare/) to a root-only folder, named pipes (contact_sheet.png, logs/pipe)
and a hard link (hard.txt) to a file of its own outside the folder (OWN).

    t = targets(top)        # the root-only files and folder, in `top`
    env = environ(out, t)   # SCRIPT's environment
    ... run [IN_NETNS, "sh", "-c", SCRIPT, LAUNCH, ...] with env ...
    untouched(t)            # [] when no target changed
"""
import os
import stat

# What SCRIPT plants, relative to the run folder: each is removed and named
# by the give-back (run/run_user.sh take: "removed PATH (...)").
PLANTED = ("report.html.tmp", "report.html", "video.mp4", "frames", "compare", "contact_sheet.png", "logs/pipe", "hard.txt")
SECRET = "root:$6$stand-in-for-shadow$not-a-real-hash:19000:0:99999:7:::\n"
SECRET_MARK = "stand-in-for-shadow"   # in no output of a run that followed nothing

SCRIPT = r'''set -e
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


def snapshot(top):
    """{path: (uid, gid, mode, bytes)} of `top` and everything under it (links not followed)."""
    out = {}
    paths = [top] if not os.path.isdir(top) or os.path.islink(top) else []
    for d, dirs, files in os.walk(top):
        paths += [d] + [os.path.join(d, f) for f in dirs + files]
    for n in paths:
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


def targets(top):
    """Makes, in `top` (root's), the root-only targets: victim (a 0600
    file), shadow (a 0600 stand-in for /etc/shadow holding SECRET), rootdir
    (a 0700 folder holding kept.txt); and names own, a file the run's user
    makes in /tmp. Returns {name: path, "before": their snapshots}."""
    t = {"victim": os.path.join(top, "root-only.txt"), "shadow": os.path.join(top, "shadow"),
         "rootdir": os.path.join(top, "root-only-folder"), "own": os.path.join("/tmp", f"afm-plant-own-{os.getpid()}-{id(top)}")}
    for path, text in ((t["victim"], "root's own, 0600\n"), (t["shadow"], SECRET)):
        with open(path, "w") as f:
            f.write(text)
        os.chmod(path, 0o600)
    os.mkdir(t["rootdir"], 0o700)
    with open(os.path.join(t["rootdir"], "kept.txt"), "w") as f:
        f.write("root's folder\n")
    t["before"] = {p: snapshot(p) for p in (t["victim"], t["shadow"], t["rootdir"])}
    return t


def environ(out, t, base=None):
    """SCRIPT's environment: the run folder and the targets."""
    return dict(base if base is not None else os.environ, OUT=out, VICTIM=t["victim"], SHADOW=t["shadow"], ROOTDIR=t["rootdir"],
                OWN=t["own"])


def untouched(t):
    """What changed among the targets ([] when nothing did), and whether the
    run's user's own file is still its own and linked from the run no more."""
    changed = [p for p, snap in t["before"].items() if snapshot(p) != snap]
    if os.path.exists(t["own"]):
        st = os.stat(t["own"])
        if st.st_uid == 0:
            changed.append(f"{t['own']} became root's")
        if st.st_nlink != 1:
            changed.append(f"{t['own']} still linked ({st.st_nlink} links)")
    return changed


def forget(t):
    """Removes the run's user's own file (the targets stay in their folder)."""
    if os.path.exists(t["own"]):
        os.unlink(t["own"])
