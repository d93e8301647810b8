#!/bin/sh
# Runs CMD without privilege (issue 35, least privilege): as the run's user
# when one is named, every capability dropped from the effective, permitted,
# inheritable and bounding sets, and the securebits set so that uid 0
# regains none at exec (noroot) and nothing can gain any later
# (no_new_privs). run/in_netns.sh runs every run's command through it once
# the namespace exists; the one place a run's process changes its user.
#   run/drop_caps.sh CMD [ARGS...]
# AFM_RUN_UID=UID AFM_RUN_GID=GID (run/in_netns.sh exports them when
# started as root; run/run_user.sh names the user): CMD runs as that uid
# and gid with no supplementary groups (AFM_RUN_GROUPS=GID[,GID...]: those
# alone; a sweep's workers share its scheduler's group, analysis/sweep_users.py),
# unless it is that uid already. All three are removed from CMD's
# environment, so a command CMD starts through this script again only drops
# capabilities.
# Every command runs under rlimits (prlimit): at most LIMIT_NPROC processes
# of its uid, files of at most LIMIT_FSIZE bytes, LIMIT_DATA bytes of data
# segment per process; run/drop_caps.sh --limits prints them as run.json's
# netns names them ("nproc=N,fsize=B,data=B").
# AFM_KEEP_CAPS=net_admin,net_raw keeps those as ambient capabilities, for
# the link and fault helper (afm_netfault) alone: ./afm faults sets it for
# that row and runs the launcher beside it through this script again,
# without it.
set -eu
LIMIT_NPROC=4096 LIMIT_FSIZE=$((16 << 30)) LIMIT_DATA=$((16 << 30))
[ "${1:-}" != --limits ] || { echo "nproc=$LIMIT_NPROC,fsize=$LIMIT_FSIZE,data=$LIMIT_DATA"; exit 0; }
[ $# -ge 1 ] || { echo "usage: run/drop_caps.sh CMD [ARGS...]" >&2; exit 2; }
command -v setpriv >/dev/null || { echo "drop_caps: setpriv not found (util-linux)" >&2; exit 2; }
keep=${AFM_KEEP_CAPS:-}
limits="prlimit --nproc=$LIMIT_NPROC --fsize=$LIMIT_FSIZE --data=$LIMIT_DATA --"
uid=${AFM_RUN_UID:-} gid=${AFM_RUN_GID:-} groups=${AFM_RUN_GROUPS:-}
unset AFM_KEEP_CAPS AFM_RUN_UID AFM_RUN_GID AFM_RUN_GROUPS
user=""
if [ -n "$uid" ] && [ "$(id -u)" != "$uid" ]; then
  case "$uid$gid" in *[!0-9]*|"") echo "drop_caps: AFM_RUN_UID and AFM_RUN_GID must be numbers, not '$uid' and '$gid'" >&2; exit 2 ;; esac
  case "$groups" in *[!0-9,]*|,*|*,|*,,*) echo "drop_caps: AFM_RUN_GROUPS must be numbers separated by commas, not '$groups'" >&2; exit 2 ;; esac
  user="--reuid=$uid --regid=$gid $([ -n "$groups" ] && echo "--groups=$groups" || echo --clear-groups)"
fi
# The securebits need CAP_SETPCAP (bit 8 of CapEff); a command already
# stripped by this script (netfault's shell starting the launcher) has them
# set and locked, and no CAP_SETPCAP.
eff=$(awk '/^CapEff/ {print $2}' /proc/self/status)
sec=""
[ $(( 0x$eff >> 8 & 1 )) = 1 ] && sec="--securebits=+noroot,+noroot_locked,+no_setuid_fixup,+no_setuid_fixup_locked"
if [ -z "$keep" ]; then
  exec setpriv $user --no-new-privs $sec --inh-caps=-all --ambient-caps=-all --bounding-set=-all -- $limits "$@"
fi
caps="-all,+$(echo "$keep" | sed 's/,/,+/g')"
exec setpriv $user $sec --inh-caps="$caps" --ambient-caps="$caps" --bounding-set="$caps" -- $limits "$@"
