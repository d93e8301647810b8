"""tests/run.sh, the suite's driver (./afm test): --fast runs the unit
label alone; the closing line counts what ctest ran; a failure exits 2
("afm: tests failed"); a bad option is one line naming it, exit 2; --help
is docs/help/test.txt. Run here on a ctest folder of three stand-in tests
(AFM_BUILD), so it needs no build."""
import os
import subprocess

TESTS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUN = os.path.join(TESTS, "run.sh")
HELP = os.path.join(os.path.dirname(TESTS), "docs", "help", "test.txt")

STAND_INS = """add_test(unit_ok "/bin/true")
set_tests_properties(unit_ok PROPERTIES LABELS "unit")
add_test(unit_bad "/bin/false")
set_tests_properties(unit_bad PROPERTIES LABELS "unit")
add_test(e2e_never "/bin/false")
set_tests_properties(e2e_never PROPERTIES LABELS "e2e")
"""


def run(*args, build=None):
    env = dict(os.environ)
    env.pop("AFM_BUILD", None)
    if build:
        env["AFM_BUILD"] = build
    return subprocess.run([RUN, *args], capture_output=True, text=True, timeout=120, env=env)


def test_fast_runs_the_unit_label_and_ends_with_the_count(tmp_path):
    build = tmp_path / "main"
    build.mkdir()
    (build / "CTestTestfile.cmake").write_text(STAND_INS)
    p = run("--fast", build=str(build))
    assert p.returncode == 2, p.stderr
    assert p.stdout.splitlines()[-1] == "tests: 1 passed, 1 failed"
    assert "unit_bad" in p.stdout and "e2e_never" not in p.stdout
    assert p.stderr.splitlines()[-1] == "afm: tests failed"
    assert "unit_bad" in (tmp_path / "test-results.txt").read_text(), "the output kept beside the build"


def test_all_passing_exits_0(tmp_path):
    build = tmp_path / "main"
    build.mkdir()
    (build / "CTestTestfile.cmake").write_text(STAND_INS.replace("/bin/false", "/bin/true"))
    p = run("--fast", build=str(build))
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[-1] == "tests: 2 passed, 0 failed"


def test_a_bad_option_is_one_line_naming_it():
    p = run("--fsat")
    assert p.returncode == 2
    assert p.stderr.strip().splitlines() == ["afm: test: unknown option '--fsat' (./afm test [--fast])"]


def test_help_is_the_commands_help_file_and_needs_no_build(tmp_path):
    p = run("--help", build=str(tmp_path / "nothing"))
    assert p.returncode == 0
    with open(HELP) as f:
        assert p.stdout == f.read()


def test_no_build_is_named(tmp_path):
    p = run("--fast", build=str(tmp_path / "nothing"))
    assert p.returncode == 2
    assert p.stderr.strip().splitlines() == [f"afm: test: no build in {tmp_path / 'nothing'} (./afm build first, or ./afm test)"]
