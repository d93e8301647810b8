#!/usr/bin/env bash
# The test suite's driver: ./afm test's body (./afm installs what is missing
# and builds before it calls this). Usage: tests/run.sh [--fast]
#   (no option)  every tier: ctest in build/main (the unit and e2e labels),
#                the firmware on its other targets (tools/fw_targets.sh: the
#                Cortex-M4 under QEMU, ASan/UBSan), the fuzz smoke run
#                (tools/fuzz.sh --smoke)
#   --fast       the unit tier alone (ctest -L unit: the firmware's, the
#                simulator's and the host's unit tests, the calculator's,
#                pytest's on the analysis package): no scene runs
# The tiers, labels and time limits: tests/timeouts.cmake, tests/timeouts.json.
# The build tested is build/main, or the one AFM_BUILD names (as for the
# analysis package). Everything printed goes to test-results.txt beside it
# (build/test-results.txt) too. The last line is
# "tests: N passed, M failed" over every ctest run above; the exit status is
# 0 when everything passed, else 2 ("afm: tests failed"), 2 on bad usage.
set -euo pipefail
top=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${AFM_BUILD:-$top/build/main}
jobs=${AFM_JOBS:-$(nproc 2>/dev/null || echo 2)}

die() { echo "afm: $*" >&2; exit 2; }

fast=0
for a in "$@"; do
  case "$a" in
    --fast) fast=1 ;;
    -h|--help) cat "$top/docs/help/test.txt"; exit 0 ;;
    *) die "test: unknown option '$a' (./afm test [--fast])" ;;
  esac
done
[ -f "$build/CTestTestfile.cmake" ] || die "test: no build in $build (./afm build first, or ./afm test)"

results="$(dirname "$build")/test-results.txt"
: > "$results"
status=0
# One step: its heading on stderr, its output also into the results file.
step() {
  local what=$1; shift
  echo "afm: $what" >&2
  set +e
  "$@" 2>&1 | tee -a "$results"
  local rc=${PIPESTATUS[0]}
  set -e
  [ "$rc" = 0 ] || status=1
}

if [ "$fast" = 1 ]; then
  step "running the unit tier (ctest -L unit, $build)" ctest --test-dir "$build" --output-on-failure -j "$jobs" -L unit
else
  step "running ctest ($build)" ctest --test-dir "$build" --output-on-failure -j "$jobs"
  step "firmware on the Cortex-M4 (QEMU) and under ASan/UBSan" "$top/tools/fw_targets.sh"
  step "a short fuzz run (libFuzzer, ASan/UBSan; every committed crash input replayed)" "$top/tools/fuzz.sh" --smoke
fi

# One closing line over every ctest run above.
awk '/tests passed, [0-9]+ tests? failed out of/ { for (i = 1; i <= NF; i++) if ($i == "out") { total += $(i + 2); failed += $(i - 3) } }
     END { printf "tests: %d passed, %d failed\n", total - failed, failed }' "$results"
[ "$status" = 0 ] || die "tests failed"
