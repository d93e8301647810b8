"""Shared helpers of the bench's end-to-end tests: where things are, how
to run a scene the way ./afm run does (in a fresh network namespace), and
how long a test may still wait (limit: within the budget ctest gives the
test file, AFM_TEST_BUDGET_S, from tests/timeouts.json)."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

SRC = os.environ["AFM_SOURCE"]
BUILD = os.environ["AFM_BUILD"]
from analysis import afmlog, paths  # noqa: E402,F401  (the project's package, installed in the venv)
LAUNCH = paths.LAUNCH
IN_NETNS = paths.IN_NETNS


# The seconds this test file's own waits must end within (ctest's limit less
# a margin, tests/timeouts.cmake), counted from its start; None when it is
# run by hand, outside ctest, where nothing kills it.
BUDGET_S = float(os.environ["AFM_TEST_BUDGET_S"]) if os.environ.get("AFM_TEST_BUDGET_S") else None
_started = time.monotonic()


def limit(seconds):
    """`seconds`, or what is left of the file's budget if that is less (at
    least 1 s): a wait given this ends, naming what it waited for, before
    ctest kills the file."""
    if BUDGET_S is None:
        return seconds
    return max(1.0, min(seconds, BUDGET_S - (time.monotonic() - _started)))


def closed_ancestor(path):
    """The first folder above `path` that others cannot traverse (no o+x),
    or None: started as root, a checkout under such a folder (a clone in
    /root, mode 700) cannot be reached by the run's user, and the run is
    refused unless uid 0 is allowed."""
    d = os.path.dirname(os.path.abspath(path))
    while True:
        if not os.stat(d).st_mode & 0o001:
            return d
        if d == "/":
            return None
        d = os.path.dirname(d)


def encoded_by_seq(msgs, blocks, field="seq"):
    """{seq: encoded bytes} of a run's own messages (seq of one of its blocks,
    the first message of each; the pose answering the last block's force may
    or may not be sent as the run stops): two runs' compared byte for byte."""
    out = {}
    for m in msgs:
        q = getattr(m, field)
        if 0 <= q < blocks:
            out.setdefault(q, m.encode())
    return out


# Started as root from a checkout the run's user cannot reach (a clone in
# /root, mode 700, as CI makes), a run is refused unless uid 0 is allowed
# (run/in_netns.sh): the suite allows it there, as before issue 46;
# test_privilege.py checks the refusal itself.
if os.geteuid() == 0 and closed_ancestor(BUILD):
    os.environ.setdefault("AFM_ALLOW_UID_0", "1")


def scene(name):
    return os.path.join(SRC, "scenes", name)


_root = None


def tmpdir(tag):
    """A fresh folder for a test's run or scene, inside this test file's own
    folder of runs (main() removes it when every test passed, and keeps it,
    naming it, when one failed)."""
    global _root
    if _root is None:
        script = os.path.splitext(os.path.basename(sys.argv[0]))[0] or "e2e"
        _root = tempfile.mkdtemp(prefix=f"afm-{script}-", dir=os.environ.get("AFM_TEST_TMP"))
        os.chmod(_root, 0o755)   # started as root, a run is the run's user (run/run_user.sh), who must reach it
    d = tempfile.mkdtemp(prefix=f"{tag}-", dir=_root)
    os.chmod(d, 0o755)
    return d


_result = None   # the running tests' result (main()): once it has a failure, cleanup() keeps what it is given


def main():
    """unittest.main for a test file: the runs of a file whose tests all
    passed are removed (unless AFM_KEEP_TEST_RUNS is set); those of a file
    with a failure are kept and named, for a person to look at."""
    import unittest

    class Result(unittest.TextTestResult):
        def __init__(self, *args, **kwargs):
            global _result
            super().__init__(*args, **kwargs)
            _result = self

    runner = unittest.TextTestRunner(resultclass=Result, verbosity=2)
    result = unittest.main(testRunner=runner, exit=False).result
    ok = result.wasSuccessful()
    if _root is not None and os.path.isdir(_root):
        if ok and not os.environ.get("AFM_KEEP_TEST_RUNS"):
            shutil.rmtree(_root, ignore_errors=True)
        else:
            print(f"e2e_support: the runs of these tests are kept in {_root}", file=sys.stderr)
    sys.exit(0 if ok else 1)


def run(scene_path, out, *extra, timeout=300):
    """Runs a scene like ./afm run, waiting `timeout` seconds at most (within
    the budget, limit()); returns (exit code, stdout, stderr, run.json or None)."""
    cmd = [IN_NETNS, LAUNCH, "--scene", scene_path, "--out", out, "--quiet", *extra]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=limit(timeout))
    rj = None
    path = os.path.join(out, "run.json")
    if os.path.exists(path):
        with open(path) as f:
            rj = json.load(f)
    return p.returncode, p.stdout, p.stderr, rj


def run_and_load(scene_name, tag, channels=None, *extra):
    """Runs scenes/<scene_name> into a fresh folder; returns (folder, exit
    code, stderr, run.json, decoded log)."""
    out = tmpdir(tag)
    code, _, err, rj = run(scene(scene_name), out, *extra)
    log = afmlog.load(os.path.join(out, "bus.lcmlog"), channels=channels)
    return out, code, err, rj, log


def write_scene(text, tag="scene"):
    d = tmpdir(tag)
    path = os.path.join(d, "scene.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def short_scene_2s(tag):
    """scenes/short.yaml for 2 simulated s (several cycles of every message
    reach every process once it listens), written under `tag`."""
    with open(scene("short.yaml")) as f:
        text = f.read().replace("duration_s: 0.6", "duration_s: 2.0")
    return write_scene(text, tag)


def cleanup(*dirs):
    """Removes runs as soon as their tests are done, unless a test of this
    file has failed (main() then keeps them all) or AFM_KEEP_TEST_RUNS is set."""
    if os.environ.get("AFM_KEEP_TEST_RUNS") or (_result is not None and not _result.wasSuccessful()):
        return
    for d in dirs:
        shutil.rmtree(d, ignore_errors=True)


def descendants(pid):
    """Every process below `pid` (children, theirs, ...), from /proc."""
    parent = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    parent[int(d)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError):
                continue
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        out += kids
        todo += kids
    return out


def sweep_processes(root_pid):
    """{"sweep": [pid...], "worker": [pid...]} below `root_pid`: the sweep's
    own Python processes (analysis.sweep: its client and scheduler, and as
    root the one that dropped to the sweep's uid too) and the Dask worker
    processes (those a nanny spawns through multiprocessing), from /proc."""
    seen = {"sweep": [], "worker": []}
    for pid in descendants(root_pid):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read()
        except OSError:
            continue
        if b"spawn_main" in cmd and b"resource_tracker" not in cmd:
            seen["worker"].append(pid)
        elif b"analysis.sweep" in cmd:
            seen["sweep"].append(pid)
    return seen
