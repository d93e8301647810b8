#!/usr/bin/env bash
# Inside a run's namespace (run/in_netns.sh puts it there): lcm-spy
# (run/spy.sh) with the project's types on its CLASSPATH, and lcm-logplayer
# replaying LOG into it. Fails (exit 1) when lcm-spy has ended before the
# replay's end: its window did not open (logs on stderr).
#   run/spy_replay.sh LOG [SPEED]
# lcm-spy stays open after the replay until closed, unless
# AFM_SPY_EXIT_AFTER_REPLAY=1 (tests), which stops it when the replay ends.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
log=${1:?usage: spy_replay.sh LOG [SPEED]}
speed=${2:-1}
lcmbin=$(echo "$top"/.venv/lib/python3*/site-packages/bin)
jar="${AFM_TYPES_JAR:-$top/build/main/lcmtypes/afm_types.jar}"
url='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304'
[ -f "$jar" ] || { echo "spy: types jar $jar missing: run ./afm build" >&2; exit 2; }
[ -n "${DISPLAY:-}" ] || { echo "spy: no DISPLAY: lcm-spy is a window (use xvfb-run for a headless check)" >&2; exit 2; }
CLASSPATH="$jar" AFM_LCM_BIN="$lcmbin" "$top/run/spy.sh" --lcm-url="$url" &
spy=$!
trap 'kill $spy 2>/dev/null || true' EXIT
sleep 3   # let lcm-spy subscribe before the replay starts
"$lcmbin/lcm-logplayer" -s "$speed" -l "$url" "$log"
kill -0 $spy 2>/dev/null || { wait $spy || true; echo "spy: lcm-spy ended before the replay did: its window did not open (see above)" >&2; exit 1; }
echo "spy: replay of $log finished" >&2
if [ "${AFM_SPY_EXIT_AFTER_REPLAY:-0}" = 1 ]; then exit 0; fi
wait $spy
