"""A reader of Gwyddion Simple Field (.gsf) files, written from the format's
description (text header "Gwyddion Simple Field 1.0", "Key = value" lines,
NUL padding to a multiple of 4 bytes, then XRes * YRes little-endian float32,
row by row), independent of the bench's writer (host_bridge/image/display.cpp).

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
and ScanRequest (the scan's req_id on the bus) or Frame (the display's)."""
import numpy as np

MAGIC = b"Gwyddion Simple Field 1.0\n"


def _header(raw, path):
    if not raw.startswith(MAGIC):
        raise ValueError(f"{path}: not a Gwyddion Simple Field file (no '{MAGIC.decode().strip()}' line)")
    nul = raw.find(b"\0")
    if nul < 0:
        raise ValueError(f"{path}: no NUL padding after the header")
    start = nul + (4 - nul % 4)
    if raw[nul:start].strip(b"\0"):
        raise ValueError(f"{path}: header padding is not NULs")
    header = {}
    for line in raw[len(MAGIC):nul].decode("utf-8").splitlines():
        key, eq, value = line.partition("=")
        if not eq:
            raise ValueError(f"{path}: header line without '=': {line!r}")
        header[key.strip()] = value.strip()
    return header, start


def read(path):
    """(header, values) of a GSF file (see the module's contract);
    ValueError naming the file when it is not one."""
    with open(path, "rb") as f:
        raw = f.read()
    header, start = _header(raw, path)
    try:
        nx, ny = int(header["XRes"]), int(header["YRes"])
    except (KeyError, ValueError):
        raise ValueError(f"{path}: XRes and YRes must be integers in the header")
    if len(raw) - start != 4 * nx * ny:
        raise ValueError(f"{path}: {len(raw) - start} data bytes for {nx} x {ny} values")
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
