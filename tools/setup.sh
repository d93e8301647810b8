#!/usr/bin/env bash
# Installs what the bench needs and is missing, and nothing else:
#   Debian packages (apt), the project's Python venv (.venv: LCM 1.5 from PyPI,
#   numpy, matplotlib, PyYAML; Dask distributed with cryptography for its TLS
#   and dask-jobqueue for sweeps on SLURM,
#   Jinja2 and SciPy for sweeps, reports and the planner; pandas, mcap and
#   jsonschema for a run's data and its export; aiohttp for the live view's
#   server and Selenium to test it in Debian's chromium; the project's own
#   package, analysis/, installed editable) and Unity (from Debian's cjson source package,
#   hash checked, unpacked into build/_deps/unity).
# Idempotent: a second run checks and returns in well under a second.
# Usage: tools/setup.sh [--quiet]
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
quiet=0; [ "${1:-}" = "--quiet" ] && quiet=1   # --quiet: say nothing when nothing is missing
say() { echo "setup: $*" >&2; }
die() { echo "setup: error: $*" >&2; exit 1; }

# ---- Debian packages --------------------------------------------------------
apt_pkgs=(build-essential cmake ninja-build pkg-config ca-certificates iproute2
          python3 python3-venv libeigen3-dev libopencv-dev libglib2.0-dev
          libyaml-cpp-dev xvfb valgrind gcc-arm-none-eabi libnewlib-arm-none-eabi
          qemu-system-arm nlohmann-json3-dev gwyddion libdlib-dev
          clang-14 libclang-rt-14-dev iptables libnetfilter-queue-dev
          libisal-dev zlib1g-dev chromium chromium-driver ffmpeg)
apt_pkgs+=(libsodium-dev)   # the bus's MAC (bus/bus_key.hpp)
apt_pkgs+=(libpng-dev libjpeg-dev)   # PNG read and the page's JPEGs without OpenCV's imgcodecs (host/image/png_read.hpp, host/renderer/jpeg_file.hpp)
apt_pkgs+=(libopencv-contrib-dev fonts-dejavu-core)   # the frames' text: OpenCV's FreeType module, DejaVu Sans (host/renderer/frame_font.hpp)
apt_pkgs+=(slurm-wlm munge)   # ./afm sweep --cluster slurm and its test's single-machine SLURM (13.2 MB installed, 3.6 MB fetched)
missing=()
# one dpkg-query for them all (a call each cost a run's build check 0.8 s);
# it exits 1 when any of them is unknown to dpkg (never installed, as on a
# fresh machine), which must not end the script under pipefail
installed=" $({ dpkg-query -W -f='${Status} ${Package}\n' "${apt_pkgs[@]}" 2>/dev/null || true; } | awk '$1 == "install" && $3 == "installed" { printf "%s ", $4 }') "
for p in "${apt_pkgs[@]}"; do
  [[ $installed == *" $p "* ]] || missing+=("$p")
done
# A JDK (javac + jar) for the lcm-spy types jar, and a JRE with AWT for
# lcm-spy's window (a headless JRE has no libawt_xawt.so: lcm-spy then fails
# with java.awt.HeadlessException even under Xvfb); any JDK 17+ already
# present will do if it has both.
if ! command -v javac >/dev/null || ! command -v jar >/dev/null; then missing+=(default-jdk); fi
java_home=$(dirname "$(dirname "$(readlink -f "$(command -v java 2>/dev/null || echo /nonexistent/bin/java)")")")
[ -e "$java_home/lib/libawt_xawt.so" ] || missing+=(default-jre)
apt_updated=0
apt_update_once() {
  [ $apt_updated = 1 ] && return 0
  say "apt-get update"
  apt-get update -qq || die "apt-get update failed"
  apt_updated=1
}
if [ ${#missing[@]} -gt 0 ]; then
  [ "$(id -u)" = 0 ] || die "missing Debian packages (${missing[*]}); run as root or install them with apt-get"
  apt_update_once
  say "installing ${#missing[@]} Debian packages: ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null \
    || die "apt-get install failed for: ${missing[*]}"
fi

# ---- Python venv with LCM 1.5 ------------------------------------------------
venv="$top/.venv"
py_reqs="lcm==1.5.3 numpy matplotlib pillow PyYAML dask==2026.8.0 distributed==2026.8.0 cryptography==46.0.3 jinja2==3.1.6 scipy==1.17.1 pandas==3.1.1 mcap==1.6.0 jsonschema==4.26.0 aiohttp==3.14.5 selenium==4.51.0 gwyfile==0.3.0 foxglove-schemas-protobuf==0.4.0 protobuf==7.36.2 pytest==9.2.0 gymnasium==1.2.2 dask-jobqueue==0.9.0"
stamp="$venv/.afm-reqs"
pkg_stamp="$venv/.afm-package"
pkg_want="$top $(sha256sum "$top/pyproject.toml" | cut -d' ' -f1)"
if [ -L "$venv" ]; then
  # A venv borrowed through a link (a worktree using its main checkout's):
  # used as it is, never rebuilt nor its package re-pointed from here, so
  # that this checkout's setup cannot undo the one it belongs to.
  [ -x "$venv/bin/python" ] || die ".venv is a link to '$(readlink -- "$venv")', which holds no python: remove the link and setup makes this checkout a venv of its own"
  [ "$(cat "$stamp" 2>/dev/null)" = "$py_reqs" ] \
    || say "warning: .venv is a link to $(readlink -f -- "$venv"), whose packages are not this checkout's list: left as it is (./afm setup in the checkout it belongs to, or remove the link)"
  [ "$(cat "$pkg_stamp" 2>/dev/null | cut -d' ' -f1)" = "$top" ] \
    || say "warning: .venv is a link to $(readlink -f -- "$venv"), whose python imports $(cut -d' ' -f1 "$pkg_stamp" 2>/dev/null)'s analysis package, not this checkout's (outside this folder)"
else
  if [ ! -x "$venv/bin/python" ] || [ "$(cat "$stamp" 2>/dev/null)" != "$py_reqs" ]; then
    say "creating Python venv in .venv ($py_reqs)"
    /usr/bin/python3 -m venv "$venv" || die "python3 -m venv failed (is python3-venv installed?)"
    "$venv/bin/pip" install -q --disable-pip-version-check $py_reqs || die "pip install failed: $py_reqs"
    echo "$py_reqs" > "$stamp"
  fi
  # The project's own package (pyproject.toml: analysis), editable: the venv's
  # python imports this checkout's analysis/ wherever it runs from.
  if [ "$(cat "$pkg_stamp" 2>/dev/null)" != "$pkg_want" ]; then
    say "installing the project's Python package (analysis) into .venv, editable"
    "$venv/bin/pip" install -q --disable-pip-version-check --no-deps -e "$top" \
      || die "pip install -e $top failed (pyproject.toml)"
    echo "$pkg_want" > "$pkg_stamp"
  fi
fi

# ---- A range of uids for the runs (issue 46; run/run_uid.sh) -------------------
# Started as root, each run takes a uid of its own from afm-runs in
# /etc/subuid and /etc/subgid (65536 ids no user, group or other range holds).
if [ "$(id -u)" = 0 ] && ! "$top/run/run_uid.sh" range >/dev/null 2>&1; then
  say "reserving uids for the runs: afm-runs $("$top/run/run_uid.sh" reserve | tr ' ' ':') in /etc/subuid and /etc/subgid"
fi

# ---- Unity 2.4.3 from Debian's cjson source package ---------------------------
unity_dir="$top/build/_deps/unity"
cjson_sha=5308fd4bd90cef7aa060558514de6a1a4a0819974a26e6ed13973c5f624c24b2
if [ ! -f "$unity_dir/.afm-ok" ]; then
  dl="$top/build/_deps/cjson-src"
  mkdir -p "$dl"
  tarball=$(ls "$dl"/cjson_1.7.15.orig.tar.gz 2>/dev/null || true)
  if [ -z "$tarball" ]; then
    # apt-get source needs a deb-src entry mirroring the machine's deb entries.
    if ! grep -rqsE '^(Types:.*deb-src|deb-src )' /etc/apt/sources.list /etc/apt/sources.list.d/; then
      [ "$(id -u)" = 0 ] || die "no deb-src entry in /etc/apt and not root to add one"
      src=/etc/apt/sources.list.d/afm-deb-src.sources
      if [ -f /etc/apt/sources.list.d/debian.sources ]; then
        sed -n 's/^Types: *deb *$/Types: deb-src/;p' /etc/apt/sources.list.d/debian.sources > "$src"
      elif grep -qs '^deb ' /etc/apt/sources.list; then
        src=/etc/apt/sources.list.d/afm-deb-src.list
        sed -n 's/^deb /deb-src /p' /etc/apt/sources.list > "$src"
      else
        die "cannot find the machine's apt sources to mirror as deb-src"
      fi
      say "added deb-src entry $src"
      apt_updated=0
    fi
    apt_update_once
    say "downloading Debian's cjson source package (for Unity)"
    (cd "$dl" && apt-get source --download-only -qq cjson=1.7.15-1+deb12u4 >/dev/null 2>&1 \
       || apt-get source --download-only -qq cjson >/dev/null) || die "apt-get source cjson failed"
    tarball="$dl/cjson_1.7.15.orig.tar.gz"
    [ -f "$tarball" ] || die "expected $tarball after apt-get source"
  fi
  echo "$cjson_sha  $tarball" | sha256sum -c --quiet - || die "sha256 of $tarball does not match $cjson_sha"
  rm -rf "$unity_dir"; mkdir -p "$unity_dir"
  tar -xzf "$tarball" -C "$dl" cJSON-1.7.15/tests/unity
  u="$dl/cJSON-1.7.15/tests/unity"
  mkdir -p "$unity_dir/src" "$unity_dir/examples"
  cp "$u/src/unity.c" "$u/src/unity.h" "$u/src/unity_internals.h" "$unity_dir/src/"
  cp "$u/examples/unity_config.h" "$unity_dir/examples/"
  cp "$u/docs/license.txt" "$unity_dir/LICENSE.txt" 2>/dev/null || true
  touch "$unity_dir/.afm-ok"
  say "Unity 2.4.3 unpacked into build/_deps/unity"
fi
[ $quiet = 1 ] || say "ok: everything the bench needs is installed"
