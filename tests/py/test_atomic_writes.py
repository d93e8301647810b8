"""The bench's one atomic writer (analysis/safefs.py: atomic, write_path)
and the writers that go through it (gwy.py, export.py, point.py,
paper/paper_report.py, paper/common.py's figures): a process killed in the
middle of a write leaves the old file whole; a link planted where a writer
writes (its name, the temporary name the writers used before, a folder on
the way) is never followed: the file it points to keeps its bytes. Needs
no build."""
import json
import os
import signal
import subprocess
import sys
import textwrap

import pytest

from analysis import point, safefs
from analysis.paper import paper_report

import test_units

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OLD = b"the old file, whole\n" * 100


def test_a_writer_killed_mid_write_leaves_the_old_file_whole(tmp_path):
    target = tmp_path / "paper.json"
    target.write_bytes(OLD)
    # a child that writes half of a new file, says so, and waits to be killed
    child = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {ROOT!r})
        from analysis import safefs
        with safefs.atomic_path({str(target)!r}) as f:
            f.write(b"new" * 100000)
            f.flush()
            print("half", flush=True)
            time.sleep(60)
            f.write(b"the rest")
        """)
    p = subprocess.Popen([sys.executable, "-c", child], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "half"
        p.send_signal(signal.SIGKILL)
    finally:
        p.wait(timeout=10)
    assert target.read_bytes() == OLD
    left = [n for n in os.listdir(tmp_path) if n != "paper.json"]
    assert len(left) == 1 and left[0].startswith(".paper.json.") and left[0].endswith(".tmp"), left


def test_an_error_mid_write_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "out.gwy"
    target.write_bytes(OLD)
    with pytest.raises(RuntimeError):
        with safefs.atomic_path(str(target)) as f:
            f.write(b"half of it")
            raise RuntimeError("the writer failed")
    assert target.read_bytes() == OLD
    assert os.listdir(tmp_path) == ["out.gwy"]
    safefs.write_path(str(target), "new")
    assert target.read_text() == "new" and os.listdir(tmp_path) == ["out.gwy"]


def plant(folder, name, victim):
    os.symlink(victim, os.path.join(folder, name))


def test_links_planted_where_the_paper_report_writes_are_not_followed(tmp_path):
    out, victim = tmp_path / "paper", tmp_path / "victim"
    out.mkdir()
    victim.write_bytes(OLD)
    results = test_units.paper_results(str(out))
    # the report's own names, and the temporary name it wrote paper.json through before
    for name in ("report.html", "report.md", "paper.json.tmp"):
        plant(out, name, victim)
    paper_report.write(str(out), results, "quick", 1.0)
    assert victim.read_bytes() == OLD
    assert not os.path.islink(out / "report.html") and "Lateral calibration" in (out / "report.html").read_text()
    assert json.loads((out / "paper.json").read_text())["experiments"]["tilted"]
    # an experiment's folder replaced by a link: its figure is refused, not written through it
    os.rename(out / "tilted", tmp_path / "elsewhere")
    plant(out, "tilted", tmp_path / "elsewhere")
    fig = paper_report_figure()
    with pytest.raises(safefs.Refused, match="tilted: refused: a symbolic link"):
        with safefs.atomic(safefs.open_dir(str(out)), "tilted/loops.png", str(out)) as f:
            fig.savefig(f, format="png")


def paper_report_figure():
    from analysis.paper import common
    fig = common.plt().figure(figsize=(2, 2))
    fig.gca().plot([0, 1], [0, 1])
    return fig


def test_links_planted_where_gwy_export_and_point_write_are_not_followed(tmp_path):
    victim = tmp_path / "victim"
    victim.write_bytes(OLD)
    # point.json and its former temporary name
    plant(tmp_path, "point.json", victim)
    plant(tmp_path, "point.json.tmp", victim)
    point._write_json(str(tmp_path / "point.json"), {"id": "p0"})
    assert json.loads((tmp_path / "point.json").read_text()) == {"id": "p0"}
    # a run's .gwy and CSV files, and the .gwy's former temporary name
    from analysis import export, gwy
    import numpy as np
    import pandas as pd

    class Run:
        dir, info = str(tmp_path), {"seed": 1}
        scans = {"scan_initial": ({"XRes": 2, "YRes": 2, "XReal": 1e-6, "YReal": 1e-6}, np.zeros((2, 2)))}
        frames = {"FW_STATE": pd.DataFrame({"utime": [1, 2]})}
    for name in ("run.gwy", "run.gwy.part", "FW_STATE.csv"):
        plant(tmp_path, name, victim)
    assert gwy.write_gwy(Run, str(tmp_path / "run.gwy")) == ["scan_initial"]
    assert export.write_csv(Run, str(tmp_path)) == {"FW_STATE": 2}
    assert victim.read_bytes() == OLD
    assert (tmp_path / "run.gwy").read_bytes().startswith(b"GWYP")
    assert (tmp_path / "FW_STATE.csv").read_text() == "utime\n1\n2\n"
    # a folder where the file should go: refused, named
    (tmp_path / "sub.gwy").mkdir()
    with pytest.raises(gwy.GwyError, match="sub.gwy: refused: a folder stands there"):
        gwy.write_gwy(Run, str(tmp_path / "sub.gwy"))
