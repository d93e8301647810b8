#!/usr/bin/env bash
# ./afm bench firmware: cost and accuracy of the firmware's per-sample chain
# (acquisition + compensation + theta + force + rotation) on three word
# sizes. Runs build/main/bench/firmware/bench_fw twice: once for wall-clock
# time and force error, once under valgrind's callgrind for instructions per
# sample (only the measured loop counts). Prints one table. A benchmark: it
# never fails on the numbers.
set -euo pipefail

usage() {
  cat <<'TXT'
usage: ./afm bench firmware [-n SAMPLES] [-r REPEATS] [-c SAMPLES] [-b SAMPLES] [-a DEG,DEG]
       bench/bench_firmware.sh [same options]

  -n SAMPLES  timing and error run: samples per scan angle (default 200000)
  -r REPEATS  timing repeats; the median ns/sample is shown (default 7)
  -c SAMPLES  callgrind run: samples per scan angle (default 50000)
  -b SAMPLES  samples per fw_board_step_block call in (b) (default 20, the default
              scene's analog block)
  -a DEGREES  scan angles in degrees (default 270,300)
  --no-callgrind  skip the instruction counts
  --no-size   skip the Cortex-M4 build and its flash size per module
  --no-board  skip the whole card per block on its board (scenes/short.yaml run with
              --firmware qemu, docs/pil.md) against callgrind's x86-64 count of the same blocks
  -h, --help  this text

Environment: AFM_BUILD (default <repo>/build/main) locates the bench binary
at $AFM_BUILD/bench/firmware/bench_fw.

Rows: (a) the firmware's 16-bit chain (fw_board16_step_block),
(b) the firmware's 32-bit fw_board_step_block, (c) the double reference of the
same chain (bench/firmware/bench_ref.c) fed the same 16-bit ADC codes, and
(c0) that reference on the unquantised input. Errors are |F - F_ref| of the
frame-A force vector against (c); % FS of k_n K_n x 10 V. Instructions are
x86-64 instructions counted by callgrind, loop overhead included.
TXT
}

top=$(cd "$(dirname "$0")/.." && pwd)
build=${AFM_BUILD:-"$top/build/main"}
bin="$build/bench/firmware/bench_fw"
n=200000
repeats=7
cg_n=50000
angles=270,300
do_cg=1
do_size=1
do_board=1
block=20

while [ $# -gt 0 ]; do
  case "$1" in
    -n) [ $# -ge 2 ] || { echo "bench_firmware: -n needs a number" >&2; exit 2; }; n=$2; shift 2 ;;
    -r) [ $# -ge 2 ] || { echo "bench_firmware: -r needs a number" >&2; exit 2; }; repeats=$2; shift 2 ;;
    -c) [ $# -ge 2 ] || { echo "bench_firmware: -c needs a number" >&2; exit 2; }; cg_n=$2; shift 2 ;;
    -b) [ $# -ge 2 ] || { echo "bench_firmware: -b needs a number" >&2; exit 2; }; block=$2; shift 2 ;;
    -a) [ $# -ge 2 ] || { echo "bench_firmware: -a needs angles" >&2; exit 2; }; angles=$2; shift 2 ;;
    --no-callgrind) do_cg=0; shift ;;
    --no-board) do_board=0; shift ;;
    --no-size) do_size=0; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "bench_firmware: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done

if [ ! -x "$bin" ]; then
  echo "bench_firmware: no bench binary at $bin" >&2
  echo "  build it first (./afm build), or point AFM_BUILD at a build tree that has" >&2
  echo "  bench/firmware (top-level CMakeLists.txt: add_subdirectory(bench/firmware))" >&2
  exit 2
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/bench_fw.XXXXXX")
chmod 755 "$tmp"   # started as root, its run is the run's user (run/run_user.sh), who must reach it
trap 'rm -rf "$tmp"' EXIT

echo "bench_firmware: timing and errors ($n samples per angle, $repeats repeats)" >&2
"$bin" -n "$n" -r "$repeats" -b "$block" -a "$angles" >"$tmp/time.txt"

# instructions per sample: callgrind, counting only each path's loop
declare -A ir=()
declare -A ir_angle=()   # "path@deg" -> instructions of that angle's loop
cg_note=""
paths=(q15 fw32 ref ref_analog)
if [ "$do_cg" -eq 1 ]; then
  if ! command -v valgrind >/dev/null 2>&1; then
    cg_note="valgrind not installed: no instruction counts"
  else
    echo "bench_firmware: callgrind ($cg_n samples per angle)" >&2
    samples=""
    if "$bin" --features | grep -q 'callgrind_requests=1'; then
      # one run; the bench dumps each path's loop (client requests)
      valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file="$tmp/cg.out" \
        "$bin" --callgrind -n "$cg_n" -b "$block" -a "$angles" >"$tmp/cg.txt" 2>"$tmp/cg.log" \
        || { tail -5 "$tmp/cg.log" >&2; echo "bench_firmware: callgrind run failed" >&2; exit 1; }
      for f in "$tmp"/cg.out.*; do
        name=$(sed -n 's/^desc: Trigger: Client Request: bench_//p' "$f")
        tot=$(sed -n 's/^totals: //p' "$f")
        if [ -n "$name" ] && [ -n "$tot" ]; then
          ir_angle[$name]=$tot
          ir[${name%@*}]=$(( ${ir[${name%@*}]:-0} + tot ))
        fi
      done
      cg_note="callgrind: client requests around each path's loop, one dump per scan angle"
    else
      # no callgrind.h at build time: one run per path, collecting inside its loop
      for p in "${paths[@]}"; do
        valgrind --tool=callgrind --toggle-collect="bench_loop_*" \
          --callgrind-out-file="$tmp/cg.$p" "$bin" --path "$p" -n "$cg_n" -b "$block" -a "$angles" \
          >"$tmp/cg.txt" 2>"$tmp/cg.log" \
          || { tail -5 "$tmp/cg.log" >&2; echo "bench_firmware: callgrind run failed" >&2; exit 1; }
        ir[$p]=$(sed -n 's/^totals: //p' "$tmp/cg.$p")
      done
      cg_note="callgrind: --toggle-collect=bench_loop_* (one run per path)"
    fi
    samples=$(sed -n 's/^input samples=\([0-9]*\).*/\1/p' "$tmp/cg.txt")
    cg_note="$cg_note, $samples samples"
  fi
fi

field() { sed -n "s/.* $1=\\([^ ]*\\).*/\\1/p" <<<"$2"; }

label() {
  case "$1" in
    q15) echo "(a) 16-bit firmware" ;;
    fw32) echo "(b) 32-bit firmware" ;;
    ref) echo "(c) double reference" ;;
    ref_analog) echo "(c0) double, no ADC" ;;
  esac
}

input=$(grep '^input ' "$tmp/time.txt")
echo
echo "Firmware per-sample chain: acquisition + compensation + theta + force + rotation"
echo "sweep: $(sed 's/^input //' <<<"$input")"
echo
printf '%-26s | %9s | %12s | %15s | %13s | %10s\n' "path" "ns/sample" "instr/sample" "worst |dF| pN" "RMS |dF| pN" "worst % FS"
printf '%-26s-+-%9s-+-%12s-+-%15s-+-%13s-+-%10s\n' "--------------------------" "---------" "------------" "---------------" "-------------" "----------"
cg_samples=$(sed -n 's/^input samples=\([0-9]*\).*/\1/p' "$tmp/cg.txt" 2>/dev/null || true)
for p in "${paths[@]}"; do
  row=$(grep "^row path=$p " "$tmp/time.txt")
  instr="-"
  if [ -n "${ir[$p]:-}" ] && [ -n "$cg_samples" ]; then
    instr=$(awk -v t="${ir[$p]}" -v s="$cg_samples" 'BEGIN { printf "%.0f", t / s }')
  fi
  printf '%-26s | %9s | %12s | %15s | %13s | %10s\n' "$(label "$p")" "$(field ns "$row")" "$instr" \
    "$(field worst_pn "$row")" "$(field rms_pn "$row")" "$(field worst_pct "$row")"
done
if [ "${#ir_angle[@]}" -gt 0 ] && [ -n "$cg_samples" ]; then
  # the bench names its dumps with %g of each angle
  angle_keys=$(tr ',' '\n' <<<"$angles" | awk 'NF { printf "%g ", $1 }')
  n_ang=$(wc -w <<<"$angle_keys")
  per_angle=$(( cg_samples / n_ang ))
  echo
  echo "instructions per sample by scan angle (alpha = angle - 270 deg; at 270 frames A and C"
  echo "coincide and (b) skips its rotations):"
  printf '%-26s' "path"
  for a in $angle_keys; do printf ' | %8s' "$a deg"; done
  echo
  for p in "${paths[@]}"; do
    printf '%-26s' "$(label "$p")"
    for a in $angle_keys; do
      v=${ir_angle[$p@$a]:-}
      if [ -n "$v" ]; then v=$(awk -v t="$v" -v s="$per_angle" 'BEGIN { printf "%.0f", t / s }'); else v="-"; fi
      printf ' | %8s' "$v"
    done
    echo
  done
fi
echo
echo "notes:"
echo "  - errors: |F - F_ref| of the frame-A force vector against (c), the double model of the"
echo "    same chain fed the same 16-bit ADC codes (so (a) and (b) show arithmetic error);"
echo "    (c0) is (c) on the unquantised input, i.e. what the 16-bit ADC itself costs."
echo "  - (b) runs as the card drives it (fw_card_step_block's signal chain): fw_board_step_block"
echo "    on blocks of $(sed -n 's/.* fw_block=\([0-9]*\).*/\1/p' <<<"$input") samples (-b)."
echo "  - instructions are x86-64 (host build flags), loop overhead included (a few per sample);"
echo "    on a Cortex-M4 the 64-bit divisions of (b) are library calls, not one instruction."
echo "  - (a) fw_board16 (firmware.word_bits: 16): sin/cos theta only where the fallback needs"
echo "    them (series in tan theta), zones on squares, the fallback clamped at 131 nN (fw_board16.h)."
echo "  - ADC filter off, inputs inside +-10 V (no virtual S_n); ${cg_note:-no callgrind run}."
grep '^note ' "$tmp/time.txt" | sed 's/^note /  - /'

# The firmware's size on the card: the Cortex-M4 build (firmware only,
# -O3, as tools/fw_targets.sh builds it), text = code + read-only data.
if [ "$do_size" -eq 1 ]; then
  echo
  if ! command -v arm-none-eabi-size >/dev/null 2>&1; then
    echo "Cortex-M4 size: arm-none-eabi-gcc not installed (./afm setup installs it)"
  else
    arm="$top/build/arm"
    echo "bench_firmware: Cortex-M4 build of the firmware (build/arm)" >&2
    if [ ! -f "$arm/build.ninja" ]; then
      cmake -S "$top" -B "$arm" -G Ninja -DAFM_FIRMWARE_ONLY=ON \
            -DCMAKE_TOOLCHAIN_FILE="$top/cmake/arm-none-eabi.cmake" -DCMAKE_BUILD_TYPE=Release >"$tmp/arm.log" 2>&1 \
        || { tail -5 "$tmp/arm.log" >&2; echo "bench_firmware: Cortex-M4 configure failed" >&2; exit 1; }
    fi
    cmake --build "$arm" --target afm_firmware >"$tmp/arm.log" 2>&1 \
      || { tail -5 "$tmp/arm.log" >&2; echo "bench_firmware: Cortex-M4 build failed" >&2; exit 1; }
    echo "Cortex-M4 flash per module (arm-none-eabi-gcc -mcpu=cortex-m4 -O3; text = code + read-only data):"
    arm-none-eabi-size "$arm/firmware/libafm_firmware.a" | awk '
      NR > 1 { n = $6; sub(/\.c\.obj$/, "", n); printf "  %-14s %7d B text  %5d B data  %5d B bss\n", n, $1, $2, $3; t += $1; d += $2; b += $3 }
      END { printf "  %-14s %7d B text  %5d B data  %5d B bss\n", "total", t, d, b }'
  fi
fi

# The whole card per block (fw_card_step_block), on its board in the loop
# (Cortex-M4 instructions from the board's timer under -icount shift=0) and
# on the host (x86-64 instructions by callgrind, replaying the same run's
# blocks through the host build): docs/pil.md.
if [ "$do_board" -eq 1 ]; then
  echo
  scene="$top/scenes/short.yaml"
  echo "bench_firmware: $scene on the board (--firmware qemu), then its blocks under callgrind" >&2
  if ! "$top/run/in_netns.sh" "$build/host/afm_launch" --scene "$scene" --out "$tmp/pil" --quiet --firmware qemu \
       >"$tmp/pil.log" 2>&1; then
    tail -3 "$tmp/pil.log" >&2
    echo "The whole card per block: the run on the board failed (above)"
  else
    py="$top/.venv/bin/python"; [ -x "$py" ] || py=python3
    read -r blocks spb m4_med m4_worst m4_mean frac1 frac2 < <("$py" -c '
import json, sys
r = json.load(open(sys.argv[1]))
b = r["card"]["board"]; i = b["instructions_per_block"]; g = b["budget"]
print(b["blocks"], r["card"]["samples_per_block"], i["median"], i["worst"], i["mean"], g["fraction_worst_cpi1"], g["fraction_worst_cpi2"])' "$tmp/pil/run.json")
    x86=""
    if [ "$do_cg" -eq 1 ] && command -v valgrind >/dev/null 2>&1; then
      valgrind --tool=callgrind --toggle-collect=fw_card_step_block --callgrind-out-file="$tmp/cg.card" \
        "$build/host/afm_replay" "$tmp/pil" --quiet >"$tmp/cg.card.txt" 2>"$tmp/cg.card.log" \
        && x86=$(sed -n 's/^totals: //p' "$tmp/cg.card")
    fi
    echo "The whole card per block (fw_card_step_block), $(basename "$scene"): $blocks blocks of $spb samples"
    printf '%-34s | %12s | %12s | %12s | %12s\n' "instructions per block" "median" "worst" "mean" "mean/sample"
    printf '%-34s-+-%12s-+-%12s-+-%12s-+-%12s\n' "----------------------------------" "------------" "------------" "------------" "------------"
    printf '%-34s | %12.0f | %12.0f | %12.0f | %12.0f\n' "Cortex-M4, on the board" "$m4_med" "$m4_worst" "$m4_mean" "$(awk -v a="$m4_mean" -v n="$spb" 'BEGIN{print a/n}')"
    if [ -n "$x86" ]; then
      printf '%-34s | %12s | %12s | %12.0f | %12.0f\n' "x86-64, host build (callgrind)" "-" "-" "$(awk -v a="$x86" -v n="$blocks" 'BEGIN{print a/n}')" \
        "$(awk -v a="$x86" -v n="$blocks" -v s="$spb" 'BEGIN{print a/n/s}')"
    fi
    echo "  - Cortex-M4: the board's timer around fw_card_step_block under qemu -icount shift=0 (to 40 instructions);"
    echo "    the worst block is $(awk -v f="$frac1" 'BEGIN{printf "%.1f", 100*f}') % of a 168 MHz core's cycles per block at CPI 1, $(awk -v f="$frac2" 'BEGIN{printf "%.1f", 100*f}') % at CPI 2"
    echo "    (icount counts instructions, not cycles; docs/pil.md)"
    if [ -n "$x86" ]; then
      echo "  - x86-64: the same blocks replayed through the host build (afm_replay), callgrind --toggle-collect=fw_card_step_block"
    fi
  fi
fi
