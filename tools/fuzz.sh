#!/usr/bin/env bash
# The libFuzzer harnesses (fuzz/): builds them in build/fuzz (clang, ASan,
# UBSan) and runs them. See usage below.
set -euo pipefail

top=$(cd "$(dirname "$0")/.." && pwd)
all_targets=(scene lcm calc lcmlog bus record)
bdir="$top/build/fuzz"
jobs=${AFM_JOBS:-$(nproc 2>/dev/null || echo 2)}
cc=${AFM_FUZZ_CC:-clang-14}
cxx=${AFM_FUZZ_CXX:-clang++-14}

usage() {
  cat "$top/docs/help/fuzz.txt"; echo   # ./afm's text for the command, then this script's own
  cat <<'TXT'
usage: tools/fuzz.sh [TARGET...] [--seconds N] [--merge]
       tools/fuzz.sh --smoke
       (./afm fuzz [TARGET...] [--seconds N] [--merge])

Fuzzes the bench's parsers with libFuzzer, ASan and UBSan (clang-14; the
harnesses are fuzz/fuzz_TARGET.cpp, built in build/fuzz, configured and
built incrementally first). Targets (default: all of them):
  scene   the scene parser and validator (load_scene), the run's copy of a scene, the card's check
  lcm     every bus message's guarded decoder (Inbox), the card's handlers, ObjectsView
  calc    the lever calculator: ./afm calc|calib|model's arguments and solvers
  lcmlog  the LCM log reader (LogReader, LogTail)
  bus     the bus's gathering of datagrams into messages (BusGather: fragments, their headers' claims, senders)
  record  the launcher's path from the bus to run.json with channel names of any bytes (BusGather, BusRecorder, LogReader, the counts' JSON)

  --seconds N  fuzz each target N seconds (default 60)
  --merge      afterwards, merge what the run found into the committed seed
               corpus fuzz/corpus/TARGET (only inputs with new coverage)
  --smoke      the test suite's run: every target 5 s, then every input in
               fuzz/crashes/TARGET/ (crashes found before, fixed) once
  -h, --help   this text

The committed corpus fuzz/corpus/TARGET is read, never written (but by
--merge); new inputs go to build/fuzz/work/TARGET (kept between runs; the
smoke run starts from the committed corpus alone). A crash, a timeout
(10 s per input), running out of memory (2 GB) or a broken promise of a
harness stops that target's run and leaves its input in
build/fuzz/artifacts/TARGET/; replay it with
  build/fuzz/fuzz/fuzz_TARGET FILE
Fix the cause in the code and add the input to fuzz/crashes/TARGET/.

One line per target: executions, executions per second, libFuzzer's cov
(code edges covered) and ft (features) at the end, new corpus inputs, and
crashes. Exit status: 0 no crash, 1 a crash, 2 bad usage or build failure.
TXT
}

die() { echo "fuzz: $*" >&2; exit 2; }

seconds=60
smoke=0
merge=0
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --seconds)
      [ $# -ge 2 ] || die "--seconds needs a value"
      [[ "$2" =~ ^[1-9][0-9]*$ ]] || die "--seconds $2: not a positive whole number"
      seconds=$2; shift 2 ;;
    --smoke) smoke=1; shift ;;
    --merge) merge=1; shift ;;
    -*) die "unknown option '$1' (see --help)" ;;
    *)
      [[ " ${all_targets[*]} " == *" $1 "* ]] || die "unknown target '$1' (${all_targets[*]})"
      targets+=("$1"); shift ;;
  esac
done
if [ "$smoke" = 1 ]; then
  [ ${#targets[@]} -eq 0 ] && [ "$merge" = 0 ] || die "--smoke takes no targets and no --merge"
  seconds=5
fi
[ ${#targets[@]} -eq 0 ] && targets=("${all_targets[@]}")

# ---- build ------------------------------------------------------------------
command -v "$cc" >/dev/null && command -v "$cxx" >/dev/null || die "$cc / $cxx not found: run ./afm setup"
mkdir -p "$bdir"
if [ ! -f "$bdir/CMakeCache.txt" ]; then
  echo "fuzz: configuring build/fuzz ($cxx, AFM_FUZZ=ON)" >&2
  cmake -S "$top" -B "$bdir" -G Ninja -DAFM_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_COMPILER="$cxx" >"$bdir/configure.log" 2>&1 \
    || { tail -30 "$bdir/configure.log" >&2; die "configure failed (build/fuzz/configure.log)"; }
fi
echo "fuzz: building build/fuzz (-j$jobs)" >&2
cmake --build "$bdir" -j "$jobs" >"$bdir/build.log" 2>&1 \
  || { grep -E "error|FAILED" "$bdir/build.log" | head -30 >&2 || true; die "build failed (build/fuzz/build.log)"; }

# ---- run ----------------------------------------------------------------------
# libFuzzer's options for every run: a hang or a runaway allocation is a
# crash; the targets' own output (the calculator prints) goes nowhere.
common=(-timeout=10 -rss_limit_mb=2048 -close_fd_mask=3 -print_final_stats=1)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
# The harnesses' private folders (a crash leaves its folder behind).
export TMPDIR="$bdir/tmp"
rm -rf "$TMPDIR"
mkdir -p "$TMPDIR"

crashes_total=0
# The last crash's reason in a log: the harness's broken promise, else the sanitizer's summary.
why() {
  local w
  w=$(grep -a '^fuzz: broken promise' "$1" | tail -1 || true)
  [ -n "$w" ] || w=$(grep -a '^SUMMARY' "$1" | tail -1 || true)
  echo "${w:-see the log}"
}
count_files() { find "$1" -maxdepth 1 -type f 2>/dev/null | wc -l; }

fuzz_one() {
  local t=$1 bin="$bdir/fuzz/fuzz_$1" seeds="$top/fuzz/corpus/$1"
  local work art log
  if [ "$smoke" = 1 ]; then work="$bdir/smoke/$t"; rm -rf "$work"; else work="$bdir/work/$t"; fi
  art="$bdir/artifacts/$t"
  log="$bdir/logs/$t.log"
  mkdir -p "$work" "$art" "$(dirname "$log")"
  local before_units before_art rc=0
  before_units=$(count_files "$work")
  before_art=$(find "$art" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
  "$bin" "${common[@]}" -max_total_time="$seconds" -artifact_prefix="$art/" "$work" "$seeds" >"$log" 2>&1 || rc=$?
  local execs eps cov ft units crashes
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  eps=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2 || true)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2 || true)
  units=$(( $(count_files "$work") - before_units ))
  crashes=$(( $(find "$art" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l) - before_art ))
  [ "$rc" != 0 ] && [ "$crashes" = 0 ] && crashes=1
  printf 'fuzz: %-7s %10s execs %7s exec/s  cov %5s  ft %6s  new units %4s  crashes %s\n' \
    "$t" "${execs:-?}" "${eps:-?}" "${cov:-?}" "${ft:-?}" "$units" "$crashes"
  if [ "$crashes" != 0 ]; then
    crashes_total=$((crashes_total + crashes))
    echo "fuzz: $t: see build/fuzz/logs/$t.log; the input is in build/fuzz/artifacts/$t/:"
    grep -a -E '^(==[0-9]+==ERROR|SUMMARY|fuzz: broken promise|artifact_prefix)' "$log" | head -8 | sed 's/^/  /' || true
  fi
  if [ "$merge" = 1 ]; then
    mkdir -p "$seeds"
    "$bin" -merge=1 "${common[@]}" "$seeds" "$work" >"$bdir/logs/$t.merge.log" 2>&1 \
      || die "$t: merging into fuzz/corpus/$t failed (build/fuzz/logs/$t.merge.log)"
    echo "fuzz: $t: fuzz/corpus/$t now holds $(count_files "$seeds") inputs" >&2
  fi
}

# Every input of fuzz/crashes/TARGET/ once, each in its own process: each
# was a crash, and must pass now that its cause is fixed.
replay_crashes() {
  local t=$1 dir="$top/fuzz/crashes/$1" log="$bdir/logs/$1.crashes.log"
  local files=() f rc failed=0
  [ -d "$dir" ] && mapfile -t files < <(find "$dir" -maxdepth 1 -type f | sort)
  : >"$log"
  for f in "${files[@]}"; do
    rc=0
    "$bdir/fuzz/fuzz_$t" "${common[@]}" "$f" >"$log.one" 2>&1 || rc=$?
    cat "$log.one" >>"$log"
    if [ "$rc" != 0 ]; then
      failed=$((failed + 1))
      printf 'fuzz: %-7s fuzz/crashes/%s/%s fails again: %s\n' "$t" "$t" "$(basename "$f")" "$(why "$log.one")"
    fi
  done
  rm -f "$log.one"
  printf 'fuzz: %-7s %d crash inputs replayed, %d fail\n' "$t" "${#files[@]}" "$failed"
  crashes_total=$((crashes_total + failed))
}

echo "fuzz: ${targets[*]}, ${seconds} s each" >&2
for t in "${targets[@]}"; do fuzz_one "$t"; done
if [ "$smoke" = 1 ]; then
  for t in "${targets[@]}"; do replay_crashes "$t"; done
fi
if [ "$crashes_total" != 0 ]; then
  echo "fuzz: FAILED: $crashes_total crash(es)"
  exit 1
fi
echo "fuzz: no crashes"
