#!/usr/bin/env bash
# Builds and tests the firmware on its other targets, firmware-only
# (-DAFM_FIRMWARE_ONLY=ON), with Ninja, AFM_JOBS (default: every core) jobs:
#   (a) build/arm: Cortex-M4 cross build (cmake/arm-none-eabi.cmake), every
#       Unity test run under qemu-system-arm (mps2-an386, semihosting);
#       prints arm-none-eabi-size of the firmware library and a test image.
#   (b) build/san: host build with ASan + UBSan, no recovery.
# Exits non-zero on the first failure. Usage: tools/fw_targets.sh [arm|san]...
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
jobs=${AFM_JOBS:-$(nproc)}
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(arm san)

say() { echo "fw_targets: $*"; }

build_arm() {
  local b="$top/build/arm"
  say "Cortex-M4 cross build in $b"
  cmake -S "$top" -B "$b" -G Ninja -DAFM_FIRMWARE_ONLY=ON \
        -DCMAKE_TOOLCHAIN_FILE="$top/cmake/arm-none-eabi.cmake" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$b" -j "$jobs"
  say "arm-none-eabi-size (text = code + rodata in flash):"
  arm-none-eabi-size -t "$b/firmware/libafm_firmware.a" | tail -n 1 | sed 's/(TOTALS)/libafm_firmware.a (all objects)/'
  arm-none-eabi-size "$b/tests/firmware/test_board.elf"
  say "running the Unity tests under qemu-system-arm"
  (cd "$b" && ctest --output-on-failure -j "$jobs")
}

build_san() {
  local b="$top/build/san"
  local san="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"
  say "ASan+UBSan host build in $b"
  cmake -S "$top" -B "$b" -G Ninja -DAFM_FIRMWARE_ONLY=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DCMAKE_C_FLAGS="$san" -DCMAKE_CXX_FLAGS="$san" \
        -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
  cmake --build "$b" -j "$jobs"
  (cd "$b" && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     ctest --output-on-failure -j "$jobs")
}

for t in "${targets[@]}"; do
  case "$t" in
    arm) build_arm ;;
    san) build_san ;;
    *) echo "fw_targets: unknown target '$t' (arm, san)" >&2; exit 2 ;;
  esac
done
say "all targets passed: ${targets[*]}"
