#!/usr/bin/env bash
# ./afm bench sim: what the simulator costs and how accurate its knobs are.
# Runs build/main/sim_afm/bench_sim (sim_afm/bench_sim.cpp) and prints its
# tables: cost per simulated second against the number of particles and with
# each effect turned on; for flexible wires, the shape error against an
# N = 256 reference and the cost, N = 4..128. A benchmark: it never fails on
# the numbers.
set -euo pipefail

usage() {
  cat <<'TXT'
usage: ./afm bench sim [particles|effects|wires]
       tools/bench_sim.sh [same]

  particles  cost against the number of particles (1, 100, 10000)
  effects    cost of each effect over a base scene
  wires      flexible wires: shape error and cost against segments N
  (none)     all three tables
  -h, --help this text

Environment: AFM_BUILD (default <repo>/build/main) locates the bench binary
at $AFM_BUILD/sim_afm/bench_sim.
TXT
}

case "${1:-}" in
  -h|--help) usage; exit 0 ;;
  ""|particles|effects|wires) ;;
  *) echo "bench_sim: unknown table '$1'" >&2; usage >&2; exit 2 ;;
esac

top=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${AFM_BUILD:-$top/build/main}
bin="$build/sim_afm/bench_sim"
[ -x "$bin" ] || { echo "bench_sim: $bin not built (run ./afm build)" >&2; exit 2; }
exec "$bin" "$@"
