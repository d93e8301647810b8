"""What the reports show of a value (analysis/units.py): each field in its
physical unit from its name, at most 4 significant digits, yes/no for a
boolean, nested tables whole; and raw_values, which the reports' tests hold
every page to, finds what the pages showed before (issue 50, item 2:
`True`, `mu_ppm 86500`, `scan_angle_mdeg 270000`, 1.8483727512146702, the
haptic JSON cut at `"passive": tr`). Needs no build."""
import json
import os

from analysis import sweep_report, units
from analysis.paper import common, paper_report


def test_fields_read_in_their_units():
    card = {"mu_ppm": 86500, "scan_angle_mdeg": 270000, "full_scale_pn": 106800, "deflection_pm_per_v": 89000,
            "twist_urad_per_v": 1334.9996879696846, "wire_friction_pn_per_um": 20000, "adhesion_pn": 1000,
            "samples_per_block": 20, "gain_N_per_nN": 0.018000000000000006, "check_us": 1336.574, "max_rss_kb": 43180}
    shown = dict(units.field(k, v) for k, v in card.items())
    assert shown == {"mu": "0.0865", "scan angle": "270 deg", "full scale": "106.8 nN", "deflection": "89 nm/V",
                     "twist": "1335 µrad/V", "wire friction": "20 nN/µm", "adhesion": "1000 pN",
                     "samples per block": "20", "gain": "0.018 N/nN", "check": "1337 µs", "max rss": "43.18 MB"}
    assert units.split("force_nN_x") == ("force x", "nN")


def test_numbers_have_at_most_four_significant_digits():
    assert units.number(1.8483727512146702) == "1.848"
    assert units.number(9.99996) == "10"
    assert units.number(12345.6) == "12350"
    assert units.number(2.842e-14) == "2.842×10⁻¹⁴"
    assert units.number(0.061836, sign=True) == "+0.06184"
    assert units.number(18738) == "18738"   # a count, exactly
    assert units.show(True) == "yes" and units.show(None) == "none"
    assert units.show(0.000375, "nN", sign=True, like=0.0185) == "+0.000375 nN"   # a bias in its RMS's unit
    # the paper's notes: values in one unit, said once (the lines' x, before: 1006.5, 1512.5, 2015.8)
    assert units.listed([1006.5, 1512.5, 2015.8], "nm") == "1006, 1512, 2016 nm"
    assert units.listed([0.4, 12.25], "nm") == "0.4, 12.25 nm" and units.listed([13, 25, 50]) == "13, 25, 50"


def test_nested_tables_are_whole():
    haptic = {"hand": {"mass_kg": 0.15}, "passive": True, "observed_energy_J": 0.021105790613193506,
              "rejected": {"by_reason": {"seq_past": 0}}, "contacts_felt": [], "z_axis": None}
    page = units.html_table({"haptic": haptic})
    text = units.page_text(page)
    for part in ("mass", "0.15 kg", "passive", "yes", "0.02111 J", "seq past", "contacts felt", "none"):
        assert part in text, part
    assert units.raw_values(text) == []


def test_raw_values_finds_what_the_pages_showed():
    before = ('mu_ppm 86500 scan_angle_mdeg 270000 pass True 1.8483727512146702 '
              '{"passive": tr 9.25e-08 twist_urad_per_v 1334.9996879696846')
    found = units.raw_values(before)
    for raw in ("True", "1.8483727512146702", "9.25e-08", "mu_ppm", "scan_angle_mdeg", "1334.9996879696846"):
        assert raw in found, raw
    assert units.raw_values("0.07 0.06996 10.68 nN/V 127.0.0.1 2026-11-28T09:48:23 adc_bits=12") == []


def sweep_points():
    """Three points of a sweep as sweep.json keeps them: one repeat each."""
    pts = []
    for i, bits in enumerate((10, 12, 14)):
        errors = {"force_rms_pN": 539.0123 - 10 * i, "force_worst_pN": 2320.4567, "apex_rms_nm": 0.105123 / (i + 1),
                  "apex_worst_nm": 0.5, "objects_worst_nm": 1.23456, "objects_final_nm": 0.9, "display_max_nm": 1.4749}
        costs = {"wall_s_per_sim_s": 3.93123 - i * 0.3, "cpu_s_per_sim_s": 2.3191 + i * 0.4, "fw_instr_per_sample": 520.44,
                 "fw_text_bytes": 33061, "renderer_ms_per_frame": 2.2113, "log_bytes": 8032343}
        pts.append({"id": f"p{i}", "label": f"adc_bits={bits}", "status": "ok", "settings": {"firmware.adc_bits": bits},
                    "errors": errors, "costs": costs, "runs": [{"errors": errors, "costs": costs}],
                    "run_dir": f"/tmp/sweep/points/{i}/run"})
    return pts


def test_the_sweep_page_shows_no_raw_value(tmp_path):
    points, knobs = sweep_points(), [("firmware.adc_bits", [10, 12, 14])]
    effects = sweep_report.knob_effects(points, knobs)
    meta = {"scene_name": "short-push", "scene": "scenes/short.yaml", "ok": 3, "failed": 0, "repeat": 1, "build_id": "abc",
            "engine": "local"}
    sweep_report.write_html(str(tmp_path), meta, points, knobs, [], effects, sweep_report.best_buy(effects))
    text = units.page_text((tmp_path / "report.html").read_text())
    assert units.raw_values(text) == []
    assert "539" in text and "0.1051" in text


def paper_results(out):
    """One experiment as ./afm paper hands it to the report, its figure saved by common.save."""
    rows = [common.Row("slope of the glass phi", "deg", paper=9.0, bench=9.000000092, truth=9.0),
            common.Row("lines at scan angle 0 against 270", "nm", bench=2.842e-14),
            common.Row("uphill slope r_u", "", paper=0.07, bench=0.06996231222034412, truth=0.06996555973646466)]
    for r, (tol, rel) in zip(rows, ((0.1, False), (3.0, False), (0.05, True))):
        r.tolerance, r.relative = tol, rel
        r.error = None if r.truth is None else (r.bench - r.truth) / (r.truth if rel else 1)
    os.makedirs(os.path.join(out, "tilted"), exist_ok=True)
    fig = common.plt().figure(figsize=(4, 3))
    fig.gca().plot([0, 1], [0, 1])
    name = common.save(fig, os.path.join(out, "tilted"), "loops.png")
    res = common.Result(rows=rows, figures=[("Friction loops", name)], notes=["fitted over 5 set points"])

    class Exp:
        TITLE, FIGURES, __doc__ = "Lateral calibration on tilted glass", "figs. 5-6", "Friction loops on tilted glass."
    return {"tilted": (Exp, res, 11.2)}


def test_the_paper_page_shows_no_raw_value_and_its_title_whole(tmp_path):
    paper_report.write(str(tmp_path), paper_results(str(tmp_path)), "quick", 246.3)
    page = (tmp_path / "report.html").read_text()
    text = units.page_text(page)
    assert units.raw_values(text) == []
    assert "‘Videolized’ AFM for interactive nanomanipulation" in text and "\"'Videolized'" not in text
    assert "+9.2×10⁻⁸ deg" in text and "2.842×10⁻¹⁴" in text
    assert 'href="tilted/loops.svg"' in page and (tmp_path / "tilted" / "loops.svg").exists()
    assert json.loads((tmp_path / "paper.json").read_text())["experiments"]["tilted"]["title"]
