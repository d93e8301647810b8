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
  - the card minus the simulator's truth (FW_STATE less SIM_TRUTH, paired
    by block: report_series.Series.diff) for the force (x, y, z), the
    compensated apex, and each object's position as the card modelled it
    (at most MAX_OBJECTS particles, those the card had most wrong); each
    line drawn through its bins' extremes (report_series.Envelope), each
    axis titled with its bias and RMS, and a table of bias, RMS and worst;
  - the fidelity check with its image and its objects;
  - the card's configuration (run.json "card"), the planner's or the hand's
    account (run.json "operator"), and the costs (wall and CPU time per
    process).
Every value is shown through analysis/units.py (physical units, at most 4
significant digits, yes/no); every table whole. The page fits 1,000 px:
the contact sheet's tiles flow in rows the page's width holds, shown at a
size where their labels read MIN_CAP_PX; the video's controls sit below the
picture. Each figure is also written beside the page, figures/NAME.png and
figures/NAME.svg (linked from the page): a forked child draws the SVGs
(and the last figure's PNG) while the parent draws the other PNGs, so
that on a second core they cost the page no wall time.
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

from analysis import safefs, units

MAX_OBJECTS = 6
VIDEO_MAX_BYTES = 40 << 20
CONTENT_PX = 968          # the page's 1,000 px less its padding
FIGURES = "figures"       # beside the page: each figure's PNG and SVG


def _plt():
    """matplotlib with the page's text sizes: its figures are made without
    pyplot (matplotlib.figure.Figure, drawn by Agg on savefig), whose
    import and figure manager a page of PNGs does not need."""
    import matplotlib
    # at dpi 100, 9 pt is 12.5 px: no text in a figure under 12 px at 100 %;
    # the SVGs' text as text (the reader's font), not paths
    matplotlib.rcParams.update({"font.size": 10, "legend.fontsize": 9, "legend.title_fontsize": 9,
                                "axes.titlesize": 10, "svg.fonttype": "none"})
    return matplotlib


def _figure(nrows, ncols, figsize, right_in=0.15, **kw):
    """A figure and its axes in fixed margins (room for the tick labels of
    six digits, the axis labels and each axis's title; right_in: room for
    legends at the right): a layout engine measures every text by drawing
    it, which cost each figure as much again as its drawing."""
    _plt()
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize)
    w, h = figsize
    gap_in = 0.55   # between rows: an axis's title and the x ticks above it
    axes_h = (h - 0.6 - 0.35 - (nrows - 1) * gap_in) / nrows
    fig.subplots_adjust(left=0.85 / w, right=1 - right_in / w, bottom=0.6 / h, top=1 - 0.35 / h,
                        wspace=1.1 / ((w - right_in) / ncols), hspace=gap_in / axes_h)
    return fig, fig.subplots(nrows, ncols, squeeze=False, **kw).ravel()


def _png(fig):
    return "data:image/png;base64," + base64.b64encode(_png_bytes(fig)).decode()


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


class _Inline:
    """A file of the run inlined into the page as a data URI as the page is
    written, read and encoded a chunk at a time (the video: its bytes, their
    base64 and the page never all in memory at once)."""
    CHUNK = 3 << 20   # a multiple of 3: the chunks' base64 joins into the whole file's

    def __init__(self, fd, mime):
        self.fd, self.mime = fd, mime

    def write_to(self, f):
        f.write(f"data:{self.mime};base64,".encode())
        os.lseek(self.fd, 0, os.SEEK_SET)
        while True:
            data = os.read(self.fd, self.CHUNK)
            while data and len(data) % 3 and (more := os.read(self.fd, 3 - len(data) % 3)):
                data += more
            if not data:
                return
            f.write(base64.b64encode(data))

    def close(self):
        os.close(self.fd)


def _stats_text(st, unit):
    """An axis's bias and RMS in words."""
    if st["bias"] is None:
        return "no pair of card and truth"
    return f"bias {units.show(st['bias'], unit, sign=True, like=st['rms'])}, RMS {units.show(st['rms'], unit)}"


# The figures: (name, title, [(column, what is plotted)], size in inches).
FORCE = ("force", "Force of the sample on the tip: the card's minus the truth",
         [("force_nN_x", "F_x"), ("force_nN_y", "F_y"), ("force_nN_z", "F_z")], (9, 6.6))
APEX = ("apex", "The apex: the card's compensated position minus the truth",
        [("tip_nm_x", "apex x"), ("tip_nm_y", "apex y")], (9, 4.6))
OBJECTS = ("objects", "Objects: the card's model minus the truth", [("x_nm", "x"), ("y_nm", "y")], (9, 5.2))
TICKS = 9   # ticks an axis is given ahead (a figure's drawing makes them otherwise, at 2 ms each)
_SKELETONS = {}


def _skeleton(spec):
    """A figure of `spec` with its axes, labels and zero lines and no data,
    its ticks made ahead: built once (while ./afm run's run runs, under
    --wait) and filled once."""
    name, _, columns, size = spec
    if name not in _SKELETONS:
        fig, axs = _figure(len(columns), 1, size, right_in=3.3 if spec is OBJECTS else 0.15, sharex=True)
        for ax, (col, what) in zip(axs, columns):
            ax.axhline(0, color="0.55", lw=0.6)
            ax.set_ylabel(f"{what} ({units.split(col)[1]})")
            ax.xaxis.get_major_ticks(TICKS)
            ax.yaxis.get_major_ticks(TICKS)
        axs[-1].set_xlabel("simulated time (s)")
        _SKELETONS[name] = (fig, axs)
    return _SKELETONS.pop(name)


def _diff_axes(series, spec):
    """(name, title, figure, rows of the table): card minus truth per block."""
    name, title, columns, _ = spec
    fig, axs = _skeleton(spec)
    rows = []
    for ax, (col, what) in zip(axs, columns):
        unit = units.split(col)[1]
        st = series.diff_stats.figures(col)
        ax.plot(*series.diff.points(0, col), lw=0.8, color="C0")
        ax.set_title(f"{what}, card − truth: {_stats_text(st, unit)}", loc="left")
        rows.append((what, st, unit))
    return name, title, fig, rows


def _object_ids(series):
    """The particles the card had most wrong (RMS distance), at most MAX_OBJECTS."""
    ids = series.particle_diff_ids()
    rms = []
    for i in ids:
        st = series.particle_diff_stats.get(i)
        fx, fy = (st.figures("x_nm"), st.figures("y_nm")) if st else ({"rms": None}, {"rms": None})
        rms.append(np.hypot(fx["rms"] or 0, fy["rms"] or 0))
    return [ids[k] for k in np.argsort(-np.array(rms), kind="stable")[:MAX_OBJECTS]]


def _objects(series):
    """(name, title, figure, rows): each object's modelled position minus the truth's."""
    ids = _object_ids(series)
    if not ids:
        return None
    fig, axs = _skeleton(OBJECTS)
    rows = []
    for ax, (col, c) in zip(axs, OBJECTS[2]):
        for i in ids:
            st = series.particle_diff_stats[i].figures(col)
            ax.plot(*series.particle_diff_points(i, col), lw=0.9, drawstyle="steps-post", label=f"p{i}: {_stats_text(st, 'nm')}")
            rows.append((f"object p{i}, {c}", st, "nm"))
        ax.set_title(f"{c}, card's model − truth", loc="left")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0, handlelength=1.2)
    rows.sort(key=lambda r: r[0])
    return ("objects", f"Objects (the {len(ids)} the card had most wrong): the card's model minus the truth", fig, rows)


def _figures(series):
    """Every figure of the page: [(name, title, figure, table rows)]."""
    from analysis.report_series import FW, TRUTH
    if not (series and series.has(FW) and series.has(TRUTH)):
        return []
    obj = _objects(series)
    return [_diff_axes(series, FORCE), _diff_axes(series, APEX)] + ([obj] if obj else [])


def _diff_table(figs):
    """Bias, RMS and worst of every card-minus-truth figure, one row each."""
    head = "<tr><th>card − truth</th><th>bias (mean)</th><th>RMS</th><th>worst</th><th>compared</th></tr>"
    body = []
    for _, _, _, rows in figs:
        for what, st, unit in rows:
            if st["bias"] is None:
                continue
            cells = [units.show(st["bias"], unit, sign=True, like=st["rms"]), units.show(st["rms"], unit),
                     units.show(st["worst"], unit, like=st["rms"])]
            body.append(f"<tr><th>{html.escape(what)}</th>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) +
                        f"<td>{st['n']} rows</td></tr>")
    return f'<table class="num">{head}{"".join(body)}</table>' if body else ""


def _png_bytes(fig):
    import io
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, pil_kwargs={"compress_level": 1})   # zlib's fastest: its time, not bytes, waited for
    return buf.getvalue()


def _child(figs, mine, dest, out_fd):
    """The forked child's share (_draw): the PNGs of `mine` (their bytes
    pickled into out_fd) and every SVG, written into dest; exits 0, or 1
    having said why."""
    import io
    import pickle
    code = 0
    try:
        pngs = {name: _png_bytes(fig) for name, _, fig, _ in figs if name in mine}
        with os.fdopen(out_fd, "wb") as f:
            f.write(pickle.dumps(pngs))
        for name, _, fig, _ in figs:
            buf = io.StringIO()
            fig.savefig(buf, format="svg", metadata={"Date": None})
            safefs.write_atomic(dest[0], f"{FIGURES}/{name}.svg", buf.getvalue(), dest[1])
    except BaseException as e:   # the parent's page then links no SVG
        print(f"run_report: the SVG figures were not written: {e}", file=sys.stderr)
        code = 1
    finally:
        sys.stderr.flush()
        os._exit(code)


def _draw(figs, dest):
    """The figures as PNG data URIs, each also written as dest's
    figures/NAME.png and figures/NAME.svg. dest: (folder descriptor, its
    path), or None (no files: the PNGs alone, here). With dest the work is
    shared with a forked child on the second core: it draws the last
    figure's PNG (sent back through a pipe) and every SVG while this
    process draws the other PNGs. Returns ({name: data URI}, {name: True
    when its SVG is there})."""
    import pickle
    if dest is not None:
        try:
            os.close(safefs.make_dir(dest[0], FIGURES, dest[1]))
        except (safefs.Refused, OSError) as e:   # a link planted there: the figures inline only, and said
            print(f"run_report: {e}: the figures are not written as files", file=sys.stderr)
            dest = None
    pid, theirs, pngs = None, set(), {}
    if dest is not None and figs:
        theirs = {figs[-1][0]} if len(figs) > 1 else set()
        r, w = os.pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            os.close(r)
            _child(figs, theirs, dest, w)
        os.close(w)
    for name, _, fig, _ in figs:
        if name not in theirs:
            pngs[name] = _png_bytes(fig)
    svgs = {}
    if pid is not None:
        with os.fdopen(r, "rb") as f:
            got = f.read()
        ok = os.waitpid(pid, 0)[1] == 0
        pngs.update(pickle.loads(got) if got else {})
        svgs = {name: ok for name, _, _, _ in figs}
    uris = {}
    for name, _, _, _ in figs:
        if name not in pngs:   # the child failed before its PNG: drawn here
            pngs[name] = _png_bytes(next(f for n, _, f, _ in figs if n == name))
        uris[name] = "data:image/png;base64," + base64.b64encode(pngs[name]).decode()
        if dest is not None:
            safefs.write_atomic(dest[0], f"{FIGURES}/{name}.png", pngs[name], dest[1])
    return uris, svgs


def _figures_html(figs, uris, svgs):
    parts = []
    for name, title, _, _ in figs:
        links = ""
        if svgs.get(name):
            links = (f'<p class="note">As files: <a href="{FIGURES}/{name}.svg">{FIGURES}/{name}.svg</a> (vector, for print), '
                     f'<a href="{FIGURES}/{name}.png">{FIGURES}/{name}.png</a></p>')
        parts.append(f'<h2>{html.escape(title)}</h2><img alt="{html.escape(title)}" src="{uris[name]}">{links}')
    if figs:
        parts.append("<h2>The card minus the truth, in figures</h2>" + _diff_table(figs))
    return "".join(parts)


def _table(d):
    return units.html_table(d)


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
    """(label, text) rows: the run's times and each process's CPU time."""
    rows = [("wall time", units.show(info.get("wall_seconds"), "s")),
            ("simulated time", units.show(info.get("sim_seconds"), "s")),
            ("simulated s per wall s", units.show(info.get("sim_seconds_per_wall_second")))]
    for p in info.get("processes", []):
        cpu = (p.get("cpu_user_s") or 0) + (p.get("cpu_system_s") or 0)
        rows.append((f"{p.get('name')} CPU time", units.show(cpu, "s")))
    return rows


def _rows_table(rows):
    return ('<table class="kv">' + "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows) +
            "</table>")


def _fidelity_objects(objs):
    """The fidelity check's objects, one row each."""
    if not objs:
        return ""
    head = "<tr><th>object</th><th>kind</th><th>found</th><th>display at</th><th>fresh scan at</th><th>error</th></tr>"
    body = []
    for o in objs:
        at = [", ".join(units.show(v, "nm") for v in (o.get(k) or [])) or "none" for k in ("display_nm", "scan_nm")]
        cells = [str(o.get("kind", "")), units.show(o.get("found")), at[0], at[1], units.show(o.get("error_nm"), "nm")]
        body.append(f"<tr><th>{html.escape(str(o.get('id', '')))}</th>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    return f'<table class="num">{head}{"".join(body)}</table>'


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


# The video's own controls, below the picture (the browser's would cover
# the frame's bottom text and its x axis): play/pause, the time as a slider
# and in seconds.
VIDEO_JS = """(function () {
  const v = document.getElementById('run-video'), b = document.getElementById('run-video-play'),
        seek = document.getElementById('run-video-seek'), t = document.getElementById('run-video-time');
  const say = () => { t.textContent = v.currentTime.toFixed(2) + ' / ' + (v.duration || 0).toFixed(2) + ' s';
                      if (v.duration) seek.value = 1000 * v.currentTime / v.duration; b.textContent = v.paused ? 'Play' : 'Pause'; };
  b.onclick = () => { if (v.paused) v.play(); else v.pause(); };
  seek.oninput = () => { if (v.duration) v.currentTime = seek.value / 1000 * v.duration; };
  for (const e of ['timeupdate', 'loadedmetadata', 'play', 'pause', 'ended']) v.addEventListener(e, say);
})();"""


def png_size(data):
    """(width, height) of PNG bytes (its IHDR), or None."""
    if len(data) < 24 or data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def sheet_grid(size, tile_px):
    """(columns, rows, gap) of a contact sheet of square tiles of tile_px
    with equal gaps around them, read from its size; None when the size is
    not such a grid."""
    if not size or not tile_px:
        return None
    w, h = size
    cols, rows = w // tile_px, h // tile_px
    if cols < 1 or rows < 1 or (w - cols * tile_px) % (cols + 1):
        return None
    gap = (w - cols * tile_px) // (cols + 1)
    return (cols, rows, gap) if h == rows * tile_px + (rows + 1) * gap else None


def _sheet_html(sheet, tile_px, cap, n_tiles):
    """The contact sheet: its tiles in rows that fit the page, each shown
    where its labels read MIN_CAP_PX (one CSS background, positioned per
    tile); the whole image fitted to the page when its grid is not found."""
    uri = _file_uri(sheet, "image/png")
    grid = sheet_grid(png_size(sheet), tile_px)
    cap_attr = f' data-label-cap-px="{int(cap)}"' if cap else ""
    if grid is None:
        return f'<img alt="contact sheet"{cap_attr} src="{uri}">'
    cols, rows, gap = grid
    least = MIN_CAP_PX / cap if cap else 1.0
    per_row = max(1, int(CONTENT_PX // (tile_px * least + 6)))
    scale = max(least, min(1.0, (CONTENT_PX / per_row - 6) / tile_px))
    shown, w, h = tile_px * scale, png_size(sheet)[0] * scale, png_size(sheet)[1] * scale
    tiles = []
    for k in range(min(n_tiles or cols * rows, cols * rows)):
        x, y = gap + (k % cols) * (tile_px + gap), gap + (k // cols) * (tile_px + gap)
        tiles.append(f'<div class="tile"{cap_attr} data-natural-px="{tile_px}" style="width:{shown:.0f}px;height:{shown:.0f}px;'
                     f'background-size:{w:.1f}px {h:.1f}px;background-position:-{x * scale:.1f}px -{y * scale:.1f}px"></div>')
    return f'<style>.tile {{ background-image: url("{uri}"); }}</style><div class="tiles">{"".join(tiles)}</div>'


def _media(folder, info):
    parts = []
    ren = info.get("renderer") or {}
    cap = ren.get("label_cap_px")
    frame_px = ren.get("frame_px") or ren.get("image_px")
    width = video_width_px(frame_px, cap)
    cap_attr = f' data-label-cap-px="{int(cap)}"' if cap else ""
    for name, mime in (("video.mp4", "video/mp4"), ("video.webm", "video/webm"), ("video.avi", "video/x-msvideo")):
        fd = folder.open(name)
        if fd is not None and 0 < os.fstat(fd).st_size <= VIDEO_MAX_BYTES:
            parts += [f'<h2>Video</h2><video id="run-video" muted playsinline preload="auto" width="{width}"{cap_attr} src="',
                      _Inline(fd, mime), '"></video>'
                      '<div class="controls"><button id="run-video-play" type="button">Play</button>'
                      f'<input id="run-video-seek" type="range" min="0" max="1000" value="0" style="width:{max(200, width - 260)}px">'
                      '<span id="run-video-time">0.00 s</span></div>'
                      f'<script>{VIDEO_JS}</script>'
                      f'<p class="note">{html.escape(_video_note(info, name))}</p>']
            break
        if fd is not None:
            os.close(fd)
    sheet = folder.read("contact_sheet.png")
    if sheet is not None:
        n = min(int(info.get("frames") or 0), 10 ** 6) or None
        parts.append("<h2>Contact sheet</h2>" + _sheet_html(sheet, frame_px, cap, _sheet_tiles(folder, n)))
    return parts


def _sheet_tiles(folder, frames):
    """How many frames the sheet holds: the scene's outputs.contact_sheet_frames
    (16 when it says none), at most the run's frames."""
    text = folder.read("scene.yaml", 1 << 20)
    want = 16
    if text:
        import re
        m = re.search(rb"^\s*contact_sheet_frames\s*:\s*(\d+)", text, re.M)
        want = int(m.group(1)) if m else want
    return min(want, frames) if frames else want


CSS = """body { font: 15px/1.45 sans-serif; max-width: 968px; margin: 1.5em auto; padding: 0 16px; color: #222; }
h1 { font-size: 24px; } h2 { font-size: 19px; margin-top: 1.6em; }
table { border-collapse: collapse; font-size: 14px; } th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: top; }
table.num td { text-align: right; } table.sub { font-size: 13px; margin: 0; } table.sub th, table.sub td { border-color: #e2e2e2; }
.good { color: #176b1e; font-weight: bold; font-size: 18px; } .bad { color: #b00020; font-weight: bold; font-size: 18px; }
.note { color: #555; font-size: 13px; } img { max-width: 100%; } * { box-sizing: border-box; }
video { image-rendering: pixelated; background: #000; display: block; max-width: 100%; height: auto; }
.controls { display: flex; gap: 10px; align-items: center; margin-top: 6px; font-size: 14px; }
.controls button { font-size: 14px; min-width: 5em; }
.tiles { display: flex; flex-wrap: wrap; gap: 6px; } .tile { background-repeat: no-repeat; image-rendering: pixelated; }"""


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
        return report_series.read(f"/proc/self/fd/{fd}", info.get("sim_seconds")), info
    except Exception as e:   # a run cut short: what run.json says, and why there is no more
        info.setdefault("error", f"its log does not read: {e}")
        return None, info
    finally:
        os.close(fd)


def render(run_dir, folder=None, dest=None):
    """The page's pieces, in order: HTML text, and _Inline files (the video)
    that write() streams into it; dest (a folder descriptor and its path):
    where its figures' files go (FIGURES), or None for none."""
    folder = folder or Folder(run_dir)
    series, info = _open(folder)
    figs = _figures(series)
    uris, svgs = _draw(figs, dest)
    fid = info.get("fidelity") or {}
    diff = folder.read("fidelity_diff.png")
    body = [f"<h1>Run {html.escape(str(info.get('scene_name', os.path.basename(os.path.abspath(run_dir)))))}</h1>",
            f'<p class="note">{html.escape(os.path.abspath(run_dir))}; scene {html.escape(str(info.get("scene", "")))}</p>',
            _verdict_html(info), _media(folder, info), _figures_html(figs, uris, svgs)]
    body.append("<h2>Fidelity: the display against a fresh scan</h2>" + _table({k: v for k, v in fid.items() if k != "objects"}))
    body.append(_fidelity_objects(fid.get("objects")))
    if diff is not None:
        fcap = (info.get("renderer") or {}).get("fidelity_label_cap_px")
        attr = f' data-label-cap-px="{int(fcap)}"' if fcap else ""
        body.append(f'<img alt="fidelity difference"{attr} src="{_file_uri(diff, "image/png")}">')
    body.append("<h2>The card's configuration</h2>" + _table(info.get("card")))
    body.append("<h2>The planner's or the hand's account</h2>" + _table(info.get("operator")))
    body.append("<h2>Costs</h2>" + _rows_table(_costs(info)))
    if folder.refused:
        body.append('<h2>Refused</h2><ul class="bad">' + "".join(f"<li>{html.escape(r)}</li>" for r in folder.refused) + "</ul>")
    pieces = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>run report</title>"
              f"<style>{CSS}</style></head><body>"]
    for k, part in enumerate(body):   # a part: text, or a list of pieces (_media's)
        pieces += ([] if k == 0 else ["\n"]) + (part if isinstance(part, list) else [part])
    return pieces + ["</body></html>"]


def write(run_dir, out=None):
    """The page into `out` (default RUN_DIR/report.html), through
    safefs.atomic, a piece at a time (render), its figures beside it
    (FIGURES); the path, and what was refused."""
    folder = Folder(run_dir)
    if out is None:
        out, dfd = os.path.join(run_dir, "report.html"), folder.fd
    else:
        dfd = safefs.open_dir(os.path.dirname(os.path.abspath(out)))
    pieces = render(run_dir, folder, (dfd, os.path.dirname(out)))
    try:
        with safefs.atomic(dfd, os.path.basename(out), os.path.dirname(out)) as f:
            for piece in pieces:
                if isinstance(piece, str):
                    f.write(piece.encode())
                else:
                    piece.write_to(f)
    finally:
        for piece in pieces:
            if not isinstance(piece, str):
                piece.close()
    return out, folder.refused


def _ready():
    """--wait: the imports and the library loaded; True once stdin says go."""
    fig, (ax,) = _figure(1, 1, (2, 2))   # a figure drawn and dropped: the fonts and Agg's caches loaded
    ax.plot([0, 1], [0, 1], label="x")
    ax.set_xlabel("simulated time (s)")
    ax.set_title("F_x, card − truth", loc="left")
    ax.legend(title="t")
    _png(fig)
    for spec in (FORCE, APEX, OBJECTS):   # the page's figures without data, their ticks made
        _SKELETONS[spec[0]] = _skeleton(spec)
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
