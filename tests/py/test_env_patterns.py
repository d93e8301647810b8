"""The pattern generator and the task set (analysis/env/patterns.py): a
task is the same scene for the same seed and another for another seed;
its sites are on the grid at the spacing, its particles inside the field,
apart and off the sites; a field too small is refused naming the
parameter; the task set's names are unique and each task generates. And
the operator's env and push lines, read by one parser (live.detail_fields)."""
import math

import pytest

from analysis.env import patterns


def test_same_seed_same_scene():
    a = patterns.generate(n=10, seed=3)
    assert a == patterns.generate(n=10, seed=3)
    assert a["objects"]["particles"] != patterns.generate(n=10, seed=4)["objects"]["particles"]


def test_sites_and_particles():
    s = patterns.generate(field_nm=6000, n=12, spacing_nm=320, mean_travel_nm=1000, seed=2, spares=3)
    sites = s["objects"]["targets"]
    parts = [(p["x_nm"], p["y_nm"]) for p in s["objects"]["particles"]]
    assert len(sites) == 12 and len(parts) == 15
    assert min(math.dist(a, b) for i, a in enumerate(sites) for b in sites[i + 1:]) == pytest.approx(320)
    half = 3000 - patterns.MARGIN_NM
    assert all(abs(x) <= half and abs(y) <= half for x, y in parts)
    assert min(math.dist(a, b) for i, a in enumerate(parts) for b in parts[i + 1:]) >= 2 * patterns.RADIUS_NM + 150
    assert min(math.dist(p, q) for p in parts for q in sites) >= patterns.SITE_KEEPOUT_NM
    assert s["operator"]["mode"] == "env"


def test_refusals_name_the_parameter():
    with pytest.raises(ValueError, match="field_nm"):
        patterns.generate(field_nm=1000, n=40, seed=1)
    with pytest.raises(ValueError, match="error_level"):
        patterns.generate(error_level=7)
    with pytest.raises(KeyError, match="p10-e0"):
        patterns.task("nope")


def test_task_set():
    names = [t["name"] for t in patterns.TASKS]
    assert len(names) == len(set(names))
    for t in patterns.TASKS:
        p = dict(t)
        name = p.pop("name")
        assert len(patterns.generate(name=name, **p)["objects"]["targets"]) == t["n"]


def test_the_operators_ready_and_push_lines():
    from analysis.env import session
    from analysis.view import live
    assert session.parse_ready("env: ready 7 seq=12 ok=1 drift_x_nm=0.5 why=refused: off the field") == {
        "k": 7, "seq": 12, "ok": 1, "drift_x_nm": 0.5, "why": "refused: off the field"}
    assert live.push_news("push: end id=3 x_nm=12.5 placed=1 note=odd why=lost it") == {
        "phase": "end", "id": 3, "x_nm": 12.5, "placed": 1, "note": "odd", "why": "lost it"}
    assert live.push_news("push:") == {"phase": ""}
