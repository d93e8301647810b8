"""AssemblyEnv: the bench as a gymnasium environment (docs/env.md).

Each reset() starts a run (analysis/env/session.py: afm_launch in a network
namespace of its own, operator.mode env, lockstep) of a scene: a file
(options={"scene": PATH}), a task of the task set (options={"task": NAME}),
or a generated pattern (options={"n": N, "error_level": L, ...}: the
arguments of patterns.generate). Each step() is one action, carried out by
the operator while the run waits for the next.

Contract:
  - Actions (a Dict): "kind" 0 a stroke (the tip lifted to "from", pressed
    at "load_nN", straight to "to", lifted), 1 a local scan (centred at
    "to", "size" of the field on a side), 2 the built-in planner's push of
    particle "particle" (an index into the scene's particles by id) to
    "to", 3 end (the run ends and is judged). "from" and "to" are in units
    of the field's half side about its centre, in [-1, 1].
  - Observations (a Dict): "image" the renderer's display (the VIEW_FRAME
    at or before the card's last block, resized to obs_px), "force_nN" and
    "flags" (its bits) the card's, "particles" the card's models (x, y, r in
    nm, rows by id, unused rows 0) with "particle_mask", "sites" the
    targets with "site_mask" (the sample's coordinates), "drift_nm" the
    card's drift estimate (a site is at site + drift in the models' frame),
    "tip_nm" and "sim_s". Never SIM_TRUTH.
  - Reward: the change of the potential -mean over sites of min(distance to
    the nearest modelled particle (the site moved by the card's drift
    estimate), 1000 nm) / 100 nm, less 0.01 an action
    (0.1 for an action the operator refused); at the end, 10 x the share of
    sites the fresh scan finds filled (run.json fidelity.assembly).
  - terminated when every site holds a modelled particle within the
    scene's tolerance (then the run is ended and judged), or after kind 3;
    truncated after max_steps actions. info: sim_s, seq, refused (why),
    placed_by_model, mean_site_error_nm, push (the planner's account),
    and at the end fresh_scan (fidelity.assembly's particles); the run's
    folder is env.run_dir (kept until the next reset, or with keep_runs).
  - Deterministic for a seed: the generated task's and the scene's seed.
"""
import math
import os
import shutil
import tempfile
import time

import io

import gymnasium as gym
import numpy as np
import yaml
from gymnasium import spaces
from PIL import Image

from analysis.env import patterns
from analysis.env.session import Session, SessionError

KIND_STROKE, KIND_SCAN, KIND_PUSH, KIND_END = 0, 1, 2, 3
CAP_NM = 1000.0
UNIT_NM = 100.0
STEP_COST = 0.01
REFUSED_COST = 0.1
END_BONUS = 10.0
BOUND_NM = 1e5
FLAG_BITS = 32


class AssemblyEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 5}

    def __init__(self, task=None, max_particles=64, obs_px=128, max_steps=200, work_dir=None, render_mode=None,
                 keep_runs=False):
        self.default_options = {"task": task} if isinstance(task, str) else dict(task or {"task": "p10-e0"})
        self.max_particles, self.obs_px, self.max_steps = max_particles, obs_px, max_steps
        self.render_mode = render_mode
        self.keep_runs = keep_runs
        self.work_dir = work_dir or tempfile.mkdtemp(prefix="afm-env-runs-")
        os.makedirs(self.work_dir, exist_ok=True)
        os.chmod(self.work_dir, 0o755)   # the run's user reaches its folder inside
        m = max_particles
        self.action_space = spaces.Dict({
            "kind": spaces.Discrete(4),
            "from": spaces.Box(-1.0, 1.0, (2,), np.float32),
            "to": spaces.Box(-1.0, 1.0, (2,), np.float32),
            "load_nN": spaces.Box(0.5, 20.0, (1,), np.float32),
            "size": spaces.Box(0.02, 0.5, (1,), np.float32),
            "particle": spaces.Discrete(m),
        })
        self.observation_space = spaces.Dict({
            "image": spaces.Box(0, 255, (obs_px, obs_px, 3), np.uint8),
            "force_nN": spaces.Box(-BOUND_NM, BOUND_NM, (3,), np.float32),
            "flags": spaces.MultiBinary(FLAG_BITS),
            "particles": spaces.Box(-BOUND_NM, BOUND_NM, (m, 3), np.float32),
            "particle_mask": spaces.MultiBinary(m),
            "sites": spaces.Box(-BOUND_NM, BOUND_NM, (m, 2), np.float32),
            "site_mask": spaces.MultiBinary(m),
            "tip_nm": spaces.Box(-BOUND_NM, BOUND_NM, (2,), np.float32),
            "drift_nm": spaces.Box(-BOUND_NM, BOUND_NM, (2,), np.float32),
            "sim_s": spaces.Box(0.0, BOUND_NM, (1,), np.float32),
        })
        self.session = None
        self.scene = None
        self.scene_path = None
        self.run_dir = None
        self.runs = 0
        self.reset_s = None
        self._image = np.zeros((obs_px, obs_px, 3), np.uint8)

    # --- the scene of a reset
    def _scene_for(self, seed, options):
        opts = dict(options) if options else dict(self.default_options)
        if "scene" in opts:
            with open(opts["scene"]) as f:
                scene = yaml.safe_load(f)
            if seed is not None:
                scene["seed"] = int(seed)
            return scene
        if "task" in opts:
            opts = {**patterns.task(opts.pop("task")), **opts}
        name = opts.pop("name", None)
        if seed is not None:
            opts["seed"] = int(seed)
        return patterns.generate(name=name, **opts)

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        t0 = time.monotonic()
        self._stop()
        self.scene = self._scene_for(seed, options)
        n_p = len(self.scene.get("objects", {}).get("particles", []))
        if n_p > self.max_particles or len(self._sites()) > self.max_particles:
            raise ValueError(f"scene: {n_p} particles, {len(self._sites())} sites: more than max_particles {self.max_particles}")
        self.runs += 1
        folder = os.path.join(self.work_dir, f"reset_{self.runs}")
        os.makedirs(folder)
        os.chmod(folder, 0o755)
        self.scene_path = os.path.join(folder, "scene.yaml")
        with open(self.scene_path, "w") as f:
            yaml.safe_dump(self.scene, f, sort_keys=False)
        self.run_dir = os.path.join(folder, "run")
        self.session = Session(self.scene_path, self.run_dir, self.scene.get("block_hz", 1000),
                               self.scene.get("frame_rate_hz", 25))
        self.steps = 0
        self.done = False
        ready, frame = self.session.first
        obs = self._observe(ready, frame)
        self._potential = self._phi(obs)
        info = self._info(ready, obs)
        self._last = (obs, info)
        self.reset_s = time.monotonic() - t0
        return obs, info

    def _sites(self):
        t = (self.scene or {}).get("objects", {}).get("targets", []) or []
        return [(float(s[0]), float(s[1])) if isinstance(s, (list, tuple)) else (float(s["x_nm"]), float(s["y_nm"]))
                for s in t]

    def _particle_ids(self):
        return sorted(int(p["id"]) for p in self.scene.get("objects", {}).get("particles", []))

    def _field(self):
        smp = self.scene.get("sample", {})
        c = smp.get("field_center_nm", [0, 0])
        return float(c[0]), float(c[1]), float(smp.get("field_nm", 5000)) / 2

    def to_nm(self, u):
        cx, cy, h = self._field()
        return cx + float(u[0]) * h, cy + float(u[1]) * h

    def to_unit(self, xy_nm):
        cx, cy, h = self._field()
        return np.clip(np.array([(xy_nm[0] - cx) / h, (xy_nm[1] - cy) / h], np.float32), -1, 1)

    # --- observation and reward
    def _observe(self, ready, frame):
        m = self.max_particles
        parts = np.zeros((m, 3), np.float32)
        pmask = np.zeros(m, np.int8)
        force = np.zeros(3, np.float32)
        flags = np.zeros(FLAG_BITS, np.int8)
        tip = np.zeros(2, np.float32)
        if frame is not None:
            img = Image.open(io.BytesIO(bytes(frame.jpeg))).convert("RGB").resize((self.obs_px, self.obs_px),
                                                                                  Image.BILINEAR)
            self._image = np.asarray(img, np.uint8).copy()
            ids = self._particle_ids()
            for p in frame.particles:
                if p.id in ids:
                    k = ids.index(p.id)
                    parts[k] = (p.x_nm, p.y_nm, p.radius_nm)
                    pmask[k] = 1
            force[:] = np.clip(frame.force_nN, -BOUND_NM, BOUND_NM)
            flags[:] = [(frame.flags >> b) & 1 for b in range(FLAG_BITS)]
            tip[:] = np.clip(frame.tip_nm, -BOUND_NM, BOUND_NM)
        sites = np.zeros((m, 2), np.float32)
        smask = np.zeros(m, np.int8)
        for k, s in enumerate(self._sites()):
            sites[k] = s
            smask[k] = 1
        sim_s = np.array([ready["seq"] / float(self.scene.get("block_hz", 1000))], np.float32)
        drift = np.clip(np.array([ready.get("drift_x_nm", 0.0), ready.get("drift_y_nm", 0.0)], np.float32), -BOUND_NM, BOUND_NM)
        return {"image": self._image.copy(), "force_nN": force, "flags": flags, "particles": parts,
                "particle_mask": pmask, "sites": sites, "site_mask": smask, "tip_nm": tip, "drift_nm": drift,
                "sim_s": np.clip(sim_s, 0, BOUND_NM)}

    def _site_errors(self, obs):
        """Each site's distance to the nearest modelled particle (the site in
        frame A: the sample's coordinates plus the card's drift estimate)."""
        pts = [tuple(obs["particles"][k][:2]) for k in range(self.max_particles) if obs["particle_mask"][k]]
        dx, dy = (float(v) for v in obs["drift_nm"])
        return [min([math.dist((s[0] + dx, s[1] + dy), p) for p in pts] + [CAP_NM]) for s in self._sites()]

    def _phi(self, obs):
        e = self._site_errors(obs)
        return -sum(e) / len(e) / UNIT_NM if e else 0.0

    def _info(self, ready, obs, refused=None):
        e = self._site_errors(obs)
        tol = float(self.scene.get("operator", {}).get("plan", {}).get("tolerance_nm", 25))
        info = {"sim_s": float(obs["sim_s"][0]), "seq": ready["seq"], "refused": refused,
                "placed_by_model": sum(1 for x in e if x <= tol), "sites": len(e),
                "mean_site_error_nm": sum(e) / len(e) if e else 0.0}
        if "placed" in ready:
            info["push"] = {k: ready[k] for k in ("placed", "error_nm", "pushes", "scans") if k in ready}
        return info

    # --- actions
    def _line(self, a):
        kind = int(a["kind"])
        if kind == KIND_STROKE:
            (x0, y0), (x1, y1) = self.to_nm(a["from"]), self.to_nm(a["to"])
            return f"STROKE {x0:.3f} {y0:.3f} {x1:.3f} {y1:.3f} {float(np.asarray(a['load_nN']).reshape(-1)[0]):.4f}"
        if kind == KIND_SCAN:
            x, y = self.to_nm(a["to"])
            size = float(np.asarray(a["size"]).reshape(-1)[0]) * 2 * self._field()[2]
            return f"SCAN {x:.3f} {y:.3f} {size:.3f}"
        if kind == KIND_PUSH:
            ids = self._particle_ids()
            k = int(a["particle"])
            x, y = self.to_nm(a["to"])
            return f"PUSH {ids[k]} {x:.3f} {y:.3f}" if k < len(ids) else f"PUSH {10 ** 8 + k} {x:.3f} {y:.3f}"
        return None

    def step(self, action):
        if self.session is None or self.done:
            raise RuntimeError("AssemblyEnv.step: call reset() first (the episode has ended)")
        self.steps += 1
        line = self._line(action)
        if line is None:
            return self._finish(0.0, terminated=True)
        try:
            ready, frame = self.session.act(line)
        except SessionError as e:
            return self._finish(0.0, truncated=True, error=str(e))
        obs = self._observe(ready, frame)
        phi = self._phi(obs)
        refused = ready.get("why") if not ready.get("ok") else None
        reward = phi - self._potential - (REFUSED_COST if refused else STEP_COST)
        self._potential = phi
        info = self._info(ready, obs, refused)
        self._last = (obs, info)
        if info["placed_by_model"] == info["sites"] and info["sites"] > 0:
            return self._finish(reward, terminated=True)
        if self.steps >= self.max_steps:
            return self._finish(reward, truncated=True)
        return obs, float(reward), False, False, info

    def _finish(self, reward, terminated=False, truncated=False, error=None):
        """The run ended (END) and judged by its fresh scan."""
        self.done = True
        obs, info = self._last
        code, rj = self.session.end() if error is None else (None, None)
        fresh = (((rj or {}).get("fidelity") or {}).get("assembly") or {}).get("particles")
        info = dict(info, fresh_scan=fresh, exit_code=code, error=error)
        if fresh and fresh.get("sites"):
            reward += END_BONUS * fresh["placed"] / fresh["sites"]
        self._stop(keep_session_dir=True)
        return obs, float(reward), terminated, truncated, info

    def render(self):
        return self._image.copy()

    def _stop(self, keep_session_dir=False):
        if self.session is not None:
            self.session.close()
            self.session = None
        self.__dict__.pop("_last", None)
        if not keep_session_dir and not self.keep_runs and self.run_dir:
            shutil.rmtree(os.path.dirname(self.run_dir), ignore_errors=True)

    def close(self):
        self._stop()
        if not self.keep_runs:
            shutil.rmtree(self.work_dir, ignore_errors=True)
        super().close()
