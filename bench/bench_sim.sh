#!/usr/bin/env bash
# ./afm bench sim: what the simulator costs and how accurate its knobs are.
# Runs build/main/bench/host/bench_sim (bench/host/bench_sim.cpp) and prints its
# tables: cost per simulated second against the number of particles and with
# each effect turned on; a 512 px scan without and with tip_convolution
# against its 3x goal; pushed wires against issue 15's goals (a rigid rod
# with uniform friction and with a trench under part of it, a flexible
# chain of N = 32; us per sample, per sample in contact, the goal); for flexible
# wires, the shape error against an N = 256 reference and the cost,
# N = 4..1024, per sample and per sample per segment, against the goal that
# the cost is linear in N. A benchmark: it never fails on the numbers.
set -euo pipefail

usage() {
  cat <<'TXT'
usage: ./afm bench sim [particles|effects|imaging|wires]
       bench/bench_sim.sh [same]

  particles  cost against the number of particles (1, 100, 10000)
  effects    cost of each effect over a base scene, then of a scan as served
             (plain, + piezo_hysteresis, + scan_artefacts)
  imaging    a 512 px scan of scenes/imaging.yaml's field (rough glass, and a
             measured map) without and with tip_convolution, against the
             goal: with it at most 3x
  wires      pushed wires against issue 15's goals (rigid, rigid with a
             trench, flexible N = 32), then flexible wires' shape error and
             cost against segments N = 4..1024 (goal: linear in N)
  (none)     all the tables
  -h, --help this text

Environment: AFM_BUILD (default <repo>/build/main) locates the bench binary
at $AFM_BUILD/bench/host/bench_sim.
TXT
}

case "${1:-}" in
  -h|--help) usage; exit 0 ;;
  ""|particles|effects|imaging|wires) ;;
  *) echo "bench_sim: unknown table '$1'" >&2; usage >&2; exit 2 ;;
esac

top=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${AFM_BUILD:-$top/build/main}
bin="$build/bench/host/bench_sim"
[ -x "$bin" ] || { echo "bench_sim: $bin not built (run ./afm build)" >&2; exit 2; }
exec "$bin" "$@"
