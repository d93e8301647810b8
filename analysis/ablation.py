"""Issue 48's ablation, its one vocabulary: the instrument's error sources
at the lab levels of item 3 and the card's compensation parts, each as the
scene settings (analysis/knobs.py's dotted keys) that turn it on; and the
particles, the card's and the truth's, at a time of a run, from its own log.
./afm bench scanner (analysis/scanner_study.py) and ./afm paper's
compensation and ablation experiments build their cases here.

Contract:
  SOURCES          {name: {dotted key: value}}: the effect listed and its
                   level, issue 48 item 3's (z_drift: the lab scene's, the
                   issue gives none); the hysteresis's span is the scene's
                   field (hysteresis_span)
  MISSING_SOURCES  {name: why}: a source item 3 names that no scene key
                   turns on today
  PARTS            {name: {dotted key: value}}: one part of the card's
                   compensation on (the others as OFF has them)
  OFF              the card's compensation off: no inverse hysteresis, no
                   creep feed-forward, the drift taken whole at each scan
                   (firmware.drift_filter step, the card's default)
  MISSING_PARTS    {name: why}: a part item 2 names that no switch turns on
                   or off today
  settings(scene, sources, parts, among)
                   {key: value}: the sources named on at their levels, every
                   other source of `among` off (its effect not listed), the
                   card's compensation as OFF with the parts named on; the
                   scene's other keys and effects stay. An unknown name is a
                   ValueError naming it and the known ones.
  particles_at(run_dir, until_s=None)
                   ({id: card's (x, y)}, {id: true (x, y)}) in nm, frame A, at
                   the last block both FW_STATE and SIM_TRUTH logged at or
                   before until_s (None: the run's last).
"""
import numpy as np

SOURCES = {
    "drift": {"effects.thermal_drift": True, "sample.drift_nm_per_min": [40, 30],   # 50 nm/min
              "sample.drift_walk_nm_per_sqrt_min": 10},
    "hysteresis": {"effects.piezo_hysteresis": True, "afm.hysteresis.width_pct": 10},
    "creep": {"effects.piezo_creep": True, "afm.creep.gamma_pct_per_decade": 1.5, "afm.creep.t0_s": 0.1},
    "artefacts": {"effects.scan_artefacts": True, "afm.scan_artefacts.line_offset_rms_nm": 0.5,
                  "afm.scan_artefacts.servo_lag_nm": 10, "afm.scan_artefacts.bow_sag_nm": 2},
    "z_drift": {"effects.z_drift": True, "afm.z_drift.rate_nm_per_min": 1, "afm.z_drift.walk_nm_per_sqrt_min": 0.5},
}
MISSING_SOURCES = {
    "object_forces": "sim_afm/object_forces (a Hamaker constant of 0.1 aJ between objects, the lab level) is a library the simulator's step does "
                     "not call: no effect or scene key turns it on (physics.md 15)",
}
OFF = {"firmware.hyst_enable": False, "firmware.creep_enable": False, "firmware.drift_filter": "step"}
PARTS = {
    "hyst": {"firmware.hyst_enable": True},
    "creep": {"firmware.creep_enable": True, "firmware.creep_gamma_pct_per_decade": 1.5},
    "kalman": {"firmware.drift_filter": "kalman"},
}
MISSING_PARTS = {
    "levelling": "scans levelled (plane and line fits) before registration: no module and no switch in the card or "
                 "the host's registration today",
    "drift off": "firmware.drift_filter takes step or kalman; no switch leaves the local scans' drift untaken",
}


def hysteresis_span(scene):
    """The hysteresis's cycle at the lab level: the scene's scanned field."""
    return float((scene.get("sample") or {}).get("field_nm", 90000))


def settings(scene, sources, parts=(), among=tuple(SOURCES)):
    """The case's settings (module docstring)."""
    for name in sources:
        if name not in among:
            raise ValueError(f"ablation: no source {name!r} among {', '.join(among)}")
    for name in parts:
        if name not in PARTS:
            raise ValueError(f"ablation: no compensation part {name!r} (known: {', '.join(PARTS)})")
    out = {}
    for name in among:
        if name in sources:
            out.update(SOURCES[name])
        else:
            out.update({k: False for k in SOURCES[name] if k.startswith("effects.")})
    if "hysteresis" in sources:
        out["afm.hysteresis.span_nm"] = hysteresis_span(scene)
    out.update(OFF)
    for name in parts:
        out.update(PARTS[name])
    return out


def particles_at(run_dir, until_s=None):
    """The card's and the true particles at a time (module docstring)."""
    from analysis.paper import common
    states = common.model_states(run_dir)
    if until_s is not None:
        states = [s for s in states if s[1].utime * 1e-6 <= until_s]
        if not states:
            raise common.PaperError(f"{run_dir}/bus.lcmlog: no block at or before {until_s} s")
    _, fw, tr = states[-1]
    pos = lambda o: {p.id: np.array([p.x_nm, p.y_nm]) for p in o.particles}   # noqa: E731
    return pos(fw), pos(tr)
