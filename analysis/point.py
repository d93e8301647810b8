"""One sweep point, run where a Dask worker runs it: the point's scene as an
ordinary run in its own network namespace (afm_launch through in_netns.sh,
as ./afm run does), then its errors from its own log and its costs from the
kernel's accounting, its renderer and the firmware replayed under callgrind.
Everything it finds is written to the point's folder (point.json), so an
interrupted sweep keeps every finished point.

A Dask task runs a batch of points (run_points_json), one after the other
in the worker's long-lived process, each still a run of its own in its own
namespace; the batch's answer is JSON text, a record per point. Each record
says where its time went ("timing", docs/sweeps.md "Where a point's time
goes"): the namespace and the drop around the launcher, the launcher's start
and end (its processes' start, the scans, run.json) and its loop, the
errors read from the log, and the callgrind replay."""
import json
import os
import re
import shutil
import subprocess
import time

from analysis import paths, runlog, safefs

# The firmware modules every card runs, and those a configuration adds.
CARD_MODULES = ["fw_math", "fw_guard", "fw_acq", "fw_rules", "fw_theta", "fw_force", "fw_comp", "fw_board", "fw_particles",
                "fw_calib", "fw_drift", "fw_card"]


def modules_run(scene):
    """The firmware modules the point's card runs (for its flash size)."""
    mods = list(CARD_MODULES)
    if (scene.get("firmware") or {}).get("word_bits") == 16:
        mods.append("fw_board16")
    if (scene.get("objects") or {}).get("wires"):
        mods.append("fw_wire")
    if "lithography" in (scene.get("effects") or []):
        mods.append("fw_litho")
    return mods


def _tail(path, n=8):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-n:])
    except OSError:
        return ""


def _write_json(path, data):
    safefs.write_path(path, json.dumps(data, indent=2, sort_keys=True) + "\n")   # whole or not at all, no link followed


# A worker started by a root sweep (analysis/sweep_users.py) names a folder
# of its own for its points' HOME and TMPDIR, emptied between points.
POINT_SCRATCH_ENV = "AFM_SWEEP_POINT_SCRATCH"


def fresh_scratch():
    """The environment of a point's processes: with POINT_SCRATCH_ENV, HOME,
    TMPDIR, MPLCONFIGDIR and XDG_CACHE_HOME in that folder, made empty
    (0700) for this point; else this process's own (None)."""
    d = os.environ.get(POINT_SCRATCH_ENV)
    if not d:
        return None
    clear_scratch()
    os.makedirs(os.path.join(d, "tmp"), mode=0o700)
    os.chmod(d, 0o700)
    return dict(os.environ, HOME=d, TMPDIR=os.path.join(d, "tmp"), MPLCONFIGDIR=os.path.join(d, ".matplotlib"),
                XDG_CACHE_HOME=os.path.join(d, ".cache"))


def clear_scratch():
    d = os.environ.get(POINT_SCRATCH_ENV)
    if d:
        shutil.rmtree(d, ignore_errors=True)


def run_scene(scene_path, run_dir, timeout_s, env=None):
    """Runs the scene; returns (exit code, stderr, run.json or None, wall s).
    A run that completes but fails one of its own checks exits 0 here
    (--no-verdict): sweeps and the paper keep its run.json "verdict" as data,
    not as a failed point."""
    cmd = [paths.IN_NETNS, paths.LAUNCH, "--scene", scene_path, "--out", run_dir, "--quiet", "--no-verdict"]
    t0 = time.monotonic()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env)
        code, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired:
        code, err = -1, f"the run did not finish in {timeout_s:.0f} s (killed)"
    wall = time.monotonic() - t0
    rj = None
    try:
        with open(os.path.join(run_dir, "run.json")) as f:
            rj = json.load(f)
    except (OSError, ValueError):
        pass
    return code, err, rj, wall


def failure_of(code, err, rj, run_dir):
    """What failed, named: the process, its exit code and its log's tail."""
    f = {"exit_code": code, "stderr": err.strip()[-2000:]}
    if rj:
        f["error"] = rj.get("error", "")
        bad = [p for p in rj.get("processes", []) if p.get("exit_code", 0) != 0]
        if bad:
            f["process"] = bad[0]["name"]
            f["process_exit_code"] = bad[0]["exit_code"]
            f["log_tail"] = _tail(os.path.join(run_dir, bad[0]["log"]))
    return f


def costs_of(rj):
    """The run's costs (docs/sweeps.md, "Running a sweep"): per simulated second, from run.json."""
    sim_s = rj.get("sim_seconds") or 0.0
    c = {"wall_s_per_sim_s": rj["wall_seconds"] / sim_s if sim_s else None, "log_bytes": rj.get("log_bytes")}
    total = 0.0
    procs = list(rj.get("processes", []))
    if "cpu_user_s" in (rj.get("launcher") or {}):   # the launcher records the bus (bus_recorder.hpp)
        procs.append(dict(rj["launcher"], name="afm_launch"))
    for p in procs:
        cpu = p.get("cpu_user_s", 0.0) + p.get("cpu_system_s", 0.0)
        total += cpu
        c[f"cpu_{p['name'].replace('-', '_')}_s_per_sim_s"] = cpu / sim_s if sim_s else None
    c["cpu_s_per_sim_s"] = total / sim_s if sim_s else None
    r = rj.get("renderer") or {}
    if "update_ms_per_frame" in r:
        c["update_ms_per_frame"] = r["update_ms_per_frame"]
        c["renderer_ms_per_frame"] = r["update_ms_per_frame"] + r.get("compose_ms_per_frame", 0.0) + r.get(
            "write_ms_per_frame", 0.0)
    return c


def firmware_instructions(run_dir, out_file, samples, env=None):
    """The card's instructions per sample on this run's own inputs: the run
    replayed through the card under callgrind, counting inside
    fw_card_step_block only. Also whether the replay was identical."""
    cmd = ["valgrind", "--tool=callgrind", "--toggle-collect=fw_card_step_block", f"--callgrind-out-file={out_file}",
           paths.REPLAY, run_dir, "--quiet"]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=3600, env=env)
    total = None
    try:
        with open(out_file) as f:
            for line in f:
                m = re.match(r"^(totals|summary):\s+(\d+)", line)
                if m:
                    total = int(m.group(2))
    except OSError:
        pass
    return {"fw_instr_per_sample": total / samples if total and samples else None, "replay_identical": p.returncode == 0}


def run_point(task):
    """task: id, dir, scene (the dict), settings, label, repeat, timeout_s,
    build_id, callgrind, arm_sizes ({module: text bytes} or None). Returns the
    point's record, also written to dir/point.json; its worker_uid is the
    uid of the worker that ran it. The point's processes have a scratch
    folder emptied before and removed after (fresh_scratch)."""
    try:
        return _run_point(task, fresh_scratch())
    finally:
        clear_scratch()


def _run_point(task, env):
    d = task["dir"]
    os.makedirs(d, exist_ok=True)
    import yaml
    scene_path = os.path.join(d, "scene.yaml")
    with open(scene_path, "w") as f:
        yaml.safe_dump(task["scene"], f, sort_keys=False)
    rec = {"id": task["id"], "settings": task["settings"], "label": task["label"], "build_id": task["build_id"],
           "dir": d, "status": "ok", "runs": [], "worker_uid": os.getuid()}
    if os.environ.get("SLURM_JOB_ID"):   # a worker of --cluster slurm: the job that ran the point
        rec["slurm_job_id"] = os.environ["SLURM_JOB_ID"]
    t0 = time.time()
    timing = {k: 0.0 for k in TIMING}
    for r in range(task["repeat"]):
        run_dir = os.path.join(d, "run" if r == 0 else f"run-{r + 1}")
        if os.path.isdir(run_dir) and not os.path.islink(run_dir):   # a run cut short (its worker's job killed, Ctrl-C)
            shutil.rmtree(run_dir)
        code, err, rj, wall = run_scene(scene_path, run_dir, task["timeout_s"], env)
        if code != 0 or not rj or rj.get("status") != "ok":
            rec["status"] = "failed"
            rec["failure"] = failure_of(code, err, rj, run_dir)
            rec["run_dir"] = run_dir
            break
        card = rj.get("card") or {}
        t1 = time.monotonic()
        run = {"run_dir": run_dir, "costs": costs_of(rj),
               "errors": runlog.errors(run_dir, card.get("full_scale_pn")),
               "fidelity": {k: (rj.get("fidelity") or {}).get(k) for k in ("max_position_error_nm", "rms_height_error_nm")},
               "samples": rj.get("samples"), "verdict": rj.get("verdict")}
        rec["runs"].append(run)
        _add_run_timing(timing, wall, rj, time.monotonic() - t1)
    if rec["status"] == "ok":
        first = rec["runs"][0]
        rec["run_dir"] = first["run_dir"]
        rec["verdict"] = first["verdict"]
        rec["errors"] = dict(first["errors"], display_max_nm=first["fidelity"]["max_position_error_nm"],
                             display_rms_height_nm=first["fidelity"]["rms_height_error_nm"])
        # None with one run: nothing was repeated, so nothing is claimed
        rec["errors_identical_over_repeats"] = (all(r["errors"] == first["errors"] for r in rec["runs"][1:])
                                                if len(rec["runs"]) > 1 else None)
        costs = {k: [r["costs"].get(k) for r in rec["runs"]] for k in first["costs"]}
        rec["costs"] = {k: _median(v) for k, v in costs.items()}
        if task["repeat"] > 1:
            rec["cost_spread"] = {k: [min(x for x in v if x is not None), max(x for x in v if x is not None)]
                                  for k, v in costs.items() if any(x is not None for x in v)}
        if task["callgrind"]:
            t1 = time.monotonic()
            rec["costs"].update(firmware_instructions(first["run_dir"], os.path.join(d, "callgrind.out"), first["samples"],
                                                      env))
            timing["callgrind_s"] = time.monotonic() - t1
        if task.get("arm_sizes"):
            mods = modules_run(task["scene"])
            rec["costs"]["fw_text_bytes"] = sum(task["arm_sizes"].get(m, 0) for m in mods)
            rec["fw_modules"] = mods
    rec["point_wall_s"] = time.time() - t0
    timing["other_s"] = max(0.0, rec["point_wall_s"] - sum(timing.values()))
    rec["timing"] = timing
    _write_json(os.path.join(d, "point.json"), rec)
    return rec


# Where a point's time goes (its record's "timing", seconds, summed over its
# repeats): the namespace and the drop around the launcher (run/in_netns.sh,
# run/drop_caps.sh), the launcher's start and end (the processes' start, the
# initial and final scans, the fidelity check, frames and video when asked,
# run.json), its loop (first block to last), the errors read from the log,
# the callgrind replay, and the rest (the scene written, the scratch folder).
TIMING = ["namespace_s", "launcher_start_end_s", "loop_s", "errors_s", "callgrind_s"]


def _add_run_timing(timing, wall, rj, errors_s):
    launcher = float(rj.get("wall_seconds") or 0.0)
    loop = float((rj.get("timing") or {}).get("loop_seconds") or 0.0)
    timing["namespace_s"] += max(0.0, wall - launcher)
    timing["launcher_start_end_s"] += max(0.0, launcher - loop)
    timing["loop_s"] += loop
    timing["errors_s"] += errors_s


def run_point_json(task):
    """run_point as a Dask task: the record as JSON text, the one kind of
    answer the sweep's client reads (analysis/engine.py: nothing from the
    network is unpickled). An exception is the point's failure, in words,
    so no exception object travels either."""
    try:
        return json.dumps(run_point(task))
    except Exception as e:   # noqa: BLE001 (every failure is the point's, named)
        return json.dumps({"id": task.get("id"), "settings": task.get("settings"), "label": task.get("label"),
                           "dir": task.get("dir"), "status": "failed",
                           "failure": {"exit_code": -1, "error": f"the point's task raised {type(e).__name__}: {e}"}})


def run_points_json(tasks):
    """A batch of points as one Dask task: each point run in turn
    (run_point_json), the answer a JSON list of their records; "task_s" in
    the first says the batch's whole time on its worker (the engine's
    overhead is what the sweep's client sees beyond it)."""
    t0 = time.monotonic()
    recs = [json.loads(run_point_json(t)) for t in tasks]
    if recs:
        recs[0]["task_s"] = time.monotonic() - t0
    return json.dumps(recs)


def _median(v):
    v = sorted(x for x in v if x is not None)
    if not v:
        return None
    n = len(v)
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])
