"""Export a run's folder for tools that do not read LCM logs:

    python -m analysis.export RUN_DIR --csv DIR      (./afm export ...)
    python -m analysis.export RUN_DIR --mcap FILE

--csv DIR writes DIR/CHANNEL.csv for every channel in the run's log: the
frames of open_run (analysis/runs.py: a row per message, units in the
column names, variable-length arrays and nested messages left out).

--mcap FILE writes one MCAP file (the `mcap` library), for Foxglove Studio
and PlotJuggler:
  - topic CHANNEL, for every channel of the log: every message, whole
    (nested objects and arrays included), JSON-encoded, with the JSON Schema
    analysis/lcmschema.py generates from lcmtypes/*.lcm (schema name
    afm.TYPE, encoding jsonschema); log time = the LCM log's timestamp;
  - topic /frames: the renderer's frames (frames/frame_NNNNN.png) as
    foxglove.CompressedImage, logged at the time the log recorded that
    frame's RENDER_FRAME;
  - topic /scans/NAME: each of the run's GSF files (NAME.gsf) as
    foxglove.Grid in frame "afm" (metres; row 0 at the scan's bottom, -y,
    as Grid's rows grow along +y), logged at the time the log recorded the
    scan's last line (its ScanRequest key) or the display's frame (Frame);
  - metadata "run": run.json's text.
The time of a message in nanoseconds is the LCM log's microseconds x 1000.

Errors (a missing folder, a folder without bus.lcmlog, a log cut short or
corrupt, a file that cannot be written) are one line on stderr naming the
file and what is wrong; exit 2."""
import argparse
import textwrap
import base64
import contextlib
import glob
import json
import os
import re
import sys

from analysis.text import printable

MAX_LOG_TIME_US = 2 ** 64 // 1000   # MCAP's log time: nanoseconds, unsigned 64-bit
FOXGLOVE_TIME = {
    "type": "object", "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}},
    "required": ["sec", "nsec"],
}
_XYZ = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}, "required": list("xyz")}
_XYZW = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}, "required": list("xyzw")}
# foxglove.CompressedImage and foxglove.Grid as Foxglove documents them
# (docs.foxglove.dev, message schemas), in their JSON encoding: bytes as base64.
COMPRESSED_IMAGE = {
    "$schema": "https://json-schema.org/draft/2020-12/schema", "title": "foxglove.CompressedImage",
    "description": "A compressed image", "type": "object",
    "properties": {
        "timestamp": FOXGLOVE_TIME, "frame_id": {"type": "string"},
        "data": {"type": "string", "contentEncoding": "base64"}, "format": {"type": "string"},
    },
    "required": ["timestamp", "frame_id", "data", "format"],
}
GRID = {
    "$schema": "https://json-schema.org/draft/2020-12/schema", "title": "foxglove.Grid",
    "description": "A 2D grid of data", "type": "object",
    "properties": {
        "timestamp": FOXGLOVE_TIME, "frame_id": {"type": "string"},
        "pose": {"type": "object", "properties": {"position": _XYZ, "orientation": _XYZW}, "required": ["position", "orientation"]},
        "column_count": {"type": "integer", "minimum": 0},
        "cell_size": {"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}}, "required": ["x", "y"]},
        "row_stride": {"type": "integer", "minimum": 0}, "cell_stride": {"type": "integer", "minimum": 0},
        "fields": {"type": "array", "items": {
            "type": "object", "required": ["name", "offset", "type"],
            "properties": {"name": {"type": "string"}, "offset": {"type": "integer", "minimum": 0}, "type": {"type": "integer", "minimum": 0, "maximum": 8}}}},
        "data": {"type": "string", "contentEncoding": "base64"},
    },
    "required": ["timestamp", "frame_id", "pose", "column_count", "cell_size", "row_stride", "cell_stride", "fields", "data"],
}
FLOAT32 = 7   # foxglove.NumericType


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
            df.to_csv(os.path.join(folder, ch + ".csv"), index=False)
    except OSError as e:
        raise ExportError(f"{e.filename or folder}: cannot write: {e.strerror}")
    return {ch: len(df) for ch, df in run.frames.items()}


# ---- MCAP ---------------------------------------------------------------------------

def _stamp(utime_us):
    return {"sec": int(utime_us // 1_000_000), "nsec": int(utime_us % 1_000_000) * 1000}


def _channel_ids(writer, run):
    """Registers a schema and a channel per LCM channel of the run."""
    from analysis import afmlog, lcmschema
    ids = {}
    for ch in run.frames:
        tname = afmlog.CHANNELS[ch]
        schema = lcmschema.json_schema(tname)
        sid = writer.register_schema(name=f"afm.{tname}", encoding="jsonschema", data=json.dumps(schema).encode())
        ids[ch] = writer.register_channel(topic=ch, message_encoding="json", schema_id=sid, metadata={"lcm_type": f"afm.{tname}"})
    return ids


def _write_bus(writer, run):
    """Every message of the log on its channel's topic; the count per channel."""
    from analysis import afmlog, lcmschema
    ids = _channel_ids(writer, run)
    counts = {ch: 0 for ch in ids}
    for ch in ids:
        tname = afmlog.CHANNELS[ch]
        for t, m in zip(run[ch]["log_time_us"].tolist(), run.messages(ch)):
            if not 0 <= t < MAX_LOG_TIME_US:   # a flipped bit in a timestamp made one negative (MCAP's are unsigned)
                raise ExportError(f"{run.dir}/bus.lcmlog: {ch} message {counts[ch]}: log time {t} us is outside MCAP's "
                                  f"range (a corrupt log?)")
            try:
                data = json.dumps(lcmschema.to_json(m, tname), allow_nan=False).encode()
            except ValueError:   # NaN or infinity: JSON has none (a corrupt log's flipped bit, or a run's fault)
                raise ExportError(f"{run.dir}/bus.lcmlog: {ch} message {counts[ch]} (log time {t} us) holds a value that is not "
                                  f"finite, which JSON cannot carry") from None
            writer.add_message(ids[ch], log_time=t * 1000, data=data, publish_time=t * 1000, sequence=counts[ch])
            counts[ch] += 1
    return counts


def _frame_times(run):
    """{frame index: (log time us, simulated utime us)} of the first RENDER_FRAME of each frame."""
    out = {}
    if "RENDER_FRAME" in run:
        for t, k, u in run["RENDER_FRAME"][["log_time_us", "index", "utime_us"]].itertuples(index=False):
            out.setdefault(int(k), (int(t), int(u)))
    return out


def _last_log_time(run):
    return max(int(df["log_time_us"].max()) for df in run.frames.values())


def _write_frames(writer, run):
    """frames/*.png as foxglove.CompressedImage on /frames; their number."""
    files = sorted(glob.glob(os.path.join(run.dir, "frames", "frame_*.png")))
    if not files:
        return 0
    sid = writer.register_schema(name="foxglove.CompressedImage", encoding="jsonschema", data=json.dumps(COMPRESSED_IMAGE).encode())
    cid = writer.register_channel(topic="/frames", message_encoding="json", schema_id=sid)
    times, last = _frame_times(run), _last_log_time(run)
    for i, path in enumerate(files):
        k = int(re.search(r"(\d+)\.png$", path).group(1))
        t, utime = times.get(k, (last, 0))
        with open(path, "rb") as f:
            png = f.read()
        msg = {"timestamp": _stamp(utime), "frame_id": "afm", "data": base64.b64encode(png).decode(), "format": "png"}
        writer.add_message(cid, log_time=t * 1000, data=json.dumps(msg).encode(), publish_time=t * 1000, sequence=i)
    return len(files)


def _scan_time(run, header):
    """The log time of a GSF file's source: its scan's last line, or its frame."""
    if "ScanRequest" in header and "AFM_SCAN_LINE" in run:
        lines = run["AFM_SCAN_LINE"]
        mine = lines[(lines["req_id"] == int(header["ScanRequest"])) & (lines["n"] == int(header["XRes"]))
                     & (lines["n_lines"] == int(header["YRes"]))]
        if len(mine):
            return int(mine["log_time_us"].max())
    if "Frame" in header:
        t = _frame_times(run).get(int(header["Frame"]))
        if t:
            return t[0]
    return _last_log_time(run)


def grid_message(header, values):
    """A GSF file (analysis.gsf.read) as a foxglove.Grid message: metres,
    frame "afm", the grid's rows from its bottom edge (-y) up."""
    import numpy as np
    nx, ny = int(header["XRes"]), int(header["YRes"])
    data = np.ascontiguousarray(np.flipud(values), dtype="<f4").tobytes()
    sim_s = float(header.get("SimTime_s", 0))
    z = header.get("ZUnits", "m")
    return {
        "timestamp": _stamp(round(sim_s * 1e6)), "frame_id": "afm",
        "pose": {"position": {"x": float(header.get("XOffset", 0)), "y": float(header.get("YOffset", 0)), "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
        "column_count": nx, "cell_size": {"x": float(header["XReal"]) / nx, "y": float(header["YReal"]) / ny},
        "row_stride": 4 * nx, "cell_stride": 4,
        "fields": [{"name": ("lateral_" if header.get("Channel") == "Lateral" else "height_") + z, "offset": 0, "type": FLOAT32}],
        "data": base64.b64encode(data).decode(),
    }


def _write_scans(writer, run):
    """Each GSF file as foxglove.Grid on /scans/NAME; their number."""
    scans = run.scans
    if not scans:
        return 0
    sid = writer.register_schema(name="foxglove.Grid", encoding="jsonschema", data=json.dumps(GRID).encode())
    for name, (header, values) in scans.items():
        cid = writer.register_channel(topic=f"/scans/{name}", message_encoding="json", schema_id=sid)
        t = _scan_time(run, header)
        writer.add_message(cid, log_time=t * 1000, data=json.dumps(grid_message(header, values)).encode(), publish_time=t * 1000)
    return len(scans)


def write_mcap(run, path):
    """The MCAP file (see the module's contract); (messages per channel, frames, grids)."""
    from mcap.writer import Writer
    tmp = path + ".part"
    try:
        with open(tmp, "wb") as f:
            w = Writer(f)
            w.start(profile="", library="afm-bench analysis.export")
            counts = _write_bus(w, run)
            frames = _write_frames(w, run)
            try:
                grids = _write_scans(w, run)
            except ValueError as e:   # a GSF file that does not read
                raise ExportError(str(e))
            w.add_metadata("run", {"run.json": json.dumps(run.info)})
            w.finish()
        os.replace(tmp, path)
    except OSError as e:
        raise ExportError(f"{e.filename or path}: cannot write: {e.strerror}")
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return counts, frames, grids


# ---- the command --------------------------------------------------------------------

class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"export: {message} (see --help)\n")


def parse(argv):
    from analysis import helptext
    p = _Parser(prog="./afm export", formatter_class=argparse.RawDescriptionHelpFormatter,
                description=helptext.text("export") + "\n\n" + textwrap.fill("Export a run's folder: its bus as CSV files (one per channel) "
                "or as one MCAP file (JSON messages with JSON Schemas from lcmtypes/*.lcm, the frames as "
                "foxglove.CompressedImage, the scans as foxglove.Grid) for Foxglove Studio and PlotJuggler. "
                "From Python: from analysis import open_run (docs/data.md).", 79),
                epilog="Exit 0 when written; 2 with one line naming the file and what is wrong.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run's folder (./afm run's --out): bus.lcmlog, run.json, frames/, *.gsf")
    p.add_argument("--csv", metavar="DIR", help="write DIR/CHANNEL.csv for every channel of the log")
    p.add_argument("--mcap", metavar="FILE", help="write the run as one MCAP file")
    a = p.parse_args(argv)
    if not a.csv and not a.mcap:
        p.error("say what to write: --csv DIR and/or --mcap FILE")
    return a


def main(argv=None):
    a = parse(sys.argv[1:] if argv is None else argv)
    try:
        run = open_checked(a.run_dir)
        if a.csv:
            counts = write_csv(run, a.csv)
            print(f"export: {len(counts)} channels, {sum(counts.values())} messages -> {a.csv}/CHANNEL.csv")
        if a.mcap:
            counts, frames, grids = write_mcap(run, a.mcap)
            print(f"export: {len(counts)} channels, {sum(counts.values())} messages, {frames} frames, {grids} scans -> {a.mcap}")
    except ExportError as e:
        print(f"export: {printable(str(e))}", file=sys.stderr)   # names from the folder and the log, escaped
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
