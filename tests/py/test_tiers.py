"""The tests' tiers and time limits, read from the build's own test list
(ctest --show-only=json-v1 in AFM_BUILD; skipped where no build is
configured): every test has one tier, unit or e2e, and a time limit; slow
marks only e2e tests; every test file of tests/e2e and tests/py is
registered; and no e2e file's own timeout (a literal `timeout=` or
`timeout_s=` in its source) exceeds its budget, the ctest limit less the
margin (tests/timeouts.json), so that ctest never kills a test that would
have said what it waited for."""
import ast
import glob
import json
import os
import subprocess

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = os.path.dirname(HERE)
BUILD = os.environ.get("AFM_BUILD") or os.path.join(os.path.dirname(TESTS), "build", "main")


def ctest_list():
    if not os.path.exists(os.path.join(BUILD, "CTestTestfile.cmake")):
        pytest.skip(f"no configured build in {BUILD} (./afm build)")
    p = subprocess.run(["ctest", "--show-only=json-v1"], cwd=BUILD, capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    out = {}
    for t in json.loads(p.stdout)["tests"]:
        props = {x["name"]: x["value"] for x in t.get("properties", [])}
        env = dict(e.split("=", 1) for e in props.get("ENVIRONMENT", []))
        out[t["name"]] = {"labels": props.get("LABELS", []), "timeout": props.get("TIMEOUT"),
                          "budget": env.get("AFM_TEST_BUDGET_S"), "command": t.get("command", [])}
    return out


@pytest.fixture(scope="module")
def tests():
    return ctest_list()


def test_every_test_has_one_tier_and_a_limit(tests):
    assert len(tests) > 50
    for name, t in tests.items():
        tiers = [l for l in t["labels"] if l in ("unit", "e2e")]
        assert len(tiers) == 1, f"{name}: labels {t['labels']}"
        assert set(t["labels"]) <= {"unit", "e2e", "slow"}, f"{name}: labels {t['labels']}"
        assert "slow" not in t["labels"] or tiers == ["e2e"], f"{name}: slow is an e2e label"
        assert (tiers == ["e2e"]) == name.startswith("e2e_"), name
        assert t["timeout"] and t["timeout"] > 0, f"{name}: no TIMEOUT"
        assert t["budget"] and 0 < int(t["budget"]) < t["timeout"], f"{name}: AFM_TEST_BUDGET_S {t['budget']}"


def test_the_fast_tier_runs_no_scene(tests):
    # the unit tier: nothing that starts the launcher, and some of each kind
    unit = {n: t for n, t in tests.items() if "unit" in t["labels"]}
    for prefix in ("fw_", "host_", "sim_", "py_test_", "afm_calc_cli"):
        assert any(n.startswith(prefix) for n in unit), prefix
    for name, t in unit.items():
        assert not any("afm_launch" in c or "/e2e/" in c for c in t["command"]), name


def test_every_test_file_is_registered(tests):
    for path in glob.glob(os.path.join(TESTS, "e2e", "test_*.py")):
        name = "e2e_" + os.path.basename(path)[:-3]
        assert name in tests, f"{path} is not a ctest test ({name})"
    for path in glob.glob(os.path.join(HERE, "test_*.py")):
        name = "py_" + os.path.basename(path)[:-3]
        assert name in tests, f"{path} is not a ctest test ({name})"


def literal_timeouts(path):
    """(line, seconds) of every `timeout=N` / `timeout_s=N` in a file: a
    call's keyword or a parameter's default."""
    tree = ast.parse(open(path).read(), path)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg in ("timeout", "timeout_s"):
            value = node.value
        elif isinstance(node, ast.arguments):
            named = node.args[len(node.args) - len(node.defaults):] if node.defaults else []
            pairs = list(zip(named, node.defaults)) + list(zip(node.kwonlyargs, node.kw_defaults))
            for arg, default in pairs:
                if arg.arg in ("timeout", "timeout_s") and isinstance(default, ast.Constant):
                    out.append((default.lineno, default.value))
            continue
        else:
            continue
        if isinstance(value, ast.Constant) and isinstance(value.value, (int, float)):
            out.append((value.lineno, value.value))
    return out


def test_literal_timeouts_are_read_from_source():
    # the reader itself must find what it is looking for
    found = literal_timeouts(os.path.join(TESTS, "e2e", "e2e_support.py"))
    assert any(v == 300 for _, v in found), found


def test_no_e2e_file_waits_past_its_budget(tests):
    for path in sorted(glob.glob(os.path.join(TESTS, "e2e", "test_*.py"))):
        name = "e2e_" + os.path.basename(path)[:-3]
        budget = int(tests[name]["budget"])
        for line, seconds in literal_timeouts(path):
            assert seconds <= budget, f"{path}:{line}: timeout {seconds} s exceeds the budget {budget} s of {name} " \
                                      f"(tests/timeouts.json)"
