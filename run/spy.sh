#!/usr/bin/env bash
# The one way the project starts lcm-spy: LCM's lcm-spy script with a Java
# runtime that can open a window.
#   run/spy.sh [lcm-spy's arguments...]
# lcm-spy's script runs the first `java` on PATH. A headless runtime (Debian's
# default-jre-headless / default-jdk-headless: no lib/libawt_xawt.so) fails
# there with java.awt.HeadlessException even under Xvfb, so this puts first on
# PATH the bin/ of a runtime that has AWT: PATH's own java when it has it, else
# the first of /usr/lib/jvm/*/ that does (tools/setup.sh installs default-jre).
# Refused in one line, exit 2, when no runtime has AWT or when
# JAVA_TOOL_OPTIONS asks for java.awt.headless=true.
# Environment: AFM_LCM_BIN, lcm-spy's folder (default: the venv's LCM bin/);
# CLASSPATH, the project's types jar, is passed through.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
lcmbin=${AFM_LCM_BIN:-$(echo "$top"/.venv/lib/python3*/site-packages/bin)}
die() { echo "spy: $*" >&2; exit 2; }
[ -x "$lcmbin/lcm-spy" ] || die "lcm-spy missing in $lcmbin: run ./afm setup"

# $1: a java executable; true when its runtime has AWT's X11 library.
has_awt() {
  local home
  home=$(dirname "$(dirname "$(readlink -f "$1")")")
  [ -e "$home/lib/libawt_xawt.so" ]
}

java_bin=""
if command -v java >/dev/null && has_awt "$(command -v java)"; then
  java_bin=$(dirname "$(readlink -f "$(command -v java)")")
else
  for j in /usr/lib/jvm/*/bin/java; do
    if [ -x "$j" ] && has_awt "$j"; then java_bin=$(dirname "$j"); break; fi
  done
fi
[ -n "$java_bin" ] || die "no Java runtime with AWT (lib/libawt_xawt.so) on PATH or in /usr/lib/jvm: lcm-spy's window needs one (./afm setup installs default-jre)"
case " ${JAVA_TOOL_OPTIONS:-} " in
  *java.awt.headless=true*) die "JAVA_TOOL_OPTIONS sets java.awt.headless=true ('${JAVA_TOOL_OPTIONS}'): lcm-spy is a window; unset it" ;;
esac
PATH="$java_bin:$PATH" exec "$lcmbin/lcm-spy" "$@"
