"""A run's scans as one Gwyddion file (./afm export RUN --gwy FILE), through
the gwyfile package (pinned in tools/setup.sh).

write_gwy(run, path) writes every GSF file of the run (run.scans, read by
analysis/gsf.py) as a channel of one .gwy, in ORDER's order and then the
others (local scans) by name:

    /N/data         GwyDataField: the GSF's values, its XReal, YReal,
                    XOffset, YOffset in metres, its XYUnits and ZUnits
                    (height in m, the lateral signal S_l in V); row 0 the
                    scan's top edge (+y), as in the GSF file and Gwyddion
    /N/data/title   the GSF file's name less .gsf (scan_initial, ...)
    /N/meta         GwyContainer of text: every key of the GSF header
                    (Scene, Load_nN, SetPoint_nN, ScanAngle_deg, SimTime_s,
                    Date, Channel, ScanRequest or Frame) and, from run.json,
                    Run_* (scene_hash, seed, ... : its scalar values);
                    each a string (Gwyddion's metadata browser shows text)

The file is written whole or not at all (analysis/safefs.py's atomic
writer). A run without GSF files, or a file that cannot be written, raises
GwyError naming the folder or the file."""
import json

from analysis import safefs

ORDER = ("scan_initial", "scan_initial_lateral", "scan_final", "scan_final_lateral", "display_final")
HEADER_SIZE_KEYS = {"XRes", "YRes", "XReal", "YReal", "XOffset", "YOffset", "XYUnits", "ZUnits", "Title"}


class GwyError(Exception):
    """A one-line reason the .gwy cannot be made (file and what is wrong)."""


def channel_order(names):
    """ORDER's names that are there, then the others by name."""
    return [n for n in ORDER if n in names] + sorted(n for n in names if n not in ORDER)


def _run_meta(info):
    """run.json's scalar values as Run_KEY: text."""
    return {f"Run_{k}": (json.dumps(v) if isinstance(v, bool) else str(v))
            for k, v in sorted(info.items()) if isinstance(v, (str, int, float, bool))}


def _field(header, values):
    import numpy as np
    from gwyfile.objects import GwyDataField
    return GwyDataField(np.ascontiguousarray(values, dtype=np.float64),
                        xreal=float(header["XReal"]), yreal=float(header["YReal"]),
                        xoff=float(header.get("XOffset", 0)), yoff=float(header.get("YOffset", 0)),
                        si_unit_xy=header.get("XYUnits", "m"), si_unit_z=header.get("ZUnits", "m"))


def write_gwy(run, path):
    """The .gwy file (see the module's contract); the channels' titles in order."""
    from gwyfile.objects import GwyContainer
    try:
        scans = run.scans
    except ValueError as e:   # a GSF file that does not read
        raise GwyError(str(e))
    if not scans:
        raise GwyError(f"{run.dir}: no GSF file (scan_initial.gsf, ...): nothing to write")
    c, run_meta = GwyContainer(), _run_meta(run.info)
    names = channel_order(scans)
    for i, name in enumerate(names):
        header, values = scans[name]
        c[f"/{i}/data"] = _field(header, values)
        c[f"/{i}/data/title"] = name
        meta = {k: str(v) for k, v in header.items() if k not in HEADER_SIZE_KEYS}
        meta.update(run_meta)
        c[f"/{i}/meta"] = GwyContainer(meta, typecodes={k: "s" for k in meta})   # text, even one character long
    try:
        with safefs.atomic_path(path) as f:   # whole or not at all, no link followed
            c.tofile(f)
    except OSError as e:
        raise GwyError(f"{path}: cannot write: {e.strerror}")
    except safefs.Refused as e:
        raise GwyError(str(e))
    return names
