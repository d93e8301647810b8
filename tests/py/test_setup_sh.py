"""tools/setup.sh on a machine where dpkg has never heard of the bench's
packages (a fresh Debian): dpkg-query then exits 1, having printed the
packages it knows; setup must go on to install the rest, not end silently
under pipefail (tools/fresh_root.sh found it: ./afm test exited 1 with no
word). Run with stand-ins for dpkg-query, apt-get and id on PATH, so it
installs nothing: the stand-in apt-get records its arguments and fails, and
setup must say which step failed."""
import os
import subprocess

TOOLS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "tools")


def stand_in(folder, name, body):
    path = folder / name
    path.write_text("#!/bin/sh\n" + body + "\n")
    path.chmod(0o755)


def test_packages_unknown_to_dpkg_are_installed_not_a_silent_exit(tmp_path):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    calls = tmp_path / "apt-calls"
    # dpkg-query as on a fresh root: the one package it knows, then exit 1 for the rest
    stand_in(bin_dir, "dpkg-query", "echo 'install ok installed ca-certificates'\necho 'dpkg-query: no packages found matching cmake' >&2\nexit 1")
    stand_in(bin_dir, "apt-get", f"echo \"$*\" >> {calls}\nexit 1")
    stand_in(bin_dir, "id", "echo 0")
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}")
    p = subprocess.run([os.path.join(TOOLS, "setup.sh"), "--quiet"], capture_output=True, text=True, timeout=60, env=env)
    assert p.returncode == 1, p.stderr
    assert "setup: apt-get update" in p.stderr, f"setup ended before its package step: {p.stderr!r}"
    assert "setup: error: apt-get update failed" in p.stderr, p.stderr
    assert calls.read_text().split("\n")[0].startswith("update"), calls.read_text()
