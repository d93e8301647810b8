#!/usr/bin/env bash
# ./afm bench render: the display's local update against a full redraw.
set -euo pipefail
build=${AFM_BUILD:-$(cd "$(dirname "$0")/.." && pwd)/build/main}
case "${1:-}" in -h|--help) echo "usage: ./afm bench render [FRAMES]"; exit 0 ;; esac
exe="$build/bench/host/bench_render"
[ -x "$exe" ] || { echo "bench render: $exe missing: run ./afm build" >&2; exit 2; }
exec "$exe" "$@"
