"""A sweep file's knob values reach no output raw (issue 46, item 6 for
sweeps): sweep.json, sweep.csv, the table on stdout, report.html and the
failure lines show every knob's name and value, every point's label and a
failure's words through the one escaper (analysis/text.py); numbers stay
numbers. No run: the points are made up."""
import csv
import json
import re

from analysis import knobs as K
from analysis import sweep, sweep_report

# every C0 control but tab and newline, DEL and the C1 controls: what a terminal acts on
CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f]")
EVIL = "local\x1b]52;c;cm0gLXJmIH4=\x07\x1b[2J\x9b"


def made_up_points():
    knobs = [("outputs.update_mode", [EVIL, "full"]), ("firmware.adc_bits", [12])]
    points = []
    for i, settings in enumerate(K.grid(knobs)):
        p = {"id": f"p{i}", "settings": settings, "label": K.label(settings), "dir": f"/x/p{i}", "run_dir": f"/x/p{i}/run",
             "worker_uid": 1879048193 + i}
        if i == 0:
            p.update(status="failed", failure={"exit_code": 1, "error": f"bad value {EVIL!s}",
                                               "log_tail": f"line one\nline {EVIL}\n"})
        else:
            p.update(status="ok", errors={"force_rms_pN": 1.0}, costs={"cpu_s_per_sim_s": 2.0})
        points.append(p)
    return knobs, points


def test_shown_points_escape_names_values_labels_and_failures_and_keep_numbers():
    knobs, points = sweep.shown_points(*made_up_points())
    assert knobs[0][1][0] == "local\\x1B]52;c;cm0gLXJmIH4=\\x07\\x1B[2J\\xC2\\x9B"
    assert knobs[1] == ("firmware.adc_bits", [12])
    bad, ok = points
    assert bad["settings"]["outputs.update_mode"] == knobs[0][1][0]
    assert bad["settings"]["firmware.adc_bits"] == 12
    assert "\\x1B" in bad["label"] and not CONTROL.search(bad["label"])
    assert bad["failure"]["exit_code"] == 1
    assert bad["failure"]["log_tail"].split("\n")[1] == "line " + knobs[0][1][0]   # its lines kept, each escaped
    assert ok["label"] == "update_mode=full adc_bits=12"


def test_no_output_of_the_sweep_holds_a_control_character(tmp_path, capsys):
    knobs, points = sweep.shown_points(*made_up_points())
    meta = {"scene": "s.yaml", "scene_name": "s", "knobs": knobs, "repeat": 1, "build_id": "b", "engine": "e",
            "points_wall_s": 1.0, "users": None, "ok": 1, "failed": 1}
    sweep_report.write_csv_json(str(tmp_path), points, [k for k, _ in knobs], meta)
    table = sweep_report.table(points)
    effects = sweep_report.knob_effects(points, knobs)
    sweep_report.write_html(str(tmp_path), meta, points, knobs, [], effects, sweep_report.best_buy(effects))
    texts = {"table": table}
    for name in ("sweep.json", "sweep.csv", "report.html"):
        texts[name] = (tmp_path / name).read_text()
    with open(tmp_path / "sweep.json") as f:   # JSON's \u001b escapes, once read back, must not be controls either
        texts["sweep.json read"] = json.dumps(json.load(f), ensure_ascii=False)
    with open(tmp_path / "sweep.csv", newline="") as f:
        texts["sweep.csv read"] = " ".join(" ".join(r.values()) for r in csv.DictReader(f))
    for name, text in texts.items():
        found = CONTROL.search(text)
        assert found is None, f"{name}: {found.group(0)!r} at {found.start()}"
        assert "\\x1B]52" in text, name


def test_the_csv_has_each_points_verdict_from_its_run_json(tmp_path):
    """Issue 50, item 8: sweep.csv had no verdict column; it says run.json's
    verdict (its one owner) in words: pass, or fail naming the checks."""
    knobs, points = made_up_points()
    points[1]["verdict"] = {"pass": False, "failed": [{"check": "fidelity", "detail": "x"}], "expected": [], "met": []}
    points.append(dict(points[1], id="p2", verdict={"pass": True, "failed": [], "expected": [], "met": []}))
    sweep_report.write_csv_json(str(tmp_path), points, [k for k, _ in knobs], {})
    with open(tmp_path / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["verdict"] for r in rows] == ["", "fail: fidelity", "pass"]
