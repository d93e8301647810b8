"""./afm paper's tolerance file (analysis/paper/tolerances.yaml) and its
judge, without a build: every key a row of the experiments names has an
entry and every entry is named by a row; each entry is whole; a row takes
its tolerance from its entry alone (the code cannot pass one); a row measured
from a run whose own verdict failed is never ok and says so; a row whose
truth is its model's own formula is labelled a unit check."""
import glob
import os
import re

import pytest

from analysis.paper import cli, common

PAPER = os.path.join(os.path.dirname(common.__file__))
KEY = re.compile(r'"((?:%s)\.(?!yaml"|png"|json"|gsf")[a-z0-9_]+)"' % "|".join(e.NAME for e in cli.EXPERIMENTS))


def keys_in_code():
    """Every "EXPERIMENT.name" string in the experiments' code: the keys rows name."""
    found = set()
    for path in glob.glob(os.path.join(PAPER, "*.py")):
        with open(path) as f:
            found |= set(KEY.findall(f.read()))
    return found


def test_every_key_a_row_names_has_an_entry_and_no_entry_is_unused():
    entries = set(common.tolerances())
    named = keys_in_code()
    assert named - entries == set(), "rows name keys tolerances.yaml lacks"
    assert entries - named == set(), "tolerances.yaml has entries no row names"


def test_every_entry_says_what_it_compares_and_why():
    for key, e in common.tolerances().items():
        for field in ("quantity", "model", "truth", "why"):
            assert str(e[field]).strip(), f"{key}: {field}"
        assert e["kind"] in common.KINDS, key


def test_a_broken_entry_is_named(tmp_path):
    p = tmp_path / "t.yaml"
    p.write_text("rod.x: {quantity: q, kind: figure, model: m, truth: t, tolerance: -1, unit: nm, why: w}\n")
    with pytest.raises(common.PaperError, match="rod.x: tolerance -1"):
        common.read_tolerances(str(p))
    p.write_text("rod.x: {quantity: q, kind: guess, model: m, truth: t, tolerance: 1, unit: nm, why: w}\n")
    with pytest.raises(common.PaperError, match="kind 'guess'"):
        common.read_tolerances(str(p))
    p.write_text("rod.x: {quantity: q, kind: figure, model: m, tolerance: 1, unit: nm, why: w}\n")
    with pytest.raises(common.PaperError, match="missing truth"):
        common.read_tolerances(str(p))


def test_the_code_cannot_pass_a_tolerance():
    with pytest.raises(TypeError):
        common.Row("x", "nN", key="rod.end_push", bench=1.0, truth=1.0, tolerance=0.5)


def test_a_figure_outside_its_tolerance_is_judged_so():
    # rod.end_push: 10 % of the truth
    assert not common.Row("x", "nN", key="rod.end_push", bench=11.1, truth=10.0).judge().ok
    assert common.Row("x", "nN", key="rod.end_push", bench=10.9, truth=10.0).judge().ok
    assert not common.Row("x", "nm", key="lines.angle_vs_270", bench=3.5).judge().ok          # a limit, 3 nm
    assert not common.Row("x", "nN", key="rod.end_push", bench=None, truth=1.0).judge().ok    # nothing measured
    assert not common.Row("x", "nN", key="rod.end_push", bench=1.0, truth=0.0).judge().ok     # relative to 0
    with pytest.raises(common.PaperError, match="unit 'nN'"):
        common.Row("x", "nm", key="rod.end_push", bench=1.0, truth=1.0).judge()
    with pytest.raises(common.PaperError, match="no entry 'rod.nonsense'"):
        common.Row("x", "nm", key="rod.nonsense", bench=1.0).judge()


def test_scaled_and_sized_tolerances():
    r = common.Row("x", "nm", key="rod.model_static_point", model=10.0, truth=0.0, scale=1300.0).judge()
    assert r.tolerance == pytest.approx(26.0) and r.ok
    assert common.Row("x", "nm", key="flex.bow", bench=1.0, truth=0.0, scale=3.0).judge().tolerance == 10.0   # at_least
    assert common.Row("x", "s", key="pattern.time", bench=30.0).judge("reduced").tolerance == pytest.approx(33.9)
    assert common.Row("x", "s", key="pattern.time", bench=30.0).judge("full").tolerance == pytest.approx(432.1)
    with pytest.raises(common.PaperError, match="per f L"):
        common.Row("x", "nN", key="rod.model_least_push", model=1.0, truth=1.0).judge()


def test_a_formula_against_itself_says_unit_check_and_a_model_row_model_error():
    r = common.Row("x", "", key="tilted.mu", model=0.0865, truth=0.0865).judge()
    assert (r.kind, r.verdict) == ("unit check", "unit check ok")
    r = common.Row("x", "nN", key="rod.model_least_push", model=11.2, truth=11.4, scale=26.0).judge()
    assert (r.kind, r.verdict) == ("model error", "ok")


def test_a_row_of_a_run_that_failed_its_verdict_is_never_ok():
    failed = {"ride_20_high": ["fidelity"]}
    r = common.Row("x", "", key="squeeze.ride_high_pushed", bench=1.0, truth=1.0, runs=("ride_20_high",))
    cli.mark_failed_runs(r, failed)
    r.judge()
    assert not r.ok and r.verdict == "run failed: fidelity (ride_20_high)" and r.error == 0
    other = common.Row("x", "", key="squeeze.ride_high_pushed", bench=1.0, truth=1.0, runs=("ride_35_high",))
    cli.mark_failed_runs(other, failed)
    assert other.judge().ok
    every = common.Row("x", "nm", key="lines.angle_vs_270", bench=1.0)   # no runs named: all the experiment's
    cli.mark_failed_runs(every, failed)
    assert not every.judge().ok
