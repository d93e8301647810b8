#!/usr/bin/env bash
# The paper's two computers on a link, inside the run's own namespace
# (docs/hosts.md). run/in_netns.sh runs this, with the privilege of the new
# namespace, when AFM_HOSTS=2; it then runs CMD without any (drop_caps.sh),
# as the run's user when it was started as root (AFM_RUN_UID): that user
# makes the afm namespace, so that the launcher, as that user, may enter it.
#   AFM_HOSTS=2 [AFM_LINK=SPEC] [AFM_LINK_DIR=DIR] run/in_netns.sh CMD [ARGS...]
#
# The namespace in_netns.sh made is "host" (the card's node, the operator,
# the renderer, the launcher and its record). "afm" is a second network
# namespace, in a user namespace nested in the run's, held open by a process
# that ends with CMD. A veth pair joins them: vhost (169.254.76.1/30) and
# vafm (169.254.76.2/30); each side routes the bus's multicast group through
# its end, so LCM (ttl=1) crosses the pair and nothing else: neither
# namespace has another interface but lo.
#
# SPEC: comma-separated KEY=VALUE, each direction alike:
#   delay=MS  jitter=MS  loss=P  dup=P  reorder=P  rate=MBIT
# Rate: tbf on each end's egress. The rest: netem where the kernel has it
# (AFM_LINK_SHAPER=netem|nfqueue|auto, default auto), else afm_netfault's
# NFQUEUE verdicts on what each side receives from the other (loss on the
# lockstep's channels, which the simulator's resend repairs; docs/hosts.md).
# Then afm_linkprobe measures the link by LCM round trips (DIR/probe.json;
# AFM_LINK_PINGS pings, default 400, of AFM_LINK_PROBE_SIZES bytes, default
# 64,4000, every AFM_LINK_PROBE_INTERVAL_US, default 1000).
#
# Exports to CMD: AFM_BUS_LINK=vhost, AFM_HOSTS_AFM_PID (the holder of the
# afm namespace: /proc/PID/ns/{user,net}), AFM_LINK_DIR, AFM_LINK_SHAPER
# (what ran: none, tbf, nfqueue+tbf, netem+tbf...), AFM_LINK_SHAPERS (pids of
# the afm_netfault processes: SIGTERM makes them write DIR/netfault-*.json),
# AFM_DROP_CAPS. AFM_LINK_DOWN=AT_S:FOR_S (./afm faults): vafm down AT_S
# seconds after CMD starts, for FOR_S seconds, then up with its route back.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: AFM_HOSTS=2 run/in_netns.sh CMD [ARGS...]" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
build=${AFM_BUILD:-$here/../build/main}
drop="$here/drop_caps.sh"
die() { echo "two_hosts: $*" >&2; exit 2; }
temporary=0
[ -n "${AFM_LINK_DIR:-}" ] || temporary=1
dir=${AFM_LINK_DIR:-$("$drop" mktemp -d "${TMPDIR:-/tmp}/afm-link-XXXXXX")}   # the run's user writes in it
mkdir -p "$dir"

delay=0 jitter=0 loss=0 dup=0 reorder=0 rate=0
num='^[0-9]+([.][0-9]+)?$'
IFS=, read -r -a kv <<< "${AFM_LINK:-}"
for item in "${kv[@]}"; do
  [ -n "$item" ] || continue
  k=${item%%=*} v=${item#*=}
  [ "$k" != "$item" ] || die "--link: '$item' is not KEY=VALUE (delay, jitter, loss, dup, reorder, rate)"
  [[ $v =~ $num ]] || die "--link: $k must be a number >= 0, not '$v'"
  case "$k" in
    delay|jitter|rate) ;;
    loss|dup|reorder) awk -v p="$v" 'BEGIN { exit !(p <= 1) }' || die "--link: $k is a probability in [0, 1], not '$v'" ;;
    *) die "--link: unknown key '$k' (delay, jitter, loss, dup, reorder, rate)" ;;
  esac
  printf -v "$k" '%s' "$v"
done
us() { awk -v ms="$1" 'BEGIN { printf "%d", ms * 1000 + 0.5 }'; }
nonzero() { awk -v x="$1" 'BEGIN { exit !(x > 0) }'; }

ip link set lo up
# The afm namespace, held while CMD (this shell's pid, after exec) lives.
# The run's user makes it (its owner), and the holder needs no privilege to
# hold them: it drops all it has.
# Not started as root (or root kept: run/in_netns.sh), this shell is root
# of the run's user namespace and makes it itself: once stripped of its
# capabilities it could not write the new namespace's maps.
maker=()
[ "${AFM_RUN_UID:-0}" = 0 ] || maker=("$drop")
"${maker[@]}" unshare -rn "$drop" tail --pid=$$ -s 0.1 -f /dev/null </dev/null >/dev/null 2>&1 &
afm=$!
for _ in $(seq 200); do
  [ "$(readlink /proc/$afm/ns/net 2>/dev/null)" != "$(readlink /proc/$$/ns/net)" ] && break
  sleep 0.005
done
[ "$(readlink /proc/$afm/ns/net 2>/dev/null)" != "$(readlink /proc/$$/ns/net)" ] \
  || die "cannot make the afm namespace (unshare -rn inside the run's: user namespaces nested?)"
if [ ${#maker[@]} -gt 0 ]; then
  in_afm() { nsenter -t "$afm" -U -n "$@"; }   # as its root: the run's user, its owner, in the run's namespace
else
  in_afm() { nsenter -t "$afm" -U -n --preserve-credentials "$@"; }   # this shell made it: its own credentials
fi
ip link add vhost type veth peer name vafm netns "$afm"
ip addr add 169.254.76.1/30 dev vhost
ip link set vhost up
ip route add 224.0.0.0/4 dev vhost
in_afm sh -c 'ip link set lo up && ip addr add 169.254.76.2/30 dev vafm && ip link set vafm up && ip route add 224.0.0.0/4 dev vafm'

# The shapers: rate, then the rest.
shaper=none shapers=""
if nonzero "$rate"; then
  for side in host afm; do
    cmd=(tc qdisc add dev "v$side" root handle 1: tbf rate "${rate}mbit" burst 64kb latency 100ms)
    if [ $side = afm ]; then in_afm "${cmd[@]}"; else "${cmd[@]}"; fi
  done
  shaper=tbf
fi
if nonzero "$delay" || nonzero "$jitter" || nonzero "$loss" || nonzero "$dup" || nonzero "$reorder"; then
  . "$here/../faults/two_hosts_shape.sh"   # the link shaper
fi

# Both ends up before anything crosses (a veth's carrier comes a moment after
# "ip link set up": what is sent before is lost, and the probe would count it).
for _ in $(seq 200); do
  ip -o link show vhost | grep -q "state UP" && in_afm ip -o link show vafm | grep -q "state UP" && break
  sleep 0.01
done
# The link as it is, by LCM round trips.
export AFM_BUS_LINK=vhost
AFM_BUS_LINK=vafm "${maker[@]}" nsenter -t "$afm" -U -n --preserve-credentials "$drop" "$build/host/afm_linkprobe" --echo --json "$dir/echo.json" 2>"$dir/echo.log" >/dev/null </dev/null &
echo_pid=$!
for _ in $(seq 200); do grep -q ready "$dir/echo.log" 2>/dev/null && break; sleep 0.01; done
"$drop" "$build/host/afm_linkprobe" --ping "${AFM_LINK_PINGS:-400}" --interval-us "${AFM_LINK_PROBE_INTERVAL_US:-1000}" --sizes "${AFM_LINK_PROBE_SIZES:-64,4000}" --echoed "$dir/echo.json" --json "$dir/probe.json" \
  2>"$dir/probe.log" >/dev/null </dev/null &
probe=$!
# the echo writes its count when the pinger says it is done (or on SIGTERM)
wait $probe || true
kill -TERM $echo_pid 2>/dev/null || true
wait $echo_pid 2>/dev/null || true

if [ -n "${AFM_LINK_DOWN:-}" ]; then
  at=${AFM_LINK_DOWN%%:*} for_s=${AFM_LINK_DOWN#*:}
  ( sleep "$at"; in_afm ip link set vafm down; echo "vafm down at $(date +%s.%N)" > "$dir/down.log"
    sleep "$for_s"; in_afm ip link set vafm up; in_afm ip route replace 224.0.0.0/4 dev vafm
    echo "vafm up at $(date +%s.%N)" >> "$dir/down.log" ) </dev/null >/dev/null 2>&1 &
fi

export AFM_LINK_DIR_TEMPORARY=$temporary AFM_HOSTS_AFM_PID=$afm AFM_LINK_DIR=$dir AFM_LINK_SHAPER=$shaper AFM_LINK_SHAPERS=$shapers AFM_DROP_CAPS=$drop
export AFM_LINK_ASKED="delay=$delay,jitter=$jitter,loss=$loss,dup=$dup,reorder=$reorder,rate=$rate"
exec "$drop" "$@"
