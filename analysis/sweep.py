"""./afm sweep: a scene's fidelity knobs turned, each point an ordinary run
in its own network namespace, its errors against the simulator's truth and
its costs measured from the run itself; a CSV, JSON, a table, Pareto plots
and one report.html. Points run on Dask distributed: a LocalCluster by
default, an existing cluster with --scheduler ADDRESS, SLURM jobs with
--cluster slurm (analysis/slurm_engine.py); each TLS with
credentials (analysis/engine.py); the client reads results as JSON, never
pickled. Started as root with a local cluster, the client and scheduler are
one leased uid and each worker another (analysis/sweep_users.py). Knob names
and values reach sweep.json, sweep.csv, the report and the terminal through
the one escaper (analysis/text.py, shown_points).

A point is known by a hash of its scene (the base scene with the point's
settings, and without frames, video or contact sheet unless --frames) and
of the build (the run's programs, hashed once per sweep): running the sweep
again into the same folder runs only the points it does not have yet.
Every point's scene is checked once, before anything starts, on every core.
Points go to the workers in batches (batch_size): a task per batch keeps
the engine's overhead under 1 % of the points' time."""
import argparse
import concurrent.futures
import hashlib
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time

import yaml

from analysis import knobs as K
from analysis import engine, paths, point, slurm_engine, sweep_report, sweep_users
from analysis.text import printable

USAGE = """usage: ./afm sweep SCENE --vary KEY=V1,V2,... [--vary ...] [options]
       ./afm sweep SWEEP.yaml [options]

  Runs every combination of the knobs' values as its own run of SCENE (each in
  its own network namespace), measures each point's errors against the
  simulator's truth and its costs, and writes into --out: sweep.csv,
  sweep.json, plots/ (Pareto plots, PNG and SVG) and report.html. A table
  on stdout, a progress line while it runs.

  A knob is a scene key (firmware.adc_bits, firmware.word_bits,
  firmware.compensate, sample_rate_hz, block_hz, sample.wire.segments,
  sample.wire.friction_points, outputs.image_px, outputs.update_mode, ...)
  or effects.NAME=on,off. SWEEP.yaml: {scene: FILE, vary: {KEY: [values]},
  out: DIR, repeat: N} (paths relative to the file).

options:
  --vary KEY=V1,V2,...  a knob and its values (repeatable)
  --out DIR             output folder (default runs/sweep-SCENENAME); an
                        earlier sweep's folder is resumed: done points are kept
  --repeat N            runs per point (default 1): costs as the median and
                        the spread; errors must repeat exactly
  --workers N           a local Dask cluster of N workers (default: one per core),
                        on 127.0.0.1, TLS with credentials made for this sweep;
                        started as root, its client and scheduler are a uid
                        leased for the sweep and each worker another, without
                        capabilities (docs/sweeps.md)
  --scheduler ADDRESS   an existing Dask cluster (tls://HOST:PORT) whose
                        workers have this checkout, built, at the same path
                        (docs/sweeps.md: python -m analysis.cluster)
  --tls-ca FILE, --tls-cert FILE, --tls-key FILE
                        the cluster's CA and this client's certificate and key
                        (PEM), for --scheduler tls://...
  --insecure            allow a plain tcp:// --scheduler (anyone who reaches it
                        can run code as its workers' user)
  --cluster slurm       the workers are SLURM jobs (dask-jobqueue), --workers N
                        of them (default: one per core), each one
                        single-threaded worker; the scheduler is this process,
                        TLS (--tls-* files, or credentials made for the sweep);
                        a job ended by its walltime is replaced and its points
                        run again (docs/sweeps.md, "On a SLURM cluster")
  --partition P, --account A, --time T, --job-mem M
                        each job's sbatch -p, -A, -t (walltime: MINUTES or
                        HH:MM:SS) and --mem (default: none asked)
  --cluster-host ADDR   the scheduler's address, which the jobs' nodes reach
                        (default 127.0.0.1: a cluster of this machine)
  --no-callgrind        skip the firmware's instructions per sample
  --frames              keep the scene's frames, video and contact sheet in
                        each point's run (default: none; run.json, the log
                        and the fidelity figures are kept either way)
  --timeout-s S         a point's run is killed after S s (default: 60 s + 40 x
                        the scene's duration)
  -h, --help            this text
exit: 0 every point measured; 1 some point failed (reported, the others kept);
      2 bad input (named before anything starts); 130 interrupted (done points kept)
"""


class SweepError(Exception):
    """Bad input, named: the sweep exits 2 before anything starts."""


def parse_args(argv):
    p = argparse.ArgumentParser(prog="./afm sweep", add_help=False, usage=USAGE)
    p.add_argument("target", nargs="?")
    p.add_argument("--vary", action="append", default=[])
    p.add_argument("--out")
    p.add_argument("--repeat", type=int)
    p.add_argument("--workers", type=int)
    p.add_argument("--scheduler")
    p.add_argument("--tls-ca")
    p.add_argument("--tls-cert")
    p.add_argument("--tls-key")
    p.add_argument("--insecure", action="store_true")
    p.add_argument("--cluster", choices=["slurm"])
    p.add_argument("--partition")
    p.add_argument("--account")
    p.add_argument("--time")
    p.add_argument("--job-mem")
    p.add_argument("--cluster-host", default="127.0.0.1")
    p.add_argument("--no-callgrind", action="store_true")
    p.add_argument("--frames", action="store_true")
    p.add_argument("--timeout-s", type=float)
    p.add_argument("-h", "--help", action="store_true")
    a, rest = p.parse_known_args(argv)
    if a.help:
        from analysis import helptext
        print(helptext.text("sweep") + "\n\n" + USAGE, end="")
        sys.exit(0)
    if rest:
        raise SweepError(f"unknown argument {rest[0]!r} (see ./afm sweep --help)")
    if not a.target:
        raise SweepError("which scene or sweep file? (see ./afm sweep --help)")
    if a.workers is not None and a.workers < 1:
        raise SweepError(f"--workers {a.workers}: at least 1")
    if a.workers is not None and a.scheduler:
        raise SweepError("--workers and --scheduler: one or the other (a cluster has its own workers)")
    if a.repeat is not None and a.repeat < 1:
        raise SweepError(f"--repeat {a.repeat}: at least 1")
    tls = [f for f, v in (("--tls-ca", a.tls_ca), ("--tls-cert", a.tls_cert), ("--tls-key", a.tls_key)) if v]
    check_cluster_args(a, tls)
    if (tls and not a.cluster or a.insecure) and not a.scheduler:
        raise SweepError(f"{(tls or ['--insecure'])[0]}: only with --scheduler (the local cluster makes its own credentials)")
    if a.scheduler:
        try:
            scheme, _, _ = engine.parse_address(a.scheduler, a.insecure)
        except engine.EngineError as e:
            raise SweepError(str(e)) from None
        if scheme == "tcp" and tls:
            raise SweepError(f"{tls[0]} with a tcp:// --scheduler: TLS needs a tls:// address")
    return a


def check_cluster_args(a, tls):
    """--cluster slurm's options: with it alone, its TLS files all or none."""
    jobs = [f for f, v in (("--partition", a.partition), ("--account", a.account), ("--time", a.time),
                           ("--job-mem", a.job_mem)) if v]
    if a.cluster_host != "127.0.0.1":
        jobs.append("--cluster-host")
    if jobs and not a.cluster:
        raise SweepError(f"{jobs[0]}: only with --cluster slurm")
    if a.cluster and a.scheduler:
        raise SweepError("--cluster and --scheduler: one or the other (--scheduler is a cluster already running)")
    if a.cluster and a.insecure:
        raise SweepError("--cluster slurm with --insecure: the SLURM engine is TLS only")
    if a.cluster and tls and len(tls) != 3:
        raise SweepError(f"{tls[0]}: --cluster slurm takes --tls-ca, --tls-cert and --tls-key together, or none "
                         f"(credentials made for the sweep)")


MAX_INPUT_BYTES = 4 << 20   # a scene or sweep file larger than this is refused (the scene reader's own cap)


def read_yaml(path, what):
    """The YAML of `path`, a scene or sweep file (what: which), or SweepError
    in one line: not a regular file, over MAX_INPUT_BYTES, not UTF-8, not
    YAML, or nested deeper than the parser's stack (a file 5 000 levels deep
    raised RecursionError from PyYAML's composer)."""
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise SweepError(f"{path}: the {what} is not a regular file")
        if st.st_size > MAX_INPUT_BYTES:
            raise SweepError(f"{path}: the {what} is {st.st_size} bytes, more than a {what} may be ({MAX_INPUT_BYTES})")
        with open(path, encoding="utf-8") as f:
            return yaml.safe_load(f)
    except OSError as e:
        raise SweepError(f"{path}: cannot read the {what} ({e.strerror})") from None
    except UnicodeDecodeError:
        raise SweepError(f"{path}: the {what} is not UTF-8 text") from None
    except yaml.YAMLError as e:
        raise SweepError(f"{path}: the {what} is not YAML ({' '.join(str(e).split())[:200]})") from None
    except RecursionError:
        raise SweepError(f"{path}: the {what} is nested too deep to read") from None


def is_sweep_file(path):
    d = read_yaml(path, "scene or sweep file")
    return isinstance(d, dict) and "vary" in d


def check_distinct(knobs, scene, sources):
    """Refuses a knob given the same value twice (equal numbers, or two
    values that make the same scene: effects.X=on,yes): its points would
    run the same scene again (a sweep of four knobs each given 10 six times
    ran 1 296 identical points)."""
    for key, values in knobs:
        seen = {}
        for v in values:
            number = isinstance(v, (int, float)) and not isinstance(v, bool)
            same = ("number", float(v)) if number else ("scene", yaml.safe_dump(K.apply(scene or {}, {key: v}), sort_keys=True))
            if same in seen:
                raise SweepError(f"{sources.get(key, key)}: {key} has the value {seen[same]!r} and {v!r}, the same point twice; "
                                 f"give each value once")
            seen[same] = v


def plan(a):
    """(base scene path, base scene dict, [(key, values)], out, repeat, sources)"""
    if not os.path.exists(a.target):
        raise SweepError(f"{a.target}: no such scene or sweep file")
    out, repeat = a.out, a.repeat
    sources = {}
    if is_sweep_file(a.target):
        scene_path, knobs, f_out, f_repeat = K.load_sweep_file(a.target)
        out = out or f_out
        repeat = repeat or f_repeat
        for k, _ in knobs:
            sources[k] = f"{a.target}: vary.{k}"
    else:
        scene_path, knobs = a.target, []
    given = {}
    for v in a.vary:
        key, values = K.parse_vary(v)
        if key in given:   # the last of two would win silently
            raise SweepError(f"--vary {v}: {key} is already varied by --vary {given[key]}; give each knob once")
        given[key] = v
        knobs = [(k, vs) for k, vs in knobs if k != key] + [(key, values)]   # over the sweep file's
        sources[key] = f"--vary {v}"
    if not knobs:
        raise SweepError(f"{a.target}: nothing to vary (give --vary KEY=V1,V2 or a sweep file with vary:)")
    scene = read_yaml(scene_path, "scene")
    if not isinstance(scene, dict):
        raise SweepError(f"{scene_path}: a scene is a mapping of keys (name, sample, ...)")
    check_distinct(knobs, scene, sources)
    name = scene.get("name") or os.path.splitext(os.path.basename(scene_path))[0]
    out = os.path.abspath(out or os.path.join(paths.ROOT, "runs", f"sweep-{name}"))
    return os.path.abspath(scene_path), scene, knobs, out, repeat or 1, sources


def check_scene(path):
    """afm_launch --check: the scene's validator and the card's rules."""
    p = subprocess.run([paths.LAUNCH, "--check", "--scene", path], capture_output=True, text=True)
    return p.returncode, p.stderr.strip()


VALIDATED_ENV = "AFM_SWEEP_VALIDATED"   # set by root's process for the sweep's user: checked once, not twice


def validate(scene_path, scene, points, sources):
    """Every point's scene checked before anything starts, on every core;
    a refusal names the first refused point's knobs (in the grid's order),
    where they came from, and the validator's words."""
    code, msg = check_scene(scene_path)
    if code != 0:
        raise SweepError(msg or f"{scene_path}: the scene does not validate")
    with tempfile.TemporaryDirectory(prefix="afm-sweep-check-") as tmp:
        files = []
        for i, settings in enumerate(points):
            path = os.path.join(tmp, f"point-{i}.yaml")
            with open(path, "w") as f:
                yaml.safe_dump(K.apply(scene, settings), f, sort_keys=False)
            files.append(path)
        with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 1) as ex:
            for settings, path, (code, msg) in zip(points, files, ex.map(check_scene, files)):
                if code != 0:
                    detail = msg.replace(path + ": ", "").replace(path, "the point's scene")
                    named = "; ".join(sources.get(k, k) for k in settings)
                    raise SweepError(f"point {K.label(settings)} ({named}): {detail}")


# What a point's run leaves out unless the sweep asks (--frames): the
# frames, the video and the contact sheet (docs/scenes.md, outputs).
NO_FRAMES = {"png": False, "video": "none", "contact_sheet_frames": 0}


def point_scene(scene, settings, frames):
    """The scene a point runs: the base with its settings, and without
    frames, video or contact sheet unless `frames`."""
    s = K.apply(scene, settings)
    if not frames:
        s["outputs"] = dict(s.get("outputs") or {}, **NO_FRAMES)
    return s


def batch_size(n_points, n_workers):
    """Points per Dask task: about 16 tasks per worker, at most 4 points each
    (a task's overhead, some ms, is then far under 1 % of its points' time,
    and the last tasks leave a worker idle a few seconds at most)."""
    return max(1, min(4, -(-n_points // (16 * max(1, n_workers)))))


def build_id():
    """A hash of the run's programs: a point measured with another build is
    measured again."""
    h = hashlib.sha256()
    for p in paths.RUN_PROGRAMS:
        try:
            with open(p, "rb") as f:
                h.update(hashlib.sha256(f.read()).digest())
        except OSError:
            raise SweepError(f"{p}: not built (./afm build)") from None
    return h.hexdigest()[:16]


def point_id(scene, build):
    return hashlib.sha256((json.dumps(scene, sort_keys=True) + build).encode()).hexdigest()[:12]


def arm_sizes():
    """{module: Cortex-M4 text bytes} of the firmware, built for the M4 as
    ./afm bench firmware builds it; None without the toolchain."""
    if not shutil.which("arm-none-eabi-size"):
        return None
    arm = paths.ARM_BUILD
    if not os.path.exists(os.path.join(arm, "build.ninja")):
        subprocess.run(["cmake", "-S", paths.ROOT, "-B", arm, "-G", "Ninja", "-DAFM_FIRMWARE_ONLY=ON",
                        f"-DCMAKE_TOOLCHAIN_FILE={paths.ROOT}/cmake/arm-none-eabi.cmake", "-DCMAKE_BUILD_TYPE=Release"],
                       check=True, capture_output=True)
    subprocess.run(["cmake", "--build", arm, "--target", "afm_firmware"], check=True, capture_output=True)
    p = subprocess.run(["arm-none-eabi-size", os.path.join(arm, "firmware", "libafm_firmware.a")], capture_output=True,
                       text=True, check=True)
    sizes = {}
    for line in p.stdout.splitlines()[1:]:
        f = line.split()
        if len(f) >= 6:
            sizes[f[5].replace(".c.obj", "")] = int(f[0])
    return sizes


def as_run_users(a, argv):
    """Started as root with a local cluster, the sweep runs as users of its
    own (analysis/sweep_users.py): its client and scheduler one leased uid,
    each worker another. Here, as root, first: the input is validated (bad
    input named before anything is made) and the Cortex-M4 sizes measured
    (they build into the checkout). Returns the sweep's exit code, or None
    when it goes on as root (said on stderr)."""
    scene_path, scene, knobs, out, _, sources = plan(a)
    t0 = time.monotonic()
    validate(scene_path, scene, K.grid(knobs), sources)
    os.environ[VALIDATED_ENV] = f"{time.monotonic() - t0:.3f}"   # for the sweep's user, who checks nothing again
    try:
        return sweep_users.run(argv, workers_wanted(a), out, arm_sizes())
    except sweep_users.UsersError as e:
        raise SweepError(str(e)) from None


def as_job_user(a, argv):
    """--cluster slurm started as root: the input validated and the
    Cortex-M4 sizes measured here, then the sweep again as the runs' user,
    whose jobs they are (slurm_engine.as_job_user)."""
    scene_path, scene, knobs, out, _, sources = plan(a)
    t0 = time.monotonic()
    validate(scene_path, scene, K.grid(knobs), sources)
    os.environ[VALIDATED_ENV] = f"{time.monotonic() - t0:.3f}"   # for the sweep's user, who checks nothing again
    return slurm_engine.as_job_user(argv, out, arm_sizes())


def workers_wanted(a):
    return a.workers or os.cpu_count() or 1


def load_done(path, build):
    try:
        with open(path) as f:
            rec = json.load(f)
    except (OSError, ValueError):
        return None
    return rec if rec.get("status") == "ok" and rec.get("build_id") == build else None


class Progress:
    def __init__(self, total, done_before):
        self.total, self.done, self.failed, self.t0 = total, done_before, 0, time.monotonic()
        self.new_done, self.durations = 0, []
        self.points_wall_s = None   # from the first submission to the last point
        self.engine_start_s = None   # the local cluster's start (its workers joined), or the connection's
        self.tty = sys.stderr.isatty()

    def show(self, running, final=False):
        left = self.total - self.done - self.failed
        eta = ""
        if self.durations and left:
            per = sum(self.durations) / len(self.durations)
            eta = f"   about {per * left / max(1, running):.0f} s left"
        line = f"sweep: {self.done + self.failed} / {self.total} points ({self.done} done, {running} running, " \
               f"{self.failed} failed){eta}   {time.monotonic() - self.t0:.0f} s"
        if self.tty:
            sys.stderr.write("\r" + line.ljust(100) + ("\n" if final else ""))
        elif final or int(time.monotonic() - self.t0) % 10 == 0:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()


def start_engine(a):
    """(client, cluster or None, the engine in words); EngineError names a
    cluster that cannot be used."""
    if a.cluster == "slurm":
        n = workers_wanted(a)
        try:
            client, cluster = slurm_engine.start(a, n, a.out)
        except slurm_engine.SlurmError as e:
            raise engine.EngineError(str(e)) from None
        cluster.afm_workers = n
        return client, cluster, f"SLURM through dask-jobqueue, {n} job(s) of one worker, TLS"
    if a.scheduler:
        client = engine.connect(a.scheduler, a.tls_ca, a.tls_cert, a.tls_key, a.insecure)
        return client, None, f"Dask cluster at {a.scheduler}"
    n = workers_wanted(a)
    if sweep_users.TLS_FD_ENV in os.environ:   # started by root's sweep_users.run: the workers are its to start
        client, cluster = sweep_users.serve_scheduler(n)
        return client, cluster, f"Dask local cluster, {n} worker(s) on 127.0.0.1, TLS, each a user of its own"
    client, cluster = engine.local_cluster(n)
    return client, cluster, f"Dask local cluster, {n} worker(s) on 127.0.0.1, TLS"


def records_of(f, batch):
    """A finished future's point records, one per task of its batch; a
    failed task, a refused answer or an answer that is not the batch's is
    each point's failure, named."""
    if f.status == "finished":
        try:
            recs = engine.results_of(f)
            if [r.get("id") for r in recs] == [t["id"] for t in batch]:
                return recs
            error = "the worker's answer was refused: its points are not the batch's"
        except engine.EngineError as e:
            error = str(e)
    else:   # the task's exception is never fetched: it would arrive pickled
        error = f"the worker failed the task ({f.status})"
    return [{"id": t["id"], "settings": t["settings"], "label": t["label"], "status": "failed", "dir": t["dir"],
             "failure": {"exit_code": -1, "error": error}} for t in batch]


def submit_batches(client, tasks, n_workers):
    """{future: its batch}: the tasks in batches (batch_size), a Dask task each."""
    size = batch_size(len(tasks), n_workers)
    batches = [tasks[i:i + size] for i in range(0, len(tasks), size)]
    return {client.submit(point.run_points_json, b, key=f"afm-points-{b[0]['id']}-{len(b)}", pure=False): b
            for b in batches}


def run_points(a, tasks, prog, started=None):
    """Submits the tasks in batches; returns their records (failed ones
    included) and the engine in words. started: start_engine's answer, if
    already had."""
    t0 = time.monotonic()
    client, cluster, engine_name = started or start_engine(a)
    prog.engine_start_s = time.monotonic() - t0
    records = []
    futures = {}
    t0 = time.monotonic()
    try:
        # SLURM's jobs join as the queue starts them: batched for as many as were asked
        futures = submit_batches(client, tasks, getattr(cluster, "afm_workers", None) or max(1, len(client.nthreads())))
        pending = set(futures)
        while pending:
            time.sleep(0.5)
            for f in [f for f in pending if f.status in ("finished", "error", "cancelled")]:
                pending.discard(f)
                for rec in records_of(f, futures[f]):
                    records.append(rec)
                    if rec["status"] == "ok":
                        prog.done += 1
                        prog.durations.append(rec.get("point_wall_s", 0.0))
                    else:
                        prog.failed += 1
            # tasks assigned to workers, at most one per worker thread at a time
            nthreads = client.nthreads()
            running = sum(min(len(v), nthreads.get(w, 1)) for w, v in client.processing().items())
            prog.show(running)
        prog.show(0, final=True)
        prog.points_wall_s = time.monotonic() - t0
    except KeyboardInterrupt:
        for f in futures:
            f.cancel()
        raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return records, engine_name


def make_tasks(a, scene, settings_list, out, repeat, build):
    """(tasks to run, records of the points done before): a point whose
    point.json says it was measured with this build, as often as asked, is
    not run again."""
    timeout = a.timeout_s or 60.0 + 40.0 * float(scene.get("duration_s", 1.0))
    # measured by the sweep's root process when it started this one as the sweep's user (as_run_users)
    sizes = json.loads(os.environ["AFM_SWEEP_ARM_SIZES"]) if "AFM_SWEEP_ARM_SIZES" in os.environ else arm_sizes()
    tasks, done = [], []
    for settings in settings_list:
        s = point_scene(scene, settings, a.frames)
        pid = point_id(s, build)
        d = os.path.join(out, "points", pid)
        rec = load_done(os.path.join(d, "point.json"), build)
        if rec is not None and len(rec.get("runs", [])) >= repeat:
            done.append(rec)
            continue
        tasks.append({"id": pid, "dir": d, "scene": s, "settings": settings, "label": K.label(settings), "repeat": repeat,
                      "timeout_s": timeout, "build_id": build, "callgrind": not a.no_callgrind, "arm_sizes": sizes})
    return tasks, done


def _interrupted(_sig, _frame):
    raise KeyboardInterrupt


def main(argv):
    signal.signal(signal.SIGTERM, _interrupted)   # as Ctrl-C: the points done are kept (exit 130)
    started = None
    serial = {}   # the sweep's serial parts, s (sweep.json "serial_s")
    try:
        a = parse_args(argv)
        if os.geteuid() == 0 and a.cluster:   # the jobs are the runs' user's, never root's
            code = as_job_user(a, argv)
            if code is not None:
                return code
        if os.geteuid() == 0 and not a.scheduler and not a.cluster:   # a local cluster's workers (a remote cluster's are its own)
            code = as_run_users(a, argv)
            if code is not None:
                return code
        if a.scheduler:   # a cluster that cannot be used is named before anything else starts
            started = start_engine(a)
        scene_path, scene, knobs, out, repeat, sources = plan(a)
        a.out = out   # the engine's folder for its jobs' output (--cluster slurm)
        settings_list = K.grid(knobs)
        t0 = time.monotonic()
        started_by_root = sweep_users.TLS_FD_ENV in os.environ or slurm_engine.JOB_NAME_ENV in os.environ
        if started_by_root and VALIDATED_ENV in os.environ:   # root's process checked them
            serial["validate_s"] = float(os.environ[VALIDATED_ENV])
        else:
            validate(scene_path, scene, settings_list, sources)
            serial["validate_s"] = time.monotonic() - t0
        t0 = time.monotonic()
        build = build_id()
        serial["build_check_s"] = time.monotonic() - t0
    except (SweepError, K.KnobError, engine.EngineError, slurm_engine.SlurmError) as e:
        print(f"sweep: {printable(str(e))}", file=sys.stderr)   # keys, values and the validator's words, escaped
        if started:
            started[0].close()
        return 2
    os.makedirs(os.path.join(out, "points"), exist_ok=True)
    tasks, done = make_tasks(a, scene, settings_list, out, repeat, build)
    print(f"sweep: {len(settings_list)} points of {printable(os.path.basename(scene_path))} into {printable(out)}: {len(done)} done before, "
          f"{len(tasks)} to run", file=sys.stderr)
    prog = Progress(len(settings_list), len(done))
    engine_name = "nothing to run"
    if started and not tasks:
        started[0].close()
    interrupted = False
    new = []
    if tasks:
        try:
            new, engine_name = run_points(a, tasks, prog, started)
        except engine.EngineError as e:
            print(f"\nsweep: {e}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            interrupted = True
            new = [r for r in (load_done(os.path.join(t["dir"], "point.json"), build) for t in tasks) if r]
            print("\nsweep: interrupted; the points done so far are kept", file=sys.stderr)
    order = {point_id(point_scene(scene, s, a.frames), build): i for i, s in enumerate(settings_list)}
    points = sorted(done + new, key=lambda r: order.get(r["id"], 0))
    serial["engine_start_s"] = prog.engine_start_s
    finish(out, scene_path, scene, knobs, points, repeat, build, engine_name, prog.points_wall_s,
           sweep_users.record(points, remote=bool(a.scheduler)), serial)
    if interrupted:
        print(f"sweep: {len(points)} of {len(settings_list)} points kept; run the same command again to finish",
              file=sys.stderr)
        return 130
    return 0 if all(p["status"] == "ok" for p in points) else 1


def shown(v):
    """A knob's name or value as the outputs show it: text through the one
    escaper (analysis/text.py), numbers and true/false as they are."""
    return printable(v) if isinstance(v, str) else v


def shown_points(knobs, points):
    """(knobs, points) as sweep.json, sweep.csv, the report, the plots and
    the terminal show them: every knob's name and value, every point's
    settings and label and a failure's words escaped, so that no control
    character of a sweep file reaches a terminal or a page raw."""
    knobs = [(shown(k), [shown(v) for v in vs]) for k, vs in knobs]
    out = []
    for p in points:
        p = dict(p, settings={shown(k): shown(v) for k, v in (p.get("settings") or {}).items()},
                 label=shown(p.get("label", "")))
        if "failure" in p:   # a log's tail keeps its lines, each escaped
            p["failure"] = {k: "\n".join(map(printable, v.split("\n"))) if isinstance(v, str) else v
                            for k, v in p["failure"].items()}
        out.append(p)
    return knobs, out


def finish(out, scene_path, scene, knobs, points, repeat, build, engine, points_wall_s=None, users=None, serial=None):
    knobs, points = shown_points(knobs, points)
    knob_keys = [k for k, _ in knobs]
    meta = {"scene": scene_path, "scene_name": shown(scene.get("name", "")), "knobs": knobs, "repeat": repeat,
            "build_id": build, "engine": engine, "points_wall_s": points_wall_s, "users": users, "serial_s": serial,
            "ok": sum(p["status"] == "ok" for p in points),
            "failed": sum(p["status"] != "ok" for p in points)}
    sweep_report.write_csv_json(out, points, knob_keys, meta)
    print(sweep_report.table(points))
    plots = sweep_report.write_plots(out, points)
    effects = sweep_report.knob_effects(points, knobs)
    best = sweep_report.best_buy(effects)
    sweep_report.write_html(out, meta, points, knobs, plots, effects, best)
    for p in points:
        if p["status"] != "ok":
            f = p.get("failure", {})
            print(f"sweep: point {p['label']} FAILED: {f.get('process', 'launcher')} exit "
                  f"{f.get('process_exit_code', f.get('exit_code'))}: {f.get('error') or f.get('stderr', '')} "
                  f"(folder {printable(p.get('run_dir', p.get('dir')))})", file=sys.stderr)
    if best:
        e, (lo, hi) = best[0], best[0]["cpu_s_per_sim_s_range"]
        print(f"sweep: most accuracy per unit of cost: {e['knob']} {e['from']} -> {e['to']}: force RMS error "
              f"x{sweep_report.fmt(e['force_rms_pN'])} for x{sweep_report.fmt(e['cpu_s_per_sim_s'])} CPU per simulated second "
              f"(x{sweep_report.fmt(lo)} to x{sweep_report.fmt(hi)} over {repeat} repeats)")
    elif any("cpu_s_per_sim_s" in e.get("unjudged", []) for e in effects):
        print(f"sweep: {sweep_report.unjudged_words(['cpu_s_per_sim_s'])}")
    print(f"sweep: wrote {out}/sweep.csv, sweep.json, report.html and {len(plots)} Pareto plots in plots/")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
