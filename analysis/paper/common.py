"""What every experiment of ./afm paper shares: its runs (a scene under
scenes/paper/, with some keys set, run as ./afm run runs it), the rows of
its table (the paper's value, the bench's measured from the run's own data,
the simulator's truth, the error and the tolerance it is held to), the
firmware's own solvers (afm_calc --json), the run's signals and scans."""
import copy
import json
import os
import subprocess
from dataclasses import asdict, dataclass, field

import numpy as np
import yaml

from analysis import gsf, knobs, paths, safefs

SCENES = os.path.join(paths.ROOT, "scenes", "paper")
CALC = paths.CALC


class PaperError(Exception):
    """An experiment could not be analysed (named: what and why)."""


@dataclass
class Run:
    """One run of an experiment: a scene under scenes/paper/ with keys set."""
    name: str                    # unique within the experiment
    scene: str                   # file name under scenes/paper/
    settings: dict = field(default_factory=dict)   # dotted key -> value (analysis.knobs)
    timeout_s: float = 900.0
    cost_s: float = 10.0         # about how long it takes (the longest start first)
    env: dict = field(default_factory=dict)        # environment variables the run's processes get besides the caller's


TOLERANCES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "tolerances.yaml")
KINDS = ("figure", "model error", "unit check")
_ENTRY_KEYS = {"quantity", "kind", "model", "truth", "tolerance", "unit", "relative", "per", "at_least", "why"}
_TOLERANCES = None


def tolerances():
    """The committed tolerance file (analysis/paper/tolerances.yaml), read
    and checked once: {key: entry}. Every row's tolerance comes from it."""
    global _TOLERANCES
    if _TOLERANCES is None:
        _TOLERANCES = read_tolerances(TOLERANCES)
    return _TOLERANCES


def read_tolerances(path):
    """{key: entry} of a tolerance file, each entry checked (PaperError naming
    the file, the key and the field)."""
    try:
        with open(path) as f:
            data = yaml.safe_load(f)
    except OSError as e:
        raise PaperError(f"{path}: cannot read the tolerances: {e.strerror}")
    if not isinstance(data, dict):
        raise PaperError(f"{path}: must map each row's key to its entry")
    for key, e in data.items():
        where = f"{path}: {key}"
        if not isinstance(e, dict):
            raise PaperError(f"{where}: must be a mapping")
        missing = {"quantity", "kind", "model", "truth", "tolerance", "unit", "why"} - set(e)
        if missing:
            raise PaperError(f"{where}: missing {', '.join(sorted(missing))}")
        if set(e) - _ENTRY_KEYS:
            raise PaperError(f"{where}: unknown field {', '.join(sorted(set(e) - _ENTRY_KEYS))}")
        if e["kind"] not in KINDS:
            raise PaperError(f"{where}: kind {e['kind']!r} is not one of {', '.join(KINDS)}")
        t = e["tolerance"]
        sizes = t.values() if isinstance(t, dict) else [t]
        if isinstance(t, dict) and set(t) != {"full", "reduced"}:
            raise PaperError(f"{where}: tolerance by size must give full and reduced, got {sorted(t)}")
        if any(v is not None and not (isinstance(v, (int, float)) and v >= 0) for v in sizes):
            raise PaperError(f"{where}: tolerance {t!r} must be a number >= 0 (or null: shown, not judged)")
        if not str(e["why"]).strip():
            raise PaperError(f"{where}: why is empty")
    return data


@dataclass
class Row:
    """One line of the report. Two kinds of value: bench (a figure measured
    from the run's own data) or model (the paper's model, as the card or the
    firmware's solver computes it); either against the truth. error: value -
    truth (absolute) unless relative; ok: |error| within tolerance. Without a
    truth, a tolerance is a limit: ok when |value| is within it. The
    tolerance, its kind (figure, model error, unit check: a formula held
    against itself) and its unit come from the row's entry `key` in
    tolerances.yaml, never from the code; `scale` is the value of the
    entry's `per` (the tolerance is that many of it). A row measured from a
    run whose own verdict failed is never ok: its verdict names the check."""
    quantity: str
    unit: str
    key: str = None              # its entry in tolerances.yaml
    paper: object = None         # the paper's value (None: it gives none)
    bench: object = None         # measured from the run's own data by the firmware's solvers
    truth: object = None         # the simulator's (the scene's physics, or SIM_TRUTH)
    model: object = None         # the paper's model's value (a model row: no bench)
    note: str = ""               # where the paper's number is lost or wrong, or how it was measured
    runs: tuple = ()             # the runs it is measured from (empty: all the experiment's)
    scale: float = None          # the value of the entry's `per`
    tolerance: float = field(default=None, init=False)   # the error allowed (absolute, in unit; or a fraction with relative)
    relative: bool = field(default=False, init=False)
    kind: str = field(default="figure", init=False)
    run_failed: str = field(default=None, init=False)    # "run failed: CHECK (RUN)" when a run's verdict failed
    error: float = field(default=None, init=False)
    ok: bool = field(default=True, init=False)

    @property
    def value(self):
        return self.model if self.model is not None else self.bench

    @property
    def verdict(self):
        """'ok' or 'NO' for a row held to a tolerance ('unit check ok' where
        the truth is the model's own formula); 'shown' for one that is only
        shown; 'run failed: ...' for one whose run failed its verdict."""
        if self.run_failed:
            return self.run_failed
        if self.value is not None and self.tolerance is None:
            return "shown"
        v = "ok" if self.ok else "NO"
        return f"unit check {v}" if self.kind == "unit check" else v

    def entry(self):
        """Its entry in tolerances.yaml (PaperError when it has none)."""
        e = tolerances().get(self.key)
        if e is None:
            raise PaperError(f"{TOLERANCES}: no entry {self.key!r} for the row {self.quantity!r}")
        if str(e["unit"]) != self.unit:
            raise PaperError(f"{TOLERANCES}: {self.key}: unit {e['unit']!r}, but the row {self.quantity!r} is in {self.unit!r}")
        return e

    def resolve(self, size):
        """The tolerance, its kind and relativity from the row's entry."""
        e = self.entry()
        t = e["tolerance"]
        t = t[size] if isinstance(t, dict) else t
        self.kind, self.relative = e["kind"], bool(e.get("relative"))
        if t is not None and self.relative:
            t = t / 100.0   # written in percent of the truth
        if t is not None and e.get("per"):
            if self.scale is None:
                raise PaperError(f"{TOLERANCES}: {self.key}: the tolerance is per {e['per']}, which the row does not give")
            t = t * abs(float(self.scale))
        if t is not None and e.get("at_least") is not None:
            t = max(t, float(e["at_least"]))
        self.tolerance = None if t is None else float(t)
        return self

    def judge(self, size="full"):
        if self.key is not None:
            self.resolve(size)
        elif self.value is not None:
            raise PaperError(f"the row {self.quantity!r} has no key into {TOLERANCES}")
        v = self.value
        if v is not None and self.truth is not None:
            e = float(v) - float(self.truth)
            if self.relative:
                e = e / float(self.truth) if self.truth else float("inf")
            self.error = e
        if v is None:
            self.ok = False
        elif self.tolerance is None:
            self.ok = True
        else:
            self.ok = abs(float(v) if self.truth is None else self.error) <= self.tolerance
        if self.run_failed:
            self.ok = False
        return self


@dataclass
class Result:
    rows: list = field(default_factory=list)
    figures: list = field(default_factory=list)   # (caption, file name in the experiment's folder)
    notes: list = field(default_factory=list)

    @property
    def ok(self):
        return all(r.ok for r in self.rows)

    def as_dict(self):
        return {"ok": self.ok, "rows": [dict(asdict(r), verdict=r.verdict) for r in self.rows], "figures": self.figures,
                "notes": self.notes}


def load_scene(name):
    path = os.path.join(SCENES, name)
    try:
        with open(path) as f:
            return yaml.safe_load(f)
    except OSError as e:
        raise PaperError(f"{path}: cannot read the experiment's scene: {e.strerror}")


def scene_for(run):
    """The run's scene: the file under scenes/paper/ with its settings."""
    scene = copy.deepcopy(load_scene(run.scene))
    return knobs.apply(scene, run.settings, where=f"{run.scene}") if run.settings else scene


def calc(*args):
    """The firmware's own solver through afm_calc ... --json: its answer."""
    p = subprocess.run([CALC, *map(str, args), "--json"], capture_output=True, text=True, timeout=60)
    if p.returncode != 0:
        raise PaperError(f"afm_calc {' '.join(map(str, args))}: {p.stderr.strip()}")
    return json.loads(p.stdout)


def squeeze_model(L, l, gamma, mu, fl, fats, twist_deg=0.0):
    """The firmware's squeeze solver (eq. 25-30: afm_calc model squeeze) for
    a rod of length L (nm) pushed at l (nm) by a cone of half angle gamma
    (deg), wire mu, friction f L and tip adhesion F_a,ts (nN), with the
    lever twisted by twist_deg: its answer (push_nN, df_nN, ...)."""
    return calc("model", "squeeze", "--length-nm", f"{L:.1f}", "--push-at-nm", f"{l:.1f}", "--gamma-deg", gamma,
                "--mu", mu, "--fl-nN", f"{fl:.4f}", "--fa-ts-nN", f"{fats:.4f}", "--twist-deg", f"{twist_deg:.5f}")


def run_json(run_dir):
    with open(os.path.join(run_dir, "run.json")) as f:
        return json.load(f)


def analog(run_dir):
    """The run's photodiode signals and piezo, sample by sample, from its
    own bus.lcmlog: dict of numpy arrays sn_v, sl_v, x_nm, y_nm, z_nm, and
    t_s; and the sample rate."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"AFM_ANALOG"})
    blocks = sorted(afmlog.by_seq(log.get("AFM_ANALOG", [])).values(), key=lambda m: m.seq)
    if not blocks:
        raise PaperError(f"{run_dir}/bus.lcmlog: no analog blocks")
    fs = blocks[0].fs_hz
    out = {k: np.concatenate([np.asarray(getattr(m, a)[:m.n]) for m in blocks])
           for k, a in (("sn_v", "sn_v"), ("sl_v", "sl_v"), ("x_nm", "piezo_x_nm"), ("y_nm", "piezo_y_nm"), ("z_nm", "piezo_z_nm"))}
    out["t_s"] = np.arange(len(out["sn_v"])) / fs
    return out, fs


def scan(run_dir, name):
    """A scan the run wrote (scan_initial, scan_final, scan_local_N): heights
    in nm as a numpy array (row 0 at the top), and the x, y of its pixel
    centres in nm (frame A)."""
    path = os.path.join(run_dir, name + ".gsf")
    try:
        header, rows = gsf.read(path)
    except OSError as e:
        raise PaperError(f"{path}: cannot read the scan: {e.strerror}")
    h = np.asarray(rows, dtype=float) * 1e9
    nx, ny = int(header["XRes"]), int(header["YRes"])
    xr, yr = float(header["XReal"]) * 1e9, float(header["YReal"]) * 1e9
    x0, y0 = float(header.get("XOffset", 0)) * 1e9, float(header.get("YOffset", 0)) * 1e9
    xs = x0 + (np.arange(nx) + 0.5) * xr / nx
    ys = y0 + yr - (np.arange(ny) + 0.5) * yr / ny   # row 0 at the top
    return h, xs, ys


def scan_particles(h, xs, ys, min_height_nm):
    """The particles a scan shows: (x, y) in nm of each local maximum at
    least min_height_nm above the scan's median (the substrate), one per
    blob (the highest pixel of each connected region above half that)."""
    from scipy import ndimage
    base = float(np.median(h))
    labels, n = ndimage.label(h - base > 0.5 * min_height_nm)
    out = []
    for k in range(1, n + 1):
        mask = labels == k
        i = np.argmax(np.where(mask, h, -np.inf))
        r, c = np.unravel_index(i, h.shape)
        if h[r, c] - base >= min_height_nm:
            out.append((float(xs[c]), float(ys[r])))
    return out


def moved_in_scans(run_dir, min_height_nm, moved_nm=30.0):
    """How many particles of the first scan a later fresh scan finds moved,
    from the run's own scans (scan_initial, scan_final): each particle of
    the first scan is matched to the nearest of the last; the sample's drift
    between the scans is the median of those displacements (most particles
    must have stayed: not a measure for a run that pushed most of them); a
    particle moved if it is more than moved_nm from where the drift alone
    would put it. Returns (moved, particles in the first scan)."""
    h0, x0, y0 = scan(run_dir, "scan_initial")
    h1, x1, y1 = scan(run_dir, "scan_final")
    first, last = scan_particles(h0, x0, y0, min_height_nm), scan_particles(h1, x1, y1, min_height_nm)
    if not first or not last:
        raise PaperError(f"{run_dir}: no particle found in scan_initial.gsf or scan_final.gsf")
    L = np.asarray(last)

    def nearest(p, off):
        return L[np.argmin(np.hypot(L[:, 0] - off[0] - p[0], L[:, 1] - off[1] - p[1]))]
    disp = np.array([nearest(p, (0.0, 0.0)) - p for p in first])
    drift = np.median(disp, axis=0)
    moved = sum(int(np.hypot(*(nearest(p, drift) - p - drift)) > moved_nm) for p in first)
    return moved, len(first)


def push_excess(run_dir):
    """The push the object takes (nN): the median lateral force across the
    push while the card flags contact, less the tip's own sliding friction,
    the median over the blocks of free sliding before the first contact
    (their second half: the scanner at speed). From the card (FW_STATE) and
    from the simulator (SIM_TRUTH); and the blocks the card flagged SQUEEZE."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE", "SIM_TRUTH"})
    ff, tr = afmlog.by_seq(log.get("FW_STATE", [])), afmlog.by_seq(log.get("SIM_TRUTH", []))
    seqs = sorted(s for s in ff if s in tr)
    flag = afmlog.afm.fw_state_t
    contact = [s for s in seqs if ff[s].flags & flag.FLAG_CONTACT]
    squeeze = sum(1 for s in seqs if ff[s].flags & flag.FLAG_SQUEEZE)
    if len(contact) < 5:
        return None, None, squeeze
    free = [s for s in seqs if s < contact[0]]
    free = free[len(free) // 2:]
    if len(free) < 10:
        raise PaperError(f"{run_dir}/bus.lcmlog: only {len(free)} blocks of free sliding before contact")
    med = lambda src, ss: float(np.median([abs(src[s].force_nN[1]) for s in ss]))
    return med(ff, contact) - med(ff, free), med(tr, contact) - med(tr, free), squeeze


def truth(run_dir):
    """The scene the run ran (its scene.yaml, includes merged): the
    simulator's truth, for the truth column only."""
    with open(os.path.join(run_dir, "scene.yaml")) as f:
        return yaml.safe_load(f)


def probe_value(scene, key):
    """A probe key of the scene, or the paper's probe (afm_calc probe) when
    the scene leaves it out."""
    v = (scene.get("probe") or {}).get(key)
    return float(v) if v is not None else float(paper_probe()[key])


_PAPER_PROBE = None


def paper_probe():
    """The paper's probe as the firmware's header has it (afm_calc probe)."""
    global _PAPER_PROBE
    if _PAPER_PROBE is None:
        _PAPER_PROBE = calc("calc", "probe")
    return _PAPER_PROBE


def save(fig, exp_dir, fname):
    """Writes a figure into the experiment's folder (PNG, and SVG beside it
    for print: the report links both; each through safefs's atomic writer)
    and closes it; its file name."""
    fig.tight_layout()
    with safefs.atomic_path(os.path.join(exp_dir, fname)) as f:
        fig.savefig(f, dpi=110, format="png")
    with safefs.atomic_path(os.path.join(exp_dir, os.path.splitext(fname)[0] + ".svg")) as f:
        fig.savefig(f, format="svg", metadata={"Date": None})
    plt().close(fig)
    return fname


def plt():
    """matplotlib, off-screen."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as p
    return p


def model_states(run_dir):
    """[(seq, card's objects, true objects)] for every block both logged."""
    from analysis import afmlog
    log = afmlog.load(os.path.join(run_dir, "bus.lcmlog"), channels={"FW_STATE", "SIM_TRUTH"})
    fw = afmlog.whole_by_seq(log.get("FW_STATE", []), objects=lambda m: m.objects)
    tr = afmlog.whole_by_seq(log.get("SIM_TRUTH", []), objects=lambda m: m.objects)
    seqs = sorted(set(fw) & set(tr))
    if not seqs:
        raise PaperError(f"{run_dir}/bus.lcmlog: no block with both FW_STATE and SIM_TRUTH")
    return [(s, fw[s], tr[s]) for s in seqs]


def model_error(f, t):
    """Largest distance (nm) between a modelled particle and the true one."""
    truth = {p.id: p for p in t.particles}
    return max(float(np.hypot(p.x_nm - truth[p.id].x_nm, p.y_nm - truth[p.id].y_nm)) for p in f.particles if p.id in truth)
