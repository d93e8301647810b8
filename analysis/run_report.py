"""report.html for one run folder: one self-contained page (every image and
the video inline, no file beside it, nothing fetched) that a person opens
first.

    python -m analysis.run_report RUN_DIR [--out FILE]

`./afm run` writes it into every run folder it makes. What it shows, all
from the run's own files (run.json; bus.lcmlog read once, streaming, by
analysis/report_series.py, whose decimated series and running figures are
all it keeps of the log, so its time and memory stay bounded whatever the
run's length; contact_sheet.png, fidelity_diff.png, video.*):
  - the verdict (run.json "verdict"), and the run's status and error;
  - the video (H.264 when the renderer had ffmpeg: run.json
    renderer.video says which writer ran; shown at video_width_px) and the
    contact sheet;
  - the card's force against the simulator's truth (FW_STATE against
    SIM_TRUTH, x, y, z), the apex the card compensated against the true one,
    and each object's position as the card modelled it against the truth
    (at most MAX_OBJECTS particles, those that moved most); each line
    drawn through its bins' extremes (report_series.Envelope);
  - the fidelity check with its image;
  - the card's configuration (run.json "card"), the planner's or the hand's
    account (run.json "operator"), and the costs (wall and CPU time per
    process).
A run that failed still gets a page with what it left.

Every file of the run folder is read, and the page written, through
analysis/safefs.py (the folder opened once; no link followed at any level,
no pipe waited on, the page written through a temporary file of its own):
started as root, this reads what a run's user wrote. A file refused there
(a link, a pipe, a device, a file with another hard link) is left out and
named on the page, under "Refused".
"""
import argparse
import base64
import html
import json
import os
import sys

import numpy as np

from analysis import safefs

MAX_OBJECTS = 6
VIDEO_MAX_BYTES = 40 << 20


def _plt():
    """matplotlib with the page's text sizes: its figures are made without
    pyplot (matplotlib.figure.Figure, drawn by Agg on savefig), whose
    import and figure manager a page of PNGs does not need."""
    import matplotlib
    # at dpi 100, 9 pt is 12.5 px: no text in a figure under 12 px at 100 %
    matplotlib.rcParams.update({"font.size": 10, "legend.fontsize": 9, "legend.title_fontsize": 9})
    return matplotlib


def _figure(nrows, ncols, figsize, **kw):
    """A figure and its axes in fixed margins (room for the tick labels of
    six digits and the axis labels): a layout engine measures every text by
    drawing it, which cost each figure as much again as its drawing."""
    _plt()
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize)
    w, h = figsize
    fig.subplots_adjust(left=0.85 / w, right=1 - 0.15 / w, bottom=0.6 / h, top=1 - 0.15 / h,
                        wspace=1.1 / (w / ncols), hspace=0.25 if nrows > 1 else 0.2)
    return fig, fig.subplots(nrows, ncols, **kw)


def _png(fig):
    import io
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


class Folder:
    """The run folder as opened once (safefs.open_dir), and what of it was refused."""

    def __init__(self, path):
        self.path, self.fd, self.refused = path, safefs.open_dir(path), []

    def read(self, name, limit=None):
        """A file's bytes, or None when it is missing, refused (named in
        self.refused) or larger than `limit`."""
        if not safefs.is_file(self.fd, name):
            return None
        try:
            data = safefs.read_bytes(self.fd, name, self.path, None if limit is None else limit + 1)
        except (safefs.Refused, OSError) as e:
            self.refused.append(str(e))
            return None
        return data if limit is None or len(data) <= limit else None

    def open(self, name):
        """A file opened for a reader that takes a path (/proc/self/fd/N:
        safefs.open_file), or None; the caller closes it."""
        if not safefs.is_file(self.fd, name):
            return None
        try:
            return safefs.open_file(self.fd, name, self.path)
        except (safefs.Refused, OSError) as e:
            self.refused.append(str(e))
            return None


def _file_uri(data, mime):
    return f"data:{mime};base64," + base64.b64encode(data).decode()


def _force_and_apex(series):
    """Two figures (data URIs): force and apex, card against truth, over time."""
    from analysis.report_series import FW, TRUTH
    out = []
    if not (series.has(FW) and series.has(TRUTH)):
        return out
    pts = series.blocks.points
    fig, axs = _figure(3, 1, (9, 6), sharex=True)
    for ax, c in zip(axs, "xyz"):
        ax.plot(*pts(TRUTH, f"force_nN_{c}"), lw=0.8, color="0.5", label="truth (SIM_TRUTH)")
        ax.plot(*pts(FW, f"force_nN_{c}"), lw=0.8, label="card (FW_STATE)")
        ax.set_ylabel(f"F_{c} (nN)")
    axs[0].legend(loc="upper right")
    axs[-1].set_xlabel("simulated time (s)")
    out.append(("Force of the sample on the tip: the card's against the truth", _png(fig)))
    fig, axs = _figure(1, 2, (9, 3.2))
    for ax, c in zip(axs, "xy"):
        ax.plot(*pts(TRUTH, f"tip_nm_{c}"), lw=0.8, color="0.5", label="truth")
        ax.plot(*pts(FW, f"tip_nm_{c}"), lw=0.8, label="card (compensated apex)")
        ax.set_xlabel("simulated time (s)")
        ax.set_ylabel(f"apex {c} (nm)")
    axs[0].legend()
    out.append(("The apex: the card's compensated position against the truth", _png(fig)))
    return out


def _objects(series):
    """A figure (data URI) of the particles that moved most: model against truth."""
    from analysis.report_series import FW, TRUTH
    truth_ids = series.particle_ids(TRUTH)
    if not truth_ids or not series.particle_ids(FW):
        return None
    spans = [series.particle_span(TRUTH, i) for i in truth_ids]
    ids = [truth_ids[k] for k in np.argsort(-np.array(spans), kind="stable")[:MAX_OBJECTS]]
    fig, axs = _figure(1, 2, (9, 3.4))
    for i in ids:
        for ax, c in zip(axs, "xy"):
            line, = ax.plot(*series.particle_points(TRUTH, i, f"{c}_nm"), lw=1.6, alpha=0.35)
            ax.plot(*series.particle_points(FW, i, f"{c}_nm"), lw=0.8, color=line.get_color(), label=f"id {i}")
    for ax, c in zip(axs, "xy"):
        ax.set_xlabel("simulated time (s)")
        ax.set_ylabel(f"{c} (nm)")
    axs[0].legend(title="thin: card, wide: truth")
    return (f"Objects (the {len(ids)} that moved most): the card's model against the truth", _png(fig))


def _table(d):
    if not isinstance(d, dict) or not d:
        return "<p>(none)</p>"
    rows = []
    for k, v in d.items():
        if isinstance(v, (dict, list)):
            v = json.dumps(v)[:300]
        rows.append(f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>")
    return "<table>" + "".join(rows) + "</table>"


def _verdict_html(info):
    v = info.get("verdict")
    status = info.get("status", "?")
    if status != "ok":
        return (f'<p class="bad">The run {html.escape(status)}: {html.escape(str(info.get("error", "")))}</p>')
    if not v:
        return "<p>No verdict in run.json (a run made before verdicts).</p>"
    met = ", ".join(v.get("met", []))
    if v["pass"]:
        return '<p class="good">Verdict: pass' + (f" (failed as the scene expects: {html.escape(met)})" if met else "") + "</p>"
    items = "".join(f"<li><b>{html.escape(f['check'])}</b>: {html.escape(f['detail'])}</li>" for f in v["failed"])
    return f'<p class="bad">Verdict: FAILED</p><ul>{items}</ul>'


def _costs(info):
    rows = {"wall_seconds": info.get("wall_seconds"), "simulated seconds": info.get("sim_seconds"),
            "simulated s per wall s": info.get("sim_seconds_per_wall_second")}
    for p in info.get("processes", []):
        rows[f"{p.get('name')} CPU (s)"] = round((p.get("cpu_user_s") or 0) + (p.get("cpu_system_s") or 0), 3)
    return rows


# Text in an image reads at least 12 px when its capitals are at least this
# high as shown: a 12 px sans-serif font's capitals measure 0.73 em
# (DejaVu Sans). The page shows each image with text (the video, the
# contact sheet, fidelity_diff.png) at a size that keeps the renderer's
# labels there (run.json renderer.label_cap_px, fidelity_label_cap_px).
MIN_CAP_PX = 9


def video_width_px(image_px, label_cap_px):
    """The width (CSS px) the page shows the video at: its labels' capitals
    MIN_CAP_PX or more, at least 512, at most 960 (a 256 px frame twice
    over)."""
    px = int(image_px or 512)
    least = px * MIN_CAP_PX / max(1, int(label_cap_px or MIN_CAP_PX))
    return int(max(512, min(960, max(px, least))))


def _video_note(info, name):
    v = (info.get("renderer") or {}).get("video") or {}
    if v.get("codec") == "h264":
        return f"{name}: H.264 ({v.get('encoder', '')})"
    if v.get("codec") == "mp4v":
        return (f"{name}: OpenCV's mp4v, which browsers do not play (no H.264: {v.get('fallback_why', '')}); "
                "open the file with a desktop player")
    return f"{name}: {v.get('codec', 'codec not recorded')}"


def _media(folder, info):
    parts = []
    ren = info.get("renderer") or {}
    cap = ren.get("label_cap_px")
    width = video_width_px(ren.get("image_px"), cap)
    cap_attr = f' data-label-cap-px="{int(cap)}"' if cap else ""
    for name, mime in (("video.mp4", "video/mp4"), ("video.webm", "video/webm"), ("video.avi", "video/x-msvideo")):
        data = folder.read(name, VIDEO_MAX_BYTES)
        if data:
            parts.append(f'<h2>Video</h2><video id="run-video" controls muted playsinline preload="auto" width="{width}"{cap_attr} '
                         f'src="{_file_uri(data, mime)}"></video>'
                         f'<p class="note">{html.escape(_video_note(info, name))}</p>')
            break
    sheet = folder.read("contact_sheet.png")
    if sheet is not None:   # at its own size (scrolled if wider than the page): its frames' labels as drawn
        parts.append(f'<h2>Contact sheet</h2><div class="wide"><img class="natural" alt="contact sheet"{cap_attr} '
                     f'src="{_file_uri(sheet, "image/png")}"></div>')
    return "".join(parts)


CSS = """body { font: 15px/1.45 sans-serif; max-width: 1000px; margin: 1.5em auto; padding: 0 1em; color: #222; }
h1 { font-size: 24px; } h2 { font-size: 19px; margin-top: 1.6em; }
table { border-collapse: collapse; font-size: 14px; } th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; }
.good { color: #176b1e; font-weight: bold; font-size: 18px; } .bad { color: #b00020; font-weight: bold; font-size: 18px; }
.note { color: #555; font-size: 13px; } img { max-width: 100%; }
video { image-rendering: pixelated; background: #000; }
.wide { overflow-x: auto; } img.natural { max-width: none; }"""


def _info(folder):
    """run.json as a dict (what it says when it is missing or not JSON)."""
    text = folder.read("run.json")
    try:
        return json.loads(text) if text is not None else {}
    except ValueError as e:
        return {"status": "unreadable", "error": f"run.json is not JSON: {e}"}


def _open(folder):
    """(report_series.Series or None, run.json as a dict): the log read in
    one pass (analysis/report_series.py) through the file safefs opened."""
    info = _info(folder)
    fd = folder.open("bus.lcmlog")
    if fd is None:
        info.setdefault("error", "its log is missing or was refused")
        return None, info
    from analysis import report_series
    try:
        return report_series.read(f"/proc/self/fd/{fd}"), info
    except Exception as e:   # a run cut short: what run.json says, and why there is no more
        info.setdefault("error", f"its log does not read: {e}")
        return None, info
    finally:
        os.close(fd)


def render(run_dir, folder=None):
    """The page's HTML text."""
    folder = folder or Folder(run_dir)
    series, info = _open(folder)
    figs = (_force_and_apex(series) + [f for f in [_objects(series)] if f]) if series else []
    fid = info.get("fidelity") or {}
    diff = folder.read("fidelity_diff.png")
    body = [f"<h1>Run {html.escape(str(info.get('scene_name', os.path.basename(os.path.abspath(run_dir)))))}</h1>",
            f'<p class="note">{html.escape(os.path.abspath(run_dir))}; scene {html.escape(str(info.get("scene", "")))}</p>',
            _verdict_html(info), _media(folder, info)]
    body += [f'<h2>{html.escape(t)}</h2><img alt="{html.escape(t)}" src="{uri}">' for t, uri in figs]
    body.append("<h2>Fidelity: the display against a fresh scan</h2>" + _table({k: v for k, v in fid.items() if k != "objects"}))
    if diff is not None:
        fcap = (info.get("renderer") or {}).get("fidelity_label_cap_px")
        attr = f' data-label-cap-px="{int(fcap)}"' if fcap else ""
        body.append(f'<div class="wide"><img class="natural" alt="fidelity difference"{attr} src="{_file_uri(diff, "image/png")}"></div>')
    body.append("<h2>The card's configuration</h2>" + _table(info.get("card")))
    body.append("<h2>The planner's or the hand's account</h2>" + _table(info.get("operator")))
    body.append("<h2>Costs</h2>" + _table(_costs(info)))
    if folder.refused:
        body.append('<h2>Refused</h2><ul class="bad">' + "".join(f"<li>{html.escape(r)}</li>" for r in folder.refused) + "</ul>")
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'><title>run report</title>"
            f"<style>{CSS}</style></head><body>" + "\n".join(body) + "</body></html>")


def write(run_dir, out=None):
    """The page into `out` (default RUN_DIR/report.html), through
    safefs.write_atomic; the path, and what was refused."""
    folder = Folder(run_dir)
    text = render(run_dir, folder)
    if out is None:
        out, dfd = os.path.join(run_dir, "report.html"), folder.fd
    else:
        dfd = safefs.open_dir(os.path.dirname(os.path.abspath(out)))
    safefs.write_atomic(dfd, os.path.basename(out), text, os.path.dirname(out))
    return out, folder.refused


def _ready():
    """--wait: the imports and the library loaded; True once stdin says go."""
    fig, ax = _figure(1, 1, (2, 2))   # a figure drawn and dropped: the fonts and Agg's caches loaded
    ax.plot([0, 1], [0, 1], label="x")
    ax.set_xlabel("simulated time (s)")
    ax.legend(title="t")
    _png(fig)
    from analysis import report_series
    try:
        report_series._lib()
    except FileNotFoundError:
        pass   # said when the page is written
    return sys.stdin.readline().strip() == "go"


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m analysis.run_report", description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir", help="a run folder (with run.json)")
    ap.add_argument("--out", help="the page (default RUN_DIR/report.html)")
    ap.add_argument("--wait", action="store_true",
                    help="load what the page needs (numpy, matplotlib, the log's reader), then wait for a line on "
                         "stdin: 'go' writes the page, anything else or the end exits 0 with none (./afm run starts "
                         "it beside the run, so the imports are not waited for after it)")
    a = ap.parse_args(argv)
    if a.wait and not _ready():
        return 0
    try:
        if not safefs.is_file(safefs.open_dir(a.run_dir), "run.json"):
            print(f"run_report: {a.run_dir}: no run.json (not a run folder)", file=sys.stderr)
            return 2
        out, refused = write(a.run_dir, a.out)
    except (safefs.Refused, OSError) as e:
        print(f"run_report: {e}", file=sys.stderr)
        return 2
    for r in refused:
        print(f"run_report: {r}", file=sys.stderr)
    print(f"run: report in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
