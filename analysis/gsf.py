"""A reader of Gwyddion Simple Field (.gsf) files, written from the format's
description (text header "Gwyddion Simple Field 1.0", "Key = value" lines,
NUL padding to a multiple of 4 bytes, then XRes * YRes little-endian float32,
row by row), independent of the bench's writer (host/image/display.cpp).

    from analysis import gsf
    header, z = gsf.read("runs/demo/scan_final.gsf")
    z.shape == (int(header["YRes"]), int(header["XRes"]))
    xs, ys = gsf.axes(header)          # pixel centres, in header["XYUnits"]

read(path) returns (header, values):
  header  {key: value}, both strings, every line of the header in order;
  values  a numpy float32 array of shape (YRes, XRes), in header["ZUnits"]
          (the bench: heights in m; the lateral channel in V).

Orientation: values[0] is the top row of the image, the line at the largest
y (+y, the far edge of the field in frame A: YOffset + YReal); values[-1] is
the line at YOffset. Within a row, column 0 is at XOffset (-x) and x grows
with the column. This is the file's order (Gwyddion's: rows from the top),
unchanged: to plot with y up, imshow(values, origin="upper") as is, or
np.flipud(values) for a row index that grows with y.

The bench's files carry the run's metadata as extra header keys (the
renderer writes them; docs/data.md lists them): Scene, Load_nN,
SetPoint_nN, ScanAngle_deg, SimTime_s, Date, Channel (Height or Lateral),
and ScanRequest (the scan's req_id on the bus) or Frame (the display's).

Every numeric header field is checked against RANGES, the same table as
the C++ reader's (common/gsf.hpp kGsfRanges: tests/py/test_gsf.py tries each
entry at and past its bounds, as tests/host/test_gsf.cpp does the C++ one);
a file that is not one, or whose field is out of its range, is a ValueError
in one line naming the file, the field and the value, escaped
(analysis/text.py)."""
import math
import os

import numpy as np

from analysis.text import printable

MAGIC = b"Gwyddion Simple Field 1.0\n"
MAX_RES = 4096
MAX_HEADER_BYTES = 65536
# field: (lowest, highest, whole number, required); lengths in m
RANGES = {
    "XRes": (2, MAX_RES, True, True),
    "YRes": (2, MAX_RES, True, True),
    "XReal": (1e-10, 1.0, False, True),
    "YReal": (1e-10, 1.0, False, True),
    "XOffset": (-1.0, 1.0, False, False),
    "YOffset": (-1.0, 1.0, False, False),
}


def _header(raw, path):
    if not raw.startswith(MAGIC):
        raise ValueError(f"{path}: not a Gwyddion Simple Field file (no '{MAGIC.decode().strip()}' line)")
    nul = raw.find(b"\0")
    if nul < 0 or nul > MAX_HEADER_BYTES:
        raise ValueError(f"{path}: no NUL padding after the header (within 64 KiB)")
    start = nul + (4 - nul % 4)
    if raw[nul:start].strip(b"\0") or start > len(raw):
        raise ValueError(f"{path}: header padding is not NULs")
    header = {}
    for line in raw[len(MAGIC):nul].split(b"\n"):
        key, eq, value = line.partition(b"=")
        if not line:
            continue
        if not eq:
            raise ValueError(f"{path}: header line without '=': '{printable(line[:80])}'")
        try:
            key, value = key.decode("utf-8").strip(" \t\r"), value.decode("utf-8").strip(" \t\r")
        except UnicodeDecodeError:
            raise ValueError(f"{path}: header line not UTF-8 text: '{printable(line[:80])}'") from None
        if key in header:   # which one would a reader take?
            raise ValueError(f"{path}: GSF header {printable(key)} given twice")
        header[key] = value
    return header, start


def number(path, header, key):
    """Header field `key` as a number in its RANGES entry (0 when missing
    and not required); ValueError naming the file, the field and the value."""
    lo, hi, whole, required = RANGES[key]
    if key not in header:
        if required:
            raise ValueError(f"{path}: GSF header {key} is missing")
        return 0
    text = header[key]
    try:
        v = float(text) if "_" not in text else math.nan   # C's strtod takes no 1_000
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and lo <= v <= hi and (not whole or v == math.floor(v))):
        raise ValueError(f"{path}: GSF header {key} must be {'a whole number' if whole else 'a number'} in [{lo:.9g}, {hi:.9g}], "
                         f"got '{printable(text[:80])}'")
    return int(v) if whole else v


def read(path):
    """(header, values) of a GSF file (see the module's contract);
    ValueError naming the file when it is not one."""
    shown = printable(os.fspath(path))
    try:
        with open(path, "rb") as f:
            if os.fstat(f.fileno()).st_size > MAX_HEADER_BYTES + 4 * MAX_RES * MAX_RES:
                raise ValueError(f"{shown}: larger than a {MAX_RES} x {MAX_RES} GSF file")
            raw = f.read()
    except OSError as e:
        raise ValueError(f"{shown}: cannot read the GSF file ({e.strerror})") from None
    header, start = _header(raw, shown)
    nx, ny = (number(shown, header, key) for key in ("XRes", "YRes"))
    for key in RANGES:
        number(shown, header, key)
    if len(raw) - start != 4 * nx * ny:
        raise ValueError(f"{shown}: {len(raw) - start} data bytes for {nx} x {ny} values")
    values = np.frombuffer(raw, dtype="<f4", count=nx * ny, offset=start).reshape(ny, nx)
    return header, values.astype(np.float32)   # a copy: writable, native order


def axes(header):
    """(xs, ys): the x of each column's and the y of each row's pixel centre,
    in the header's XYUnits; ys decreases with the row (row 0 at +y)."""
    nx, ny = int(header["XRes"]), int(header["YRes"])
    xr, yr = float(header["XReal"]), float(header["YReal"])
    x0, y0 = float(header.get("XOffset", 0)), float(header.get("YOffset", 0))
    xs = x0 + (np.arange(nx) + 0.5) * xr / nx
    ys = y0 + yr - (np.arange(ny) + 0.5) * yr / ny
    return xs, ys
