#!/bin/sh
# Runs CMD without privilege (issue 35, least privilege): every capability
# dropped from the effective, permitted, inheritable and bounding sets, and
# the securebits set so that uid 0 regains none at exec (noroot) and nothing
# can gain any later (no_new_privs). tools/in_netns.sh runs every run's
# command through it once the namespace exists.
#   tools/drop_caps.sh CMD [ARGS...]
# AFM_KEEP_CAPS=net_admin,net_raw keeps those as ambient capabilities, for
# the link and fault helper (afm_netfault) alone: ./afm faults sets it for
# that row and runs the launcher beside it through this script again,
# without it.
set -eu
[ $# -ge 1 ] || { echo "usage: tools/drop_caps.sh CMD [ARGS...]" >&2; exit 2; }
command -v setpriv >/dev/null || { echo "drop_caps: setpriv not found (util-linux)" >&2; exit 2; }
keep=${AFM_KEEP_CAPS:-}
unset AFM_KEEP_CAPS
# The securebits need CAP_SETPCAP (bit 8 of CapEff); a command already
# stripped by this script (netfault's shell starting the launcher) has them
# set and locked, and no CAP_SETPCAP.
eff=$(awk '/^CapEff/ {print $2}' /proc/self/status)
sec=""
[ $(( 0x$eff >> 8 & 1 )) = 1 ] && sec="--securebits=+noroot,+noroot_locked,+no_setuid_fixup,+no_setuid_fixup_locked"
if [ -z "$keep" ]; then
  exec setpriv --no-new-privs $sec --inh-caps=-all --ambient-caps=-all --bounding-set=-all -- "$@"
fi
caps="-all,+$(echo "$keep" | sed 's/,/,+/g')"
exec setpriv $sec --inh-caps="$caps" --ambient-caps="$caps" --bounding-set="$caps" -- "$@"
