"""What every row of the fault matrix shares (faults/faults.py): the paths,
the processes of a run, one afm_launch in its own namespace with hooks
while it runs (Run), a helper beside a run (beside), and what a finished
run left (its video, its trajectories, its log)."""
import json
import os
import signal
import subprocess
import time

from analysis import afmlog, paths, trajectory

SRC, BUILD, LAUNCH, IN_NETNS, DROP_CAPS = paths.ROOT, paths.BUILD, paths.LAUNCH, paths.IN_NETNS, paths.DROP_CAPS
os.environ.setdefault("AFM_BUILD", BUILD)   # the run's programs (run/two_hosts.sh) find the build there

PROCS = ["sim_afm", "fw_node", "operator", "renderer"]
# faults/forge.py --spoof: each forgery from the source port of the run's
# process that publishes its channel (through a raw socket): the program
# whose port it takes, and the channel
SPOOF_PORT = {"stop": ("afm_launch", "AFM_HEARTBEAT"), "pose": ("operator", "HAPTIC_POSE"), "fix": ("renderer", "HOST_OBJECT_FIX")}
# The link rows (docs/hosts.md): --link of each, and of the spoof rows on two hosts.
LINKS = {"link:clean": "delay=0.2,loss=0.02", "link:down": "delay=0.2", "link:loss": "delay=0.2,loss=0.1",
         "link:reorder": "delay=0.2,jitter=0.3,reorder=0.1", "spoof": "delay=0.2"}
LINK_BUS_URL = "udpm://239.255.76.67:7667?ttl=1"   # the bus across the link (bus/bus.hpp kLinkBusUrl)


def processes():
    """(pid, name, state, ppid, pgid) of every process, from /proc/PID/stat."""
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                st = f.read()
        except OSError:   # ended meanwhile
            continue
        fields = st[st.rindex(")") + 2:].split()
        yield int(d), st[st.index("(") + 1:st.rindex(")")], fields[0], int(fields[1]), int(fields[2])


def children(pid):
    """{name: pid} of the processes whose parent is `pid`."""
    return {name: p for p, name, _, ppid, _ in processes() if ppid == pid}


def signal_live(pid, sig):
    """os.kill, except that a process already ended (a zombie its parent has
    not reaped yet, which os.kill would signal without effect) raises
    ProcessLookupError like one that is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            st = f.read()
    except OSError:
        raise ProcessLookupError(pid)
    if st[st.rindex(")") + 2:].split()[0] == "Z":
        raise ProcessLookupError(pid)
    os.kill(pid, sig)


def netns_of(pid):
    """The network namespace of `pid` ("net:[N]"), or "" when it is gone."""
    try:
        return os.readlink(f"/proc/{pid}/ns/net")
    except OSError:
        return ""


def alive_in_groups(pgids):
    """Processes still alive (not zombies) in any of the process groups `pgids`."""
    return [p for p, _, state, _, pgid in processes() if state != "Z" and pgid in pgids]


class Run:
    """One afm_launch in its own namespace, with hooks while it runs."""

    def __init__(self, scene, out, extra=(), wrap=None, env=None, keep_caps=None, link=None, writes=None, outer=()):
        self.out = out
        cmd = [LAUNCH, "--scene", scene, "--out", out, "--quiet", "--stall-s", "20", *extra]
        if link is not None:   # two hosts (run/two_hosts.sh): the namespaces, the link, then the launcher
            cmd += ["--hosts", "2"]
            env = dict(env or os.environ, AFM_HOSTS="2", AFM_LINK=link, AFM_BUILD=BUILD)
        if wrap:
            cmd = wrap(cmd)
        # keep_caps (afm_netfault's row alone): the namespace's command keeps
        # those capabilities; beside() runs the launcher without them.
        if keep_caps:
            env = dict(env or os.environ, AFM_KEEP_CAPS=keep_caps)
        # the run's folder (or `writes`, the folder that holds what its
        # helper writes too), for in_netns.sh to hand to the run's user when
        # started as root (a wrapped command names it inside a shell's text)
        env = dict(env or os.environ, AFM_RUN_WRITES=writes or out)
        # outer: a command around the namespace's (disk:full's mount
        # namespace: the run's own privilege could not mount there)
        self.p = subprocess.Popen([*outer, IN_NETNS, *cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                  start_new_session=True, env=env)
        self.kids = {}

    def wait_kids(self, timeout=30):
        """Waits until the four bus processes run; returns {name: pid}."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout and self.p.poll() is None:
            self.kids = {k: v for k, v in children(self.launcher_pid()).items() if k in PROCS}
            if len(self.kids) == len(PROCS):
                return self.kids
            time.sleep(0.02)
        return self.kids

    def launcher_pid(self):
        # in_netns.sh execs unshare, which execs sh, which execs afm_launch: one pid
        # (for wrapped commands the launcher is the shell's child)
        kids = children(self.p.pid)
        return kids.get("afm_launch", self.p.pid)

    def finish(self, timeout=300):
        try:
            out, err = self.p.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self.p.pid, signal.SIGKILL)
            out, err = self.p.communicate()
            err += "\n(faults: timed out)"
        self.code, self.stdout, self.stderr = self.p.returncode, out, err
        self.rj = None
        try:
            with open(os.path.join(self.out, "run.json")) as f:
                self.rj = json.load(f)
        except (OSError, ValueError):
            pass
        return self


def video_opens(out):
    """(whether the run's video.mp4 opens, what afm_media said): an
    interrupted run closes its video too (the renderer ends on SIGTERM as
    when the run is over)."""
    path = os.path.join(out, "video.mp4")
    if not os.path.exists(path):
        return True, "no video"
    p = subprocess.run([paths.MEDIA, "frames", path], capture_output=True, text=True,
                       timeout=60)
    if p.returncode != 0:
        return False, f"video.mp4 does not open ({os.path.getsize(path)} bytes)"
    return True, f"video opens ({p.stdout.split()[0]} frames)"


def trajectories(out, blocks):
    """(analysis.trajectory.read of the run, ""), or (None, why) if the log does not read."""
    try:
        return trajectory.read(out, blocks), ""
    except Exception as e:  # a log that does not read is a finding, not a crash
        return None, str(e)


NOT_READY = 97   # beside(): the helper never said it was ready


def beside(helper, cmd, ready_log=None):
    """A shell command that runs `helper` in the background, then `cmd`, then
    stops the helper (SIGTERM) and waits for it; it exits with cmd's code.
    With `ready_log`, the helper's stderr goes there and cmd starts only once
    the helper has written "ready" to it (5 s at most, else exit NOT_READY)."""
    q = " ".join(f"'{c}'" for c in [DROP_CAPS, *cmd])   # the run itself without any capability the helper kept
    h = " ".join(f"'{c}'" for c in helper)
    if ready_log is None:
        start = f"{h} > /dev/null & h=$!; "
    else:
        start = (f"{h} 2> '{ready_log}' & h=$!; "
                 f"i=0; until grep -q ready '{ready_log}' 2>/dev/null; do i=$((i+1)); "
                 f"{{ [ $i -lt 500 ] && kill -0 $h 2>/dev/null; }} || exit {NOT_READY}; sleep 0.01; done; ")
    return ["sh", "-c", start + f"{q}; rc=$?; kill -TERM $h; wait $h; exit $rc"]


def log_reads(out):
    try:
        afmlog.load(os.path.join(out, "bus.lcmlog"), channels=["AFM_HEARTBEAT"])
        return True
    except Exception:
        return False
