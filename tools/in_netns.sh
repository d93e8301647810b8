#!/usr/bin/env bash
# Runs a command in a fresh, private network namespace whose loopback is up
# and carries the multicast route (design.md, "The bus"), so no LCM datagram
# of the run can leave through the machine's network interface.
#   tools/in_netns.sh CMD [ARGS...]
# AFM_HOSTS=2: two namespaces joined by a veth pair instead, the bus across
# it (tools/two_hosts.sh, docs/hosts.md); it needs user namespaces.
# Tries a user namespace first (unshare -rn, no root needed); as root where
# user namespaces are refused (a chroot), falls back to unshare -n. Exports
# AFM_NETNS_MODE=rootless|root so the run can say which it used.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: tools/in_netns.sh CMD [ARGS...]" >&2; exit 2; }
command -v unshare >/dev/null || { echo "in_netns: unshare not found (util-linux)" >&2; exit 2; }
command -v ip >/dev/null || { echo "in_netns: ip not found (iproute2; run ./afm setup)" >&2; exit 2; }
# Once the namespace is set up, the command runs with no capabilities
# (tools/drop_caps.sh): root, or root in the user namespace, keeps uid 0 but
# loses every privilege that uid 0 would bring.
drop="$(cd "$(dirname "$0")" && pwd)/drop_caps.sh"
inner='ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$0" "$@"'
case "${AFM_HOSTS:-1}" in
  1) ;;
  2) drop="$(cd "$(dirname "$0")" && pwd)/two_hosts.sh"   # it drops the privilege itself
     inner='exec "$0" "$@"'
     unshare -rn true 2>/dev/null || { echo "in_netns: two hosts need user namespaces (unshare -rn refused here)" >&2; exit 2; } ;;
  *) echo "in_netns: AFM_HOSTS must be 1 or 2, not '$AFM_HOSTS'" >&2; exit 2 ;;
esac
if unshare -rn true 2>/dev/null; then
  AFM_NETNS_MODE=rootless exec unshare -rn sh -c "$inner" "$drop" "$@"
elif [ "$(id -u)" = 0 ] && unshare -n true 2>/dev/null; then
  AFM_NETNS_MODE=root exec unshare -n sh -c "$inner" "$drop" "$@"
else
  echo "in_netns: cannot create a network namespace here (unshare -rn refused and not root);" \
       "the bus must not run in the host's namespace" >&2
  exit 2
fi
