"""Export a run's folder for tools that do not read LCM logs:

    python -m analysis.export RUN_DIR --csv DIR      (./afm export ...)
    python -m analysis.export RUN_DIR --mcap FILE
    python -m analysis.export RUN_DIR --gwy FILE

--csv DIR writes DIR/CHANNEL.csv for every channel in the run's log: the
frames of open_run (analysis/runs.py: a row per message, units in the
column names, variable-length arrays and nested messages left out).

--mcap FILE writes one MCAP file (the `mcap` library), for Foxglove Studio
and PlotJuggler, every message logged and published at its simulated time
(sim_times: its own utime, or the block's in progress; ns), in that order:
  - topic CHANNEL, for every channel of the log: every message, whole
    (nested objects and arrays included), JSON-encoded, with the JSON Schema
    analysis/lcmschema.py generates from lcmtypes/*.lcm (schema name
    afm.TYPE, encoding jsonschema) and the LCM log's timestamp (the wall
    clock, us) as WALL_FIELD;
  - /scene/card, /scene/truth (foxglove.SceneUpdate), /tip, /truth/tip
    (PoseInFrame), /tf (FrameTransform): FW_STATE's and SIM_TRUTH's tip,
    objects, lever and force per block (analysis/foxglove.py);
  - /frames: the renderer's frames (frames/frame_NNNNN.png) as
    foxglove.CompressedImage at their RENDER_FRAME's simulated time;
  - /scans/NAME: each of the run's GSF files (NAME.gsf) as foxglove.Grid
    at its SimTime_s;
  - metadata "run": run.json's text.
The Foxglove types are protobuf with the schemas of Foxglove's package.
Beside it, layout_path(FILE) is a Foxglove layout (templates/foxglove_layout.json).

--gwy FILE writes the run's GSF files as the channels of one .gwy
(analysis/gwy.py).

Errors (a missing folder, a folder without bus.lcmlog, a log cut short or
corrupt, a run without GSF files for --gwy, a file that cannot be written)
are one line on stderr naming the file and what is wrong; exit 2. Each
file is written whole or not at all, no link followed (analysis/safefs.py's
atomic writer)."""
import argparse
import textwrap
import contextlib
import glob
import json
import os
import re
import sys

from analysis import safefs
from analysis.text import printable

MAX_LOG_TIME_US = 2 ** 64 // 1000   # MCAP's log time: nanoseconds, unsigned 64-bit
# The field of a channel's message that holds its simulated time (us); None:
# the message has none (AFM_SCAN_REQ's utime is the wall clock), so it takes
# the simulated time of the block in progress when the log recorded it.
SIM_TIME_FIELD = {"AFM_HEARTBEAT": "sim_utime", "AFM_SCAN_REQ": None}
WALL_FIELD = "log_wall_time_us"
LAYOUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates", "foxglove_layout.json")
CARD_RGBA, TRUTH_RGBA = (0.2, 0.5, 1.0, 0.9), (0.2, 0.9, 0.3, 0.5)


class ExportError(Exception):
    """A one-line reason the export cannot be made (file and what is wrong)."""


@contextlib.contextmanager
def quiet_c_stderr():
    """liblcm's reader prints to the C stderr when a log has garbage in it;
    the export says it itself, in one line."""
    sys.stderr.flush()
    saved = os.dup(2)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)


def open_checked(run_dir):
    """open_run, its errors as ExportError."""
    from analysis import afmlog, runs
    try:
        with quiet_c_stderr():
            return runs.open_run(run_dir)
    except (runs.RunError, afmlog.LogError) as e:
        raise ExportError(str(e))
    except OSError as e:
        raise ExportError(f"{e.filename or run_dir}: {e.strerror}")
    except UnicodeDecodeError:   # LCM's Python reader decodes each channel name; a flipped bit made one not UTF-8
        raise ExportError(f"{os.path.join(run_dir, 'bus.lcmlog')}: corrupt: an event's channel name is not UTF-8 text") from None


# ---- CSV ----------------------------------------------------------------------------

def write_csv(run, folder):
    """DIR/CHANNEL.csv per channel; {channel: rows}."""
    try:
        os.makedirs(folder, exist_ok=True)
        for ch, df in run.frames.items():
            safefs.write_path(os.path.join(folder, ch + ".csv"), df.to_csv(index=False))   # whole, no link followed
    except OSError as e:
        raise ExportError(f"{e.filename or folder}: cannot write: {e.strerror}")
    except safefs.Refused as e:
        raise ExportError(str(e))
    return {ch: len(df) for ch, df in run.frames.items()}


# ---- MCAP ---------------------------------------------------------------------------

def _range_checked(t, what):
    if not 0 <= t < MAX_LOG_TIME_US:   # a flipped bit made a time negative (MCAP's are unsigned)
        raise ExportError(f"{what}: log time {t} us is outside MCAP's range (a corrupt log?)")
    return t


class _Out:
    """The file's messages, gathered, then written in simulated-time order
    (log time = publish time = simulated time), each topic's sequence
    counting from 0."""

    def __init__(self, writer):
        self.w, self.rows, self.schemas, self.topics = writer, [], {}, {}

    def channel(self, topic, name, encoding, data, message_encoding, metadata=None):
        if name not in self.schemas:
            self.schemas[name] = self.w.register_schema(name=name, encoding=encoding, data=data)
        if topic not in self.topics:
            self.topics[topic] = self.w.register_channel(topic=topic, message_encoding=message_encoding,
                                                         schema_id=self.schemas[name], metadata=metadata or {})
        return self.topics[topic]

    def add(self, cid, utime_us, data, what):
        self.rows.append((_range_checked(int(utime_us), what), len(self.rows), cid, data))

    def proto(self, topic, utime_us, msg, what):
        from analysis import foxglove
        name, fds = foxglove.schema(type(msg))
        self.add(self.channel(topic, name, "protobuf", fds, "protobuf"), utime_us, msg.SerializeToString(), what)

    def write(self):
        self.rows.sort(key=lambda r: r[:2])
        seq = {}
        for t, _, cid, data in self.rows:
            n = seq[cid] = seq.get(cid, -1) + 1
            self.w.add_message(cid, log_time=t * 1000, publish_time=t * 1000, data=data, sequence=n)
        return len(self.rows)


def _block_clock(run):
    """(log times, simulated times) of AFM_ANALOG's blocks, in log order."""
    import numpy as np
    if "AFM_ANALOG" not in run:
        return np.zeros(0), np.zeros(0)
    a = run["AFM_ANALOG"]
    order = np.argsort(a["log_time_us"].to_numpy(), kind="stable")
    return a["log_time_us"].to_numpy()[order], a["utime_us"].to_numpy()[order]


def sim_times(run, ch, msgs, clock):
    """The simulated time (us) of each message of channel ch: its own field
    (SIM_TIME_FIELD; utime by default), or, where it has none or a negative
    one, that of the last block the log recorded before it (0 before any)."""
    import numpy as np
    field = SIM_TIME_FIELD.get(ch, "utime")
    logs, sims = clock
    out = []
    for t, m in zip(run[ch]["log_time_us"].tolist(), msgs):
        u = getattr(m, field) if field else -1
        if u < 0 and ch in SIM_TIME_FIELD:
            i = int(np.searchsorted(logs, t, "right")) - 1
            u = int(sims[i]) if i >= 0 else 0
        out.append(int(u))
    return out


def _write_bus(out, run, clock):
    """Every message of the log on its channel's topic, JSON with the log's
    wall-clock time as WALL_FIELD; the count per channel."""
    from analysis import afmlog, lcmschema
    counts = {}
    for ch in run.frames:
        tname = afmlog.CHANNELS[ch]
        schema = lcmschema.json_schema(tname)
        schema["properties"][WALL_FIELD] = {"type": "integer", "description": "when the launcher recorded it: "
                                            "the LCM log's timestamp, microseconds since the epoch (wall clock)"}
        schema["required"] = list(schema.get("required", [])) + [WALL_FIELD]
        cid = out.channel(ch, f"afm.{tname}", "jsonschema", json.dumps(schema).encode(), "json", {"lcm_type": f"afm.{tname}"})
        msgs = run.messages(ch)
        for i, (t, u, m) in enumerate(zip(run[ch]["log_time_us"].tolist(), sim_times(run, ch, msgs, clock), msgs)):
            what = f"{run.dir}/bus.lcmlog: {ch} message {i}"
            _range_checked(t, what)
            try:
                data = json.dumps({**lcmschema.to_json(m, tname), WALL_FIELD: t}, allow_nan=False).encode()
            except ValueError:   # NaN or infinity: JSON has none (a corrupt log's flipped bit, or a run's fault)
                raise ExportError(f"{what} (log time {t} us) holds a value that is not finite, which JSON cannot carry") from None
            out.add(cid, u, data, what)
        counts[ch] = len(msgs)
    return counts


def _paper_probe_um(name):
    """A default of the scene's probe: the paper's probe's FW_PAPER_NAME_NM
    (firmware/include/fw_paper_probe.h, where scene/scene.hpp takes it), um."""
    from analysis import paths
    header = os.path.join(paths.ROOT, "firmware", "include", "fw_paper_probe.h")
    try:
        with open(header) as f:
            m = re.search(rf"#define FW_PAPER_{name}_NM\s+([0-9.eE+-]+)", f.read())
    except OSError as e:
        raise ExportError(f"{header}: cannot read: {e.strerror}")
    if not m:
        raise ExportError(f"{header}: no FW_PAPER_{name}_NM")
    return float(m.group(1)) * 1e-3


def _probe(run):
    """(lever_length_um, tip_height_um): the run's scene.yaml's probe, else the paper probe's."""
    import yaml
    try:
        with open(os.path.join(run.dir, "scene.yaml")) as f:
            probe = (yaml.safe_load(f) or {}).get("probe") or {}
    except (OSError, yaml.YAMLError, AttributeError):
        probe = {}
    return (float(probe.get("lever_length_um") or _paper_probe_um("LEVER_LENGTH")),
            float(probe.get("tip_height_um") or _paper_probe_um("TIP_HEIGHT")))


def _write_state(out, run):
    """The card's and the truth's tip, objects, lever and force as Foxglove
    types: /tf (afm -> tip, afm -> tip_truth), /tip and /truth/tip
    (PoseInFrame), /scene/card and /scene/truth (SceneUpdate); their number."""
    from analysis import afmlog, foxglove
    probe, n = _probe(run), 0
    for ch, child, pose_topic, name, rgba in (("FW_STATE", "tip", "/tip", "card", CARD_RGBA),
                                              ("SIM_TRUTH", "tip_truth", "/truth/tip", "truth", TRUTH_RGBA)):
        if ch not in run:
            continue
        for m, whole in afmlog.whole_objects(run.messages(ch), objects=lambda m: m.objects):
            what = f"{run.dir}/bus.lcmlog: {ch} seq {m.seq}"
            out.proto("/tf", m.utime, foxglove.transform(m.utime, child, m.tip_nm), what)
            out.proto(pose_topic, m.utime, foxglove.pose(m.utime, m.tip_nm), what)
            out.proto(f"/scene/{name}", m.utime, foxglove.scene(m.utime, name, whole, m.tip_nm, m.force_nN, probe, rgba), what)
            n += 3
    return n


def _frame_times(run):
    """{frame index: simulated utime us} of the first RENDER_FRAME of each frame."""
    from analysis import runs
    out = {}
    if "RENDER_FRAME" in run:
        for k, u in run["RENDER_FRAME"][[runs.column_name("index"), "utime_us"]].itertuples(index=False):
            out.setdefault(int(k), int(u))
    return out


def _last_sim_time(clock):
    return int(clock[1].max()) if len(clock[1]) else 0


def _write_frames(out, run, clock):
    """frames/*.png as foxglove.CompressedImage on /frames, at their
    RENDER_FRAME's simulated time; their number."""
    from analysis import foxglove
    files = sorted(glob.glob(os.path.join(run.dir, "frames", "frame_*.png")))
    times, last = _frame_times(run), _last_sim_time(clock)
    for path in files:
        u = times.get(int(re.search(r"(\d+)\.png$", path).group(1)), last)
        with open(path, "rb") as f:
            out.proto("/frames", u, foxglove.image(u, f.read()), path)
    return len(files)


def _write_scans(out, run, clock):
    """Each GSF file as foxglove.Grid on /scans/NAME, at its SimTime_s; their number."""
    from analysis import foxglove
    try:
        scans = run.scans
    except ValueError as e:   # a GSF file that does not read
        raise ExportError(str(e))
    for name, (header, values) in scans.items():
        u = round(float(header["SimTime_s"]) * 1e6) if "SimTime_s" in header else _last_sim_time(clock)
        out.proto(f"/scans/{name}", u, foxglove.grid(header, values), f"{run.dir}/{name}.gsf")
    return len(scans)


def layout_path(mcap_path):
    """Where the Foxglove layout goes beside an MCAP file: FILE.layout.json, less .mcap."""
    root, ext = os.path.splitext(mcap_path)
    return (root if ext == ".mcap" else mcap_path) + ".layout.json"


def write_mcap(run, path):
    """The MCAP file and its layout (see the module's contract);
    (messages per channel, frames, grids, Foxglove state messages)."""
    from mcap.writer import Writer
    try:
        with safefs.atomic_path(path) as f:   # whole or not at all, no link followed
            w = Writer(f)
            w.start(profile="", library="afm-bench analysis.export")
            out, clock = _Out(w), _block_clock(run)
            counts = _write_bus(out, run, clock)
            state = _write_state(out, run)
            frames = _write_frames(out, run, clock)
            grids = _write_scans(out, run, clock)
            out.write()
            w.add_metadata("run", {"run.json": json.dumps(run.info)})
            w.finish()
        with open(LAYOUT) as f:
            safefs.write_path(layout_path(path), json.dumps(json.load(f), indent=1))
    except OSError as e:
        raise ExportError(f"{e.filename or path}: cannot write: {e.strerror}")
    except safefs.Refused as e:
        raise ExportError(str(e))
    return counts, frames, grids, state


# ---- the command --------------------------------------------------------------------

class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"export: {message} (see --help)\n")


def parse(argv):
    from analysis import helptext
    p = _Parser(prog="./afm export", formatter_class=argparse.RawDescriptionHelpFormatter,
                description=helptext.text("export") + "\n\n" + textwrap.fill("Export a run's folder: its bus as CSV files (one per channel); "
                "as one MCAP file on simulated time (JSON messages with JSON Schemas from lcmtypes/*.lcm; the tip, objects, "
                "lever and force as foxglove.SceneUpdate, PoseInFrame and FrameTransform, the frames as "
                "foxglove.CompressedImage, the scans as foxglove.Grid) for Foxglove Studio and PlotJuggler, with a Foxglove "
                "layout beside it; or its scans as the channels of one Gwyddion file. "
                "From Python: from analysis import open_run (docs/data.md).", 79),
                epilog="Exit 0 when written; 2 with one line naming the file and what is wrong.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run's folder (./afm run's --out): bus.lcmlog, run.json, frames/, *.gsf")
    p.add_argument("--csv", metavar="DIR", help="write DIR/CHANNEL.csv for every channel of the log")
    p.add_argument("--mcap", metavar="FILE", help="write the run as one MCAP file, on simulated time, and FILE.layout.json "
                   "(less .mcap) for Foxglove")
    p.add_argument("--gwy", metavar="FILE", help="write the run's scans (height, lateral signal, display) as the channels of "
                   "one Gwyddion file, with their metadata")
    a = p.parse_args(argv)
    if not a.csv and not a.mcap and not a.gwy:
        p.error("say what to write: --csv DIR, --mcap FILE and/or --gwy FILE")
    return a


def main(argv=None):
    a = parse(sys.argv[1:] if argv is None else argv)
    try:
        run = open_checked(a.run_dir)
        if a.csv:
            counts = write_csv(run, a.csv)
            print(f"export: {len(counts)} channels, {sum(counts.values())} messages -> {a.csv}/CHANNEL.csv")
        if a.mcap:
            counts, frames, grids, state = write_mcap(run, a.mcap)
            print(f"export: {len(counts)} channels, {sum(counts.values())} messages, {state} Foxglove state messages, "
                  f"{frames} frames, {grids} scans -> {a.mcap} (Foxglove layout: {layout_path(a.mcap)})")
        if a.gwy:
            from analysis import gwy
            try:
                names = gwy.write_gwy(run, a.gwy)
            except gwy.GwyError as e:
                raise ExportError(str(e))
            print(f"export: {len(names)} channels ({', '.join(names)}) -> {a.gwy}")
    except ExportError as e:
        print(f"export: {printable(str(e))}", file=sys.stderr)   # names from the folder and the log, escaped
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
