"""A reader of Gwyddion Simple Field (.gsf) files, written from the format's
description (text header "Gwyddion Simple Field 1.0", "Key = value" lines,
NUL padding to a multiple of 4 bytes, then XRes * YRes little-endian float32),
independent of the bench's writer."""
import struct


def read(path):
    with open(path, "rb") as f:
        raw = f.read()
    magic = b"Gwyddion Simple Field 1.0\n"
    if not raw.startswith(magic):
        raise ValueError(f"{path}: not a Gwyddion Simple Field file")
    nul = raw.index(b"\0")
    start = nul + (4 - nul % 4)
    if raw[nul:start].strip(b"\0"):
        raise ValueError(f"{path}: header padding is not NULs")
    header = {}
    for line in raw[len(magic):nul].decode("utf-8").splitlines():
        key, _, value = line.partition("=")
        header[key.strip()] = value.strip()
    nx, ny = int(header["XRes"]), int(header["YRes"])
    n = nx * ny
    if len(raw) - start != 4 * n:
        raise ValueError(f"{path}: {len(raw) - start} data bytes for {nx} x {ny} values")
    values = struct.unpack(f"<{n}f", raw[start:])
    rows = [values[r * nx:(r + 1) * nx] for r in range(ny)]
    return header, rows
