"""Where the checkout, its build and its programs are."""
import os
import tempfile

ROOT = os.environ.get("AFM_SOURCE") or os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.environ.get("AFM_BUILD") or os.path.join(ROOT, "build", "main")
SIM_AFM = os.path.join(BUILD, "sim_afm", "sim_afm")
# host/'s programs, built into one folder (CMakeLists.txt's AFM_HOST_BIN)
HOST_BIN = os.path.join(BUILD, "host")
LAUNCH = os.path.join(HOST_BIN, "afm_launch")
REPLAY = os.path.join(HOST_BIN, "afm_replay")
REPLAY_PERTURBED = os.path.join(HOST_BIN, "afm_replay_perturbed")   # tests: a card with a perturbed gain
FW_NODE = os.path.join(HOST_BIN, "fw_node")
OPERATOR = os.path.join(HOST_BIN, "operator")
RENDERER = os.path.join(HOST_BIN, "renderer")
VIEW_BRIDGE = os.path.join(HOST_BIN, "afm_view_bridge")   # a viewed run's frames out of its namespace
CALC = os.path.join(HOST_BIN, "calc", "afm_calc")
MEDIA = os.path.join(HOST_BIN, "afm_media")          # tools/: a video's frame count
NETFAULT = os.path.join(HOST_BIN, "afm_netfault")    # faults/: the kernel-level fault injector
# run/: the namespace and privilege wrappers every run passes through
RUN_DIR = os.path.join(ROOT, "run")
IN_NETNS = os.path.join(RUN_DIR, "in_netns.sh")
RUN_USER = os.path.join(RUN_DIR, "run_user.sh")   # who a run is when started as root
DROP_CAPS = os.path.join(RUN_DIR, "drop_caps.sh")  # the one place a process becomes that user
RUN_UID = os.path.join(RUN_DIR, "run_uid.sh")      # the range of the runs' uids and their leases
# faults/: the fault matrix, its injectors, the forgers (their modules are
# imported from here: hostile, plant)
FAULTS_DIR = os.path.join(ROOT, "faults")
FAULTS = os.path.join(FAULTS_DIR, "faults.py")
FORGE = os.path.join(FAULTS_DIR, "forge.py")
HOSTILE = os.path.join(FAULTS_DIR, "hostile.py")
# tools/: the developer's tools
SPY_REPLAY = os.path.join(RUN_DIR, "spy_replay.sh")
ARM_BUILD = os.path.join(ROOT, "build", "arm")
# The programs a run is made of: their contents identify the build a sweep
# point was measured with (resume reruns a point when any of them changed).
RUN_PROGRAMS = [
    SIM_AFM,
    FW_NODE,
    OPERATOR,
    RENDERER,
    LAUNCH,
    REPLAY,
]


def bench_folder(out, prefix):
    """A benchmark's folder for its runs: `out`, made if it is not there, or
    else a new temporary one; (path, kept: whether `out` was given). Open to
    the run's user (0755): a run started as root is that user's
    (run/run_user.sh), who must reach it."""
    path = out or tempfile.mkdtemp(prefix=prefix)
    os.makedirs(path, exist_ok=True)
    os.chmod(path, 0o755)
    return path, out is not None


# bus/: the report's one pass over a log (log_series_c.h, analysis/report_series.py)
LOG_SERIES_LIB = os.path.join(BUILD, "bus", "libafm_log_series_c.so")
