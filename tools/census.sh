#!/usr/bin/env bash
# The functions longer than N lines (default 80), longest first, one a line:
# lines, file, name. C and C++ are read with Universal Ctags (Debian's
# universal-ctags: a function's line to its end line); Python with its own
# ast module (the venv's python, else python3: end_lineno - lineno + 1, a
# method named Class.method, a nested function outer.inner). The folders
# read by default are all of the checkout's code: the firmware, the board,
# the simulator, the host side, common/, lcmtypes/, the analysis package,
# the benchmarks, the tests, the fuzz harnesses and their seed maker, the
# run's wrappers (run/), the fault injectors (faults/) and tools/. The
# project's rule (issue 45) is that it finds nothing.
# Usage: tools/census.sh [N] [FOLDER...]; exit 0 (found or not), 2 when a
# tool is missing or a Python file does not parse (named, with its line).
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-80}; [ $# -gt 0 ] && shift
[[ $n =~ ^[0-9]+$ ]] || { echo "census: N must be a whole number of lines, got '$n'" >&2; exit 2; }
dirs=("$@")
[ ${#dirs[@]} -gt 0 ] || dirs=(firmware board sim_afm host common scene bus lcmtypes analysis bench tests fuzz run faults tools)
command -v ctags >/dev/null || { echo "census: needs ctags (apt-get install universal-ctags)" >&2; exit 2; }
py=.venv/bin/python; [ -x "$py" ] || py=python3

c_functions() {
  ctags -R --languages=C,C++ --kinds-C++=f --kinds-C=f --fields=+ne -f - "${dirs[@]}" 2>/dev/null |
    awk -F'\t' -v n="$n" '{ s = ""; e = ""
      for (i = 4; i <= NF; i++) { if ($i ~ /^line:/) s = substr($i, 6); if ($i ~ /^end:/) e = substr($i, 5) }
      if (s != "" && e != "" && e - s + 1 > n) printf "%4d %s %s\n", e - s + 1, $2, $1 }'
}

py_functions() {
  find "${dirs[@]}" -name '*.py' -not -path '*/__pycache__/*' -print0 | sort -z | xargs -0 -r "$py" -c '
import ast, sys
n = int(sys.argv[1])

def visit(node, path, prefix):
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
            lines = child.end_lineno - child.lineno + 1
            if lines > n:
                print(f"{lines:4d} {path} {prefix}{child.name}")
            visit(child, path, f"{prefix}{child.name}.")
        elif isinstance(child, ast.ClassDef):
            visit(child, path, f"{prefix}{child.name}.")
        else:
            visit(child, path, prefix)

for path in sys.argv[2:]:
    try:
        with open(path, "rb") as f:
            tree = ast.parse(f.read(), path)
    except SyntaxError as e:
        print(f"census: {path}:{e.lineno}: Python that does not parse ({e.msg})", file=sys.stderr)
        sys.exit(2)
    visit(tree, path, "")
' "$n"
}

{ c_functions; py_functions; } | sort -rn
