"""The card's bench calibration before a run (./afm run SCENE --calibrate):
where a scene's card section gives the card neither mu nor k_theta K_l / h
(firmware.mu, firmware.lateral_nN_per_V) and no firmware.calibration, the
tilted calibration is run first on the scene's own probe and tip-substrate
pair, and the run starts with what it measured as firmware.calibration.

    python -m analysis.card_calib prepare SCENE --work DIR [--recalibrate]

prints the path of the scene to run: SCENE itself when its card section
gives both constants or a calibration already, else DIR/scene.yaml, SCENE
with firmware.calibration {run: "tilted sha256:KEY", mu, lateral_nN_per_V}
set in its card section. SCENE is read as the launcher resolves it, the one
reader of the scene format (`afm_launch --scene SCENE --resolved`: checked
as --check checks it, its includes merged in, its file paths absolute), so
DIR/scene.yaml stands in another folder and a scene the launcher refuses
is refused here, in its words, before anything runs.
DIR must be a folder the run's user can reach (./afm makes it, 0755): the
calibration's runs are made in DIR/calibration.

The calibration: scenes/paper/tilted.yaml (glass tilted by 9 deg, scan angle
270) with the scene's probe, its sample's tip_substrate, photodiode noise and
temperature, and the card's k_n and K_n from its card section; one run per set
point of LOADS_NN; the slopes, the slope angle and the solve as ./afm paper's
tilted experiment measures them (analysis/paper/exp_tilted.py,
analysis/loops.py: the one owner of each). Measured, never copied from the
truth: the run's mu is the calibration's, within its accuracy.

The cache: KEY is the SHA-256 of the resolved scene's probe and sample
sections and the calibration's own settings; its result is
DIR_CACHE/KEY.json, DIR_CACHE $XDG_CACHE_HOME/afm-calib, else
~/.cache/afm-calib, made 0700. The folder must be a folder (not a link), the
caller's, closed to others; the entry is read and written through
analysis/safefs.py (no link followed, a regular file; written by rename). A
second run with the same probe and sample runs nothing ("from the cache" on
stderr); --recalibrate ignores the cache and writes it anew. A refusal is
one line on stderr and exit 2."""
import argparse
import copy
import hashlib
import json
import os
import stat
import sys
import time

import yaml

from analysis import loops, paths, point, safefs
from analysis.paper import common, exp_tilted
from analysis.resolved import SceneRefused, resolved_scene

LOADS_NN = exp_tilted.LOADS_NN["reduced"]
CALIB_SCENE = "tilted.yaml"            # under scenes/paper/
CALIB_SCAN_ANGLE_DEG = 270             # the lever across the slope: the calibration's own scan
SAMPLE_KEYS = ("tip_substrate", "photodiode_noise_V", "temperature_K")   # the sample's, taken onto the tilted glass
CARD_KEYS = ("spring_N_per_m", "deflection_nm_per_V")                   # the card's k_n and K_n
RUN_TIMEOUT_S = 600.0
VERSION = 1                            # of the calibration's recipe: a new one is a new key


class CalibError(Exception):
    """The calibration could not run or was refused (named: what and why)."""


def resolved(scene_path):
    """The scene as the launcher resolves it (analysis/resolved.py), a mapping."""
    try:
        return resolved_scene(scene_path)
    except SceneRefused as e:
        raise CalibError(str(e)) from None


def needs_calibration(fw):
    """Why the card is calibrated (a sentence), or None when its section gives it what a calibration would."""
    if fw.get("calibration") is not None:
        return None
    missing = [k for k in ("mu", "lateral_nN_per_V") if fw.get(k) is None]
    return f"the scene's card section gives no {' and no '.join('firmware.' + k for k in missing)}" if missing else None


def calib_scene(sections):
    """The calibration's scene (without its set point): the tilted glass
    with the scene's probe, tip-substrate pair and the card's k_n, K_n."""
    scene = copy.deepcopy(common.load_scene(CALIB_SCENE))
    scene["probe"] = dict(sections["probe"], scan_angle_deg=CALIB_SCAN_ANGLE_DEG)
    for k in SAMPLE_KEYS:
        if sections["sample"].get(k) is not None:
            scene["sample"][k] = copy.deepcopy(sections["sample"][k])
    card = {k: sections["firmware"][k] for k in CARD_KEYS if sections["firmware"].get(k) is not None}
    if card:
        scene["firmware"] = card
    return scene


def cache_key(sections, scene):
    """The SHA-256 of the probe and sample sections and the calibration's own settings."""
    what = {"probe": sections["probe"], "sample": sections["sample"], "calibration": scene, "loads_nN": LOADS_NN,
            "version": VERSION}
    return hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()


def cache_dir():
    """The cache's folder as a descriptor (see the module's contract)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    path = os.path.join(base, "afm-calib")
    os.makedirs(base, mode=0o700, exist_ok=True)
    if not os.path.lexists(path):
        os.mkdir(path, 0o700)
    try:
        fd = safefs.open_dir(path)
    except safefs.Refused as e:
        raise CalibError(f"the calibration cache: {e}") from None
    st = os.fstat(fd)
    if st.st_uid != os.geteuid() or st.st_mode & 0o077:
        os.close(fd)
        raise CalibError(f"the calibration cache: {path}: uid {st.st_uid}, mode {stat.S_IMODE(st.st_mode):o}: "
                         f"it must be yours (uid {os.geteuid()}) and closed to others (0700): remove it")
    return fd, path


def cached(fd, path, key):
    """The cached result of key, or None."""
    rel = key + ".json"
    if not safefs.is_file(fd, rel):
        return None
    try:
        got = json.loads(safefs.read_bytes(fd, rel, path, limit=1 << 16))
    except safefs.Refused as e:
        raise CalibError(f"the calibration cache: {e}") from None
    except ValueError:
        return None                    # unreadable: calibrated again and rewritten
    ok = isinstance(got, dict) and all(isinstance(got.get(k), (int, float)) for k in ("mu", "lateral_nN_per_V"))
    return got if ok else None


def run_calibration(scene, work):
    """The calibration's runs in work/calibration (one per set point) and
    its result: {mu, lateral_nN_per_V, r_u, r_d, phi_deg, loads_nN}."""
    base = os.path.join(work, "calibration")
    os.makedirs(base, exist_ok=True)
    os.chmod(base, 0o755)              # the run's user makes its runs here
    dirs = {}
    for L in LOADS_NN:
        s = copy.deepcopy(scene)
        s.setdefault("operator", {})["load_nN"] = L
        path, out = os.path.join(base, f"load_{L}nN.yaml"), os.path.join(base, f"load_{L}nN")
        with open(path, "w") as f:
            f.write(f"# the card's tilted calibration at {L} nN (analysis/card_calib.py)\n")
            yaml.safe_dump(s, f, sort_keys=False)
        code, err, rj, _ = point.run_scene(path, out, RUN_TIMEOUT_S)
        if code != 0 or not rj or rj.get("status") != "ok":
            raise CalibError(f"the calibration's run at {L} nN failed (exit {code}; its folder {out}): "
                             f"{(err.strip().splitlines() or ['no message'])[-1]}")
        dirs[L] = out
    fit = loops.fit_slopes([exp_tilted.loop_means(dirs[L])[0] for L in LOADS_NN])
    (ru, _, _), (rd, _, _) = fit["up"], fit["down"]
    phi = exp_tilted.slope_deg(dirs[LOADS_NN[0]])
    card = common.run_json(dirs[LOADS_NN[0]])["card"]
    kn = card["normal_gain_pn_per_v"] / card["deflection_pm_per_v"]   # N/m, as the card has it
    Kn = card["deflection_pm_per_v"] * 1e-3                           # nm/V
    sol = loops.solve(paths.CALC, ru, rd, phi, kn, Kn)
    return {"mu": sol["mu"], "lateral_nN_per_V": sol["lateral_nN_per_V"], "r_u": ru, "r_d": rd, "phi_deg": phi,
            "loads_nN": LOADS_NN}


def calibration(sections, work, recalibrate):
    """firmware.calibration for the scene's sections: from the cache, or measured and cached."""
    scene = calib_scene(sections)
    key = cache_key(sections, scene)
    fd, cpath = cache_dir()
    try:
        got = None if recalibrate else cached(fd, cpath, key)
        if got is not None:
            say(f"calibration tilted sha256:{key[:16]} from the cache ({cpath}/{key}.json): no run")
        else:
            t0 = time.monotonic()
            say(f"calibrating the card: the tilted calibration at {', '.join(map(str, LOADS_NN))} nN on the scene's "
                f"probe and tip-substrate pair{' (--recalibrate)' if recalibrate else ''}")
            got = run_calibration(scene, work)
            got["wall_s"] = round(time.monotonic() - t0, 1)
            safefs.write_atomic(fd, key + ".json", json.dumps(got, indent=1) + "\n", cpath)
            say(f"calibration tilted sha256:{key[:16]} measured in {got['wall_s']} s, cached in {cpath}/{key}.json")
    finally:
        os.close(fd)
    say(f"calibration tilted sha256:{key[:16]}: mu {got['mu']:.5f}, k_theta K_l / h {got['lateral_nN_per_V']:.3f} nN/V")
    return {"run": f"tilted sha256:{key[:16]}", "mu": got["mu"], "lateral_nN_per_V": got["lateral_nN_per_V"]}


def prepare(scene_path, work, recalibrate=False):
    """The path of the scene to run (see the module's contract)."""
    scene = resolved(scene_path)
    sections = {k: scene.get(k) if isinstance(scene.get(k), dict) else {} for k in ("probe", "sample", "firmware")}
    why = needs_calibration(sections["firmware"])
    if why is None:
        say(f"{scene_path}: the scene's card section gives mu and k_theta K_l / h (or a calibration): not calibrated")
        return scene_path
    say(f"{scene_path}: {why}")
    cal = calibration(sections, work, recalibrate)
    if not isinstance(scene.get("firmware"), dict):
        scene["firmware"] = {}
    scene["firmware"]["calibration"] = cal
    out = os.path.join(work, "scene.yaml")
    with open(out, "w") as f:
        f.write(f"# {os.path.abspath(scene_path)} with firmware.calibration from calibration run {cal['run']} "
                f"(./afm run --calibrate)\n")
        yaml.safe_dump(scene, f, sort_keys=False)
    os.chmod(out, 0o644)
    return out


def say(msg):
    print(f"calibrate: {msg}", file=sys.stderr)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m analysis.card_calib", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("prepare", help="the scene to run, calibrated first where its card section gives nothing")
    p.add_argument("scene")
    p.add_argument("--work", required=True, help="a folder the run's user can reach (0755)")
    p.add_argument("--recalibrate", action="store_true", help="ignore the cache")
    a = ap.parse_args(argv)
    try:
        print(prepare(a.scene, a.work, a.recalibrate))
    except (CalibError, common.PaperError, loops.LoopError) as e:
        say(str(e))
        return 2
    except (safefs.Refused, OSError) as e:
        say(f"the calibration cache: {e}")
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
