"""Generated assembly tasks of a known difficulty, and the versioned task set
(docs/env.md).

A task is a pattern of N sites on a square grid `spacing_nm` apart, centred
in a field of `field_nm`, and N particles (plus `spares`) each put at a
distance of about `mean_travel_nm` (uniform in [0.5, 1.5] of it, any
direction) from the site it is meant for, no two closer than
`min_gap_nm` surface to surface, none on or beside a site, all inside the
field less a margin; `error_level` chooses the instrument's errors
(ERROR_LEVELS); `seed` draws it all (numpy's PCG64), so that a task is the
same scene on every machine.

Contract:
  - generate(...) returns the scene as a dict (scene.md's keys; operator.mode
    env, lockstep), or raises ValueError naming the parameter when the
    particles cannot be placed (the field too small for N, spacing, travel).
  - TASKSET_VERSION names TASKS; a change to a task, to generate() or to
    ERROR_LEVELS that changes any scene is a new version.
  - task(name) returns the task's generator parameters; KeyError naming the
    names there are.
"""
import math

import numpy as np

TASKSET_VERSION = "1"

# The instrument's errors by level: 0 the ideal scanner with the imaging's
# own effects; 1 and 2 add the sample's thermal drift (physics.md section 10)
# at a quiet lab's level and at scenes/drift.yaml's.
BASE_EFFECTS = ["bending_offset", "adhesion", "photodiode_noise", "tip_convolution"]
ERROR_LEVELS = {
    0: {"effects": BASE_EFFECTS, "sample": {}},
    1: {"effects": BASE_EFFECTS + ["thermal_drift"],
        "sample": {"drift_nm_per_min": [20, -10], "drift_walk_nm_per_sqrt_min": 2}},
    2: {"effects": BASE_EFFECTS + ["thermal_drift"],
        "sample": {"drift_nm_per_min": [60, -30], "drift_walk_nm_per_sqrt_min": 5}},
}

RADIUS_NM = 50.0
SITE_KEEPOUT_NM = 190.0     # a particle's centre at least this far from any site (2 r + the planner's clearance)
MARGIN_NM = 300.0           # particles this far inside the field's edge
TRIES = 400                 # draws per particle before the task is refused

TASKS = [
    {"name": "p10-e0", "field_nm": 5000, "n": 10, "spacing_nm": 300, "mean_travel_nm": 900, "error_level": 0, "seed": 1},
    {"name": "p10-e1", "field_nm": 5000, "n": 10, "spacing_nm": 300, "mean_travel_nm": 900, "error_level": 1, "seed": 2},
    {"name": "p20-e0", "field_nm": 6000, "n": 20, "spacing_nm": 300, "mean_travel_nm": 1200, "error_level": 0, "seed": 3},
    {"name": "p20-e1", "field_nm": 6000, "n": 20, "spacing_nm": 300, "mean_travel_nm": 1200, "error_level": 1, "seed": 4},
    {"name": "p40-e0", "field_nm": 8000, "n": 40, "spacing_nm": 300, "mean_travel_nm": 1500, "error_level": 0, "seed": 5},
    {"name": "p40-e2", "field_nm": 8000, "n": 40, "spacing_nm": 300, "mean_travel_nm": 1500, "error_level": 2, "seed": 6},
]


def task(name):
    for t in TASKS:
        if t["name"] == name:
            return dict(t)
    raise KeyError(f"task set {TASKSET_VERSION}: no task '{name}' (there are {', '.join(t['name'] for t in TASKS)})")


def grid_sites(n, spacing_nm):
    """n sites on a square grid, row by row, centred on (0, 0)."""
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    out = []
    for k in range(n):
        r, c = divmod(k, cols)
        out.append(((c - (cols - 1) / 2) * spacing_nm, (r - (rows - 1) / 2) * spacing_nm))
    return out


def _free(p, placed, sites, min_gap_nm, half):
    if abs(p[0]) > half - MARGIN_NM or abs(p[1]) > half - MARGIN_NM:
        return False
    if any(math.dist(p, s) < SITE_KEEPOUT_NM for s in sites):
        return False
    return all(math.dist(p, q) >= 2 * RADIUS_NM + min_gap_nm for q in placed)


def _place(rng, around, mean_travel_nm, placed, sites, min_gap_nm, half):
    for _ in range(TRIES):
        if around is None:   # a spare: anywhere
            p = tuple(rng.uniform(-half + MARGIN_NM, half - MARGIN_NM, 2))
        else:
            a, d = float(rng.uniform(0, 2 * math.pi)), mean_travel_nm * float(rng.uniform(0.5, 1.5))
            p = (around[0] + d * math.cos(a), around[1] + d * math.sin(a))
        if _free(p, placed, sites, min_gap_nm, half):
            return (round(float(p[0]), 1), round(float(p[1]), 1))
    return None


def generate(field_nm=5000, n=10, spacing_nm=300, mean_travel_nm=900, error_level=0, seed=0, spares=2,
             min_gap_nm=150, name=None, max_sim_s=1200):
    """The task's scene (a dict, operator.mode env)."""
    if error_level not in ERROR_LEVELS:
        raise ValueError(f"error_level: {error_level} is not one of {sorted(ERROR_LEVELS)}")
    if not (n >= 1 and spacing_nm >= 2 * RADIUS_NM + 40 and field_nm > 2 * MARGIN_NM and mean_travel_nm > 0):
        raise ValueError(f"n, spacing_nm, field_nm, mean_travel_nm: {n}, {spacing_nm}, {field_nm}, {mean_travel_nm} "
                         f"(n >= 1, spacing_nm >= {2 * RADIUS_NM + 40:.0f}, field_nm > {2 * MARGIN_NM:.0f}, travel > 0)")
    rng = np.random.Generator(np.random.PCG64(seed))
    sites = grid_sites(n, spacing_nm)
    half = field_nm / 2
    placed = []
    for s in sites + [None] * spares:
        p = _place(rng, s, mean_travel_nm, placed, sites, min_gap_nm, half)
        if p is None:
            raise ValueError(f"field_nm {field_nm}: no room for particle {len(placed) + 1} of {n + spares} "
                             f"(spacing_nm {spacing_nm}, mean_travel_nm {mean_travel_nm}, min_gap_nm {min_gap_nm})")
        placed.append(p)
    level = ERROR_LEVELS[error_level]
    sample = {"substrate": "glass", "field_nm": field_nm, "tip_substrate": {"mu": 0.0865, "adhesion_nN": 1.0},
              "particle_substrate": {"mu": 0.3, "adhesion_nN": 3.0}}
    sample.update(level["sample"])
    return {
        "name": name or f"pattern-n{n}-e{error_level}-s{seed}",
        "seed": int(seed),
        "duration_s": max_sim_s,
        "sample_rate_hz": 20000,
        "block_hz": 1000,
        "frame_rate_hz": 5,
        "effects": list(level["effects"]),
        "sample": sample,
        "objects": {"particles": [{"id": i + 1, "x_nm": p[0], "y_nm": p[1], "radius_nm": RADIUS_NM}
                                  for i, p in enumerate(placed)],
                    "targets": [[round(x, 1), round(y, 1)] for x, y in sites]},
        "operator": {"mode": "env", "load_nN": 5, "plan": {"tolerance_nm": 25}},
        "outputs": {"image_px": 256, "video": "none"},
    }
