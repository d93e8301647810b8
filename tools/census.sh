#!/usr/bin/env bash
# The functions longer than N lines (default 80) in the host side, the
# simulator, common/ and the benchmarks, longest first: lines, file, name.
# Uses Universal Ctags (Debian's universal-ctags); the README's rule is that
# none exceeds 80 lines unless its parts have no names.
# Usage: tools/census.sh [N] [FOLDER...]
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-80}; [ $# -gt 0 ] && shift
dirs=("$@"); [ ${#dirs[@]} -gt 0 ] || dirs=(host_bridge sim_afm common bench firmware)
command -v ctags >/dev/null || { echo "census: needs ctags (apt-get install universal-ctags)" >&2; exit 2; }
ctags -R --languages=C,C++ --kinds-C++=f --kinds-C=f --fields=+ne -f - "${dirs[@]}" 2>/dev/null |
  awk -F'\t' -v n="$n" '{ s = ""; e = ""
    for (i = 4; i <= NF; i++) { if ($i ~ /^line:/) s = substr($i, 6); if ($i ~ /^end:/) e = substr($i, 5) }
    if (s != "" && e != "" && e - s + 1 > n) printf "%4d %s %s\n", e - s + 1, $2, $1 }' | sort -rn
