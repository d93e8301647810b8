# Sourced by run/two_hosts.sh: delay, jitter, loss, duplication and
# reordering on the link, each direction alike. netem on each end's egress
# where the kernel has sch_netem (under the tbf of a rate, if any); else
# afm_netfault in each namespace on what arrives from the other (one queue,
# one direction each; docs/hosts.md). Sets shaper and shapers.
want=${AFM_LINK_SHAPER:-auto}
case "$want" in auto|netem|nfqueue) ;; *) die "AFM_LINK_SHAPER must be auto, netem or nfqueue, not '$want'" ;; esac
pct() { awk -v p="$1" 'BEGIN { printf "%g%%", p * 100 }'; }
if [ "$want" != nfqueue ] && tc qdisc add dev vhost root handle 9: netem delay 1ms 2>/dev/null; then
  tc qdisc del dev vhost root handle 9: 2>/dev/null || true
  for side in host afm; do
    args=(delay "${delay}ms" "${jitter}ms" loss "$(pct "$loss")" duplicate "$(pct "$dup")" reorder "$(pct "$reorder")")
    if nonzero "$rate"; then cmd=(tc qdisc add dev "v$side" parent 1:1 handle 10: netem "${args[@]}")
    else cmd=(tc qdisc add dev "v$side" root handle 10: netem "${args[@]}"); fi
    if [ $side = afm ]; then in_afm "${cmd[@]}"; else "${cmd[@]}"; fi
  done
  shaper=netem
  if nonzero "$rate"; then shaper="netem+tbf"; fi
else
  [ "$want" != netem ] || die "AFM_LINK_SHAPER=netem: this kernel has no sch_netem (tc qdisc ... netem refused)"
  # the lockstep's channels (their loss is repaired by the simulator's resend)
  # and the probe's; the rest is delayed, duplicated and reordered, never lost
  lossy=AFM_ANALOG,AFM_CMD,HAPTIC_FORCE,HAPTIC_POSE,LINK_PING,LINK_PONG
  nf() {  # SIDE PEER: afm_netfault on what arrives through vSIDE from PEER
    local side=$1 peer=$2
    local q=(env AFM_KEEP_CAPS=net_admin,net_raw "$drop" "$build/host/afm_netfault" --queue 0
      --link-in "v$side" --peer "$peer" --iptables --dup-dev lo --delay-us "$(us "$delay")" --jitter-us "$(us "$jitter")"
      --drop "$loss" --dup "$dup" --reorder "$reorder" --hold-us 1000 --drop-channels "$lossy"
      --seed "${AFM_LINK_SEED:-1}$([ "$side" = afm ] && echo 1 || echo 2)" --report "$dir/netfault-to-$side.json"
      --while-pid $$)
    local log="$dir/netfault-to-$side.log"
    # never the caller's stdout: a shaper that outlived the run would hold its pipe open
    # (nsenter itself in the background, not the in_afm function: a subshell would stay, privileged, for the run's life)
    # (in the afm namespace: entered as the run's user, its owner, as the launcher enters it)
    if [ "$side" = afm ]; then env AFM_KEEP_CAPS=net_admin,net_raw "$drop" nsenter -t "$afm" -U -n --preserve-credentials "${q[@]}" \
                                 2>"$log" </dev/null >/dev/null &
    else "${q[@]}" 2>"$log" </dev/null >/dev/null & fi
    local started=$!
    for _ in $(seq 300); do
      if grep -q ready "$log" 2>/dev/null; then   # its own pid (nsenter may have forked)
        shapers="$shapers${shapers:+,}$(sed -n 's/^afm_netfault: pid \([0-9]*\).*/\1/p' "$log" | head -1)"
        return 0
      fi
      kill -0 $started 2>/dev/null || break; sleep 0.01
    done
    die "afm_netfault in the $side namespace did not get ready: $(tail -1 "$dir/netfault-to-$side.log" 2>/dev/null)"
  }
  nf host 169.254.76.2
  nf afm 169.254.76.1
  shaper=nfqueue
  if nonzero "$rate"; then shaper="nfqueue+tbf"; fi
fi
