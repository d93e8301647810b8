"""A scene from a scan (./afm scene from-scan FILE.gsf [--out SCENE.yaml]):

    python -m analysis.from_scan FILE.gsf --out SCENE.yaml

reads a height scan (GSF, metres: one the bench wrote, or one saved by
Gwyddion), levels it, finds the objects on it and writes a scene with them
on that substrate:

  - levelling: a plane fitted to the substrate (least squares, the pixels
    more than LEVEL_SIGMAS noise widths above it left out, three rounds),
    then each line's median of its substrate pixels taken off (a line fit
    of order 0: the scanner's line-to-line offsets);
  - objects: the connected regions more than FIND_SIGMAS noise widths (and
    at least MIN_HEIGHT_NM) above the substrate, of MIN_PIXELS or more. A
    region whose long axis is ROD_RATIO times its short one or more is a
    rod (objects.wires: its ends along the long axis, less the tip's
    widening, and its diameter its median ridge height); any other is a
    particle (objects.particles: a sphere fitted to its top, the pixels
    above CAP_FRACTION of its height; the sphere's top is the particle's
    top, 2 r above the substrate, so r = top / 2, and its centre x, y is
    the particle's: the tip widens the image but keeps its centre);
  - the substrate: the levelled scan with the objects' regions (grown by
    their widening) set to the substrate level 0, written as a GSF beside
    the scene (SCENE_substrate.gsf, float32 metres) and named as
    sample.substrate {gsf, material: glass};
  - the scene: name from-scan-NAME, field_nm the scan's side, the objects
    above (ids 1, 2, ... in the order found), an operator at rest at the
    field's centre (a scene needs one) and the scan's size as the display.

Errors (a file that is not a GSF height scan, no substrate to level) are one
line on stderr naming the file and what is wrong; exit 2."""
import argparse
import os
import sys

import numpy as np

LEVEL_SIGMAS = 3.0
FIND_SIGMAS = 5.0
MIN_HEIGHT_NM = 2.0
MIN_PIXELS = 4
ROD_RATIO = 2.5
CAP_FRACTION = 0.75


class ScanError(Exception):
    """A one-line reason no scene can be made (file and what is wrong)."""


def noise_nm(h):
    """The substrate's noise width: 1.4826 x the median absolute deviation, nm."""
    return 1.4826 * float(np.median(np.abs(h - np.median(h)))) or 1e-3


def level(z_nm, xs, ys):
    """The scan less its substrate plane and each line's offset, nm; and the noise width."""
    X, Y = np.meshgrid(xs, ys)
    A = np.column_stack([X.ravel(), Y.ravel(), np.ones(X.size)])
    keep = np.ones(X.size, bool)
    for _ in range(3):
        coef, *_ = np.linalg.lstsq(A[keep], z_nm.ravel()[keep], rcond=None)
        h = z_nm - (A @ coef).reshape(z_nm.shape)
        keep = h.ravel() < LEVEL_SIGMAS * noise_nm(h.ravel()[keep])
    sub = keep.reshape(h.shape)
    for r in range(h.shape[0]):
        if sub[r].sum() >= 3:
            h[r] -= np.median(h[r][sub[r]])
    return h, noise_nm(h[sub])


def fit_sphere(x, y, z):
    """(x0, y0, top) of the sphere through the points (linear least squares)."""
    A = np.column_stack([2 * x, 2 * y, 2 * z, np.ones_like(x)])
    (x0, y0, zc, k), *_ = np.linalg.lstsq(A, x * x + y * y + z * z, rcond=None)
    return x0, y0, zc + np.sqrt(max(k + x0 * x0 + y0 * y0 + zc * zc, 0.0))


def particle(h, region, X, Y):
    top = float(h[region].max())
    cap = region & (h >= CAP_FRACTION * top)
    if cap.sum() < 4:
        r, c = np.unravel_index(np.argmax(np.where(region, h, -np.inf)), h.shape)
        return {"x_nm": float(X[r, c]), "y_nm": float(Y[r, c]), "radius_nm": top / 2}
    x0, y0, t = fit_sphere(X[cap], Y[cap], h[cap])
    return {"x_nm": float(x0), "y_nm": float(y0), "radius_nm": float(t) / 2}


def rod(h, region, X, Y, axes):
    x, y = X[region], Y[region]
    cx, cy = x.mean(), y.mean()
    u = axes[:, -1]                                    # the long axis
    s = (x - cx) * u[0] + (y - cy) * u[1]
    d = float(np.median(h[region][h[region] >= 0.5 * h[region].max()]))
    half = max((s.max() - s.min()) / 2 - d / 2, d)     # the tip widens each end by about a radius
    return {"x0_nm": float(cx - half * u[0]), "y0_nm": float(cy - half * u[1]),
            "x1_nm": float(cx + half * u[0]), "y1_nm": float(cy + half * u[1]), "diameter_nm": d}


def find_objects(h, sigma, xs, ys):
    """([particle], [rod], mask of their regions) of a levelled scan."""
    from scipy import ndimage
    X, Y = np.meshgrid(xs, ys)
    labels, n = ndimage.label(h > max(FIND_SIGMAS * sigma, MIN_HEIGHT_NM))
    particles, rods = [], []
    for k in range(1, n + 1):
        region = labels == k
        if region.sum() < MIN_PIXELS:
            continue
        pts = np.column_stack([X[region], Y[region]])
        w, axes = np.linalg.eigh(np.cov(pts.T) if len(pts) > 2 else np.eye(2))
        if w[0] > 0 and np.sqrt(w[1] / w[0]) >= ROD_RATIO:
            rods.append(rod(h, region, X, Y, axes))
        else:
            particles.append(particle(h, region, X, Y))
    return particles, rods, ndimage.binary_dilation(labels > 0, iterations=2)


def write_gsf(path, header, values_m):
    """A GSF 1.0 file of float32 metres with the scan's size (the format of analysis/gsf.py)."""
    lines = ["Gwyddion Simple Field 1.0"] + [f"{k} = {header[k]}" for k in
                                            ("XRes", "YRes", "XReal", "YReal", "XOffset", "YOffset") if k in header]
    lines += ["XYUnits = m", "ZUnits = m", "Title = substrate"]
    text = ("\n".join(lines) + "\n").encode()
    text += b"\0" * (4 - len(text) % 4)
    with open(path, "wb") as f:
        f.write(text + np.ascontiguousarray(values_m, dtype="<f4").tobytes())


def scene_text(name, field_nm, substrate_file, particles, rods, centre):
    out = [f"# Made by ./afm scene from-scan from {name}: levelled, its objects found (analysis/from_scan.py).",
           f"name: from-scan-{name}", "seed: 1", "duration_s: 1.0",
           "effects: [adhesion, tip_convolution]", "sample:",
           f"  substrate: {{gsf: {substrate_file}, material: glass}}", f"  field_nm: {field_nm:.6g}", "objects:"]
    out.append("  particles:" if particles else "  particles: []")
    for i, p in enumerate(particles, 1):
        out.append(f"    - {{id: {i}, x_nm: {p['x_nm']:.2f}, y_nm: {p['y_nm']:.2f}, radius_nm: {p['radius_nm']:.2f}}}")
    if rods:
        out.append("  wires:")
        for i, w in enumerate(rods, len(particles) + 1):
            out.append(f"    - {{id: {i}, x0_nm: {w['x0_nm']:.2f}, y0_nm: {w['y0_nm']:.2f}, x1_nm: {w['x1_nm']:.2f}, "
                       f"y1_nm: {w['y1_nm']:.2f}, diameter_nm: {w['diameter_nm']:.2f}}}")
    out += ["operator:", "  load_nN: 5", f"  path_nm: [[{centre[0]:.1f}, {centre[1]:.1f}]]"]
    return "\n".join(out) + "\n"


def from_scan(path, out):
    """Writes the scene and its substrate; ([particle], [rod])."""
    from analysis import gsf
    try:
        header, z = gsf.read(path)
    except (ValueError, OSError) as e:
        raise ScanError(str(e) if isinstance(e, ValueError) else f"{path}: cannot read: {e.strerror}")
    if header.get("ZUnits", "m") != "m":
        raise ScanError(f"{path}: ZUnits {header.get('ZUnits')}: not a height scan (m)")
    xs, ys = (a * 1e9 for a in gsf.axes(header))
    h, sigma = level(z.astype(float) * 1e9, xs, ys)
    particles, rods, mask = find_objects(h, sigma, xs, ys)
    sub = os.path.splitext(out)[0] + "_substrate.gsf"
    try:
        write_gsf(sub, header, np.where(mask, 0.0, h) * 1e-9)
        with open(out, "w") as f:
            f.write(scene_text(os.path.basename(path)[:-4] if path.endswith(".gsf") else os.path.basename(path),
                               float(header["XReal"]) * 1e9, os.path.basename(sub), particles, rods,
                               (float(xs.mean()), float(ys.mean()))))
    except OSError as e:
        raise ScanError(f"{e.filename or out}: cannot write: {e.strerror}")
    return particles, rods


def main(argv=None):
    from analysis import helptext
    p = argparse.ArgumentParser(prog="./afm scene from-scan", formatter_class=argparse.RawDescriptionHelpFormatter,
                                description=helptext.text("scene") + "\n\n" + __doc__.split("\n\n", 1)[1],
                                epilog="Exit 0 when written; 2 with one line naming the file and what is wrong.")
    p.add_argument("scan", metavar="FILE.gsf", help="a height scan (GSF, metres)")
    p.add_argument("--out", metavar="SCENE.yaml", help="the scene to write (default: FILE_scene.yaml beside the scan)")
    a = p.parse_args(sys.argv[1:] if argv is None else argv)
    out = a.out or os.path.splitext(a.scan)[0] + "_scene.yaml"
    try:
        particles, rods = from_scan(a.scan, out)
    except ScanError as e:
        print(f"scene from-scan: {e}", file=sys.stderr)
        return 2
    print(f"scene from-scan: {len(particles)} particles, {len(rods)} rods -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
