#!/usr/bin/env bash
# Runs a command in a fresh, private network namespace whose loopback is up
# and carries the multicast route (design.md, "The bus"), so no LCM datagram
# of the run can leave through the machine's network interface.
#   run/in_netns.sh CMD [ARGS...]
# AFM_HOSTS=2: two namespaces joined by a veth pair instead, the bus across
# it (run/two_hosts.sh, docs/hosts.md); it needs user namespaces.
#
# A run's processes need no root (design.md, "Least privilege"). Once the
# namespace is set up, the command runs through run/drop_caps.sh: no
# capabilities, and, started as root, as the run's user
# (run/run_user.sh: nobody unless AFM_RUN_USER says otherwise).
# - Not root: a user namespace (unshare -rn) mapping the caller to root, who
#   sets up the loopback; the command runs as the caller.
# - Root: a user namespace mapping root and the run's user each to itself
#   (written here: unshare's own --map-users needs newuidmap); where user
#   namespaces are refused (a chroot), unshare -n. Root in it sets up the
#   loopback, then the command runs as the run's user. Before, the folders
#   the run writes are handed to that user (run/run_user.sh give): each
#   `--out DIR` among the arguments, the folders in AFM_RUN_WRITES
#   (colon-separated: for commands that name them otherwise) and
#   AFM_LINK_DIR; after, whatever the outcome (a signal too, which is passed
#   on to the command), they are given back to root (by the last run that
#   holds them; run_user.sh take removes and names every link, pipe, device
#   and hard link left in them), and those made for the run and left empty
#   are removed. When the command is afm_launch (or holds it among its
#   arguments), it is first asked (--check) whether it takes --out DIR: a
#   folder it refuses is never handed over. If the run's user cannot reach
#   the folders or CMD, the run is refused with one line on stderr (exit 2),
#   unless AFM_ALLOW_UID_0=1 (./afm run --allow-uid-0): then it keeps uid 0
#   (still without capabilities).
#   Started as root without AFM_RUN_USER, the run's user is a uid leased for
#   the run's life from the range run/run_uid.sh names (below); files the
#   run reads that root made (AFM_RUN_FILES, colon-separated: the live
#   view's hand pipe) are that user's for the run's life.
# Exports AFM_NETNS_MODE (run.json "netns"): rootless (not root); user:UID
# or root:UID (root, in a user namespace or not, the run as uid UID), then
# " lease:FIRST:COUNT" when UID was leased and " limits:..." (the rlimits,
# run/drop_caps.sh --limits).
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: run/in_netns.sh CMD [ARGS...]" >&2; exit 2; }
command -v unshare >/dev/null || { echo "in_netns: unshare not found (util-linux)" >&2; exit 2; }
command -v ip >/dev/null || { echo "in_netns: ip not found (iproute2; run ./afm setup)" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
drop="$here/drop_caps.sh"
inner='ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$0" "$@"'
case "${AFM_HOSTS:-1}" in
  1) ;;
  2) drop="$here/two_hosts.sh"   # it drops the privilege itself
     inner='exec "$0" "$@"'
     unshare -rn true 2>/dev/null || { echo "in_netns: two hosts need user namespaces (unshare -rn refused here)" >&2; exit 2; } ;;
  *) echo "in_netns: AFM_HOSTS must be 1 or 2, not '$AFM_HOSTS'" >&2; exit 2 ;;
esac

unset AFM_RUN_UID AFM_RUN_GID   # this script alone names the run's user to drop_caps.sh
if [ "$(id -u)" != 0 ]; then
  unshare -rn true 2>/dev/null || { echo "in_netns: cannot create a network namespace here (unshare -rn refused and not root);" \
                                         "the bus must not run in the host's namespace" >&2; exit 2; }
  AFM_NETNS_MODE=rootless exec unshare -rn sh -c "$inner" "$drop" "$@"
fi

# The folders the run writes.
writes=() prev=""
for a in "$@"; do
  [ "$prev" = --out ] && writes+=("$a")
  case "$a" in --out=*) writes+=("${a#--out=}") ;; esac
  prev=$a
done
IFS=: read -r -a extra <<< "${AFM_RUN_WRITES:-}"
for d in "${extra[@]}" "${AFM_LINK_DIR:-}"; do [ -z "$d" ] || writes+=("$d"); done
unset AFM_RUN_WRITES

# Those that do not exist yet are made for the run to write in; what of
# them is still empty after it is removed again (a refused scene leaves
# nothing): "LEAF|TOP", TOP the highest folder made for it.
made=()
for d in "${writes[@]}"; do
  [ ! -e "$d" ] || continue
  top=$d
  while [ ! -e "$(dirname "$top")" ]; do top=$(dirname "$top"); done
  made+=("$d|$top")
done
remove_made_empty() {   # what was made for the run and is still empty, up to the highest folder made
  local m leaf top
  for m in "${made[@]}"; do
    leaf=${m%|*} top=${m#*|}
    while rmdir "$leaf" 2>/dev/null && [ "$leaf" != "$top" ]; do leaf=$(dirname "$leaf"); done
  done
}

# A launcher is asked first whether it takes its --out (a folder that holds
# something not a run's is refused before anything changes hands).
for i in $(seq 1 $#); do
  if [ "$(basename -- "${!i}")" = afm_launch ]; then
    "${@:i}" --check --quiet || exit $?
    break
  fi
done

# A user of its own (issue 46, item 2): started as root without
# AFM_RUN_USER, the run leases a uid (and the same gid) of the range
# run/run_uid.sh names, one no process holds and that owns no file where a
# run writes (run/run_uid.sh lease: a lock on /run/afm/uid-UID.lock, held
# by that command until its input ends: this script holds the pipe until the
# folders are given back, and the run inherits it, so a process of the run
# that outlives this script keeps the lease too). Without a range reserved (tools/setup.sh reserves it), the
# run's user is nobody, the documented fallback (AFM_RUN_USER=nobody).
# A leased user is in no /etc/passwd: HOME (and MPLCONFIGDIR, XDG_CACHE_HOME)
# are a scratch folder of the run's, handed over with the others and
# removed after.
lease="" home=""
if [ -z "${AFM_RUN_USER:-}" ] && "$here/run_uid.sh" range >/dev/null 2>&1; then
  coproc LEASE { exec "$here/run_uid.sh" lease 1; }
  read -r lease <&"${LEASE[0]}" || true
  [ -n "$lease" ] || exit 2   # run/run_uid.sh said why, in one line
  export AFM_RUN_USER=$lease:$lease
  home=$(mktemp -d "${TMPDIR:-/tmp}/afm-run-home-XXXXXX")
  writes+=("$home")
fi

# The run's user must reach CMD (a path) and drop_caps.sh, and each folder.
reach=(--reach "$here/drop_caps.sh")
[[ $1 != */* ]] || reach+=(--reach "$1")
# If it cannot (give exits 3), the run is refused in one line, whatever
# stderr is, as when give refuses a folder (exit 2); with
# AFM_ALLOW_UID_0=1 it is made as it is made without root (unshare -rn: root
# in a user namespace of its own, no capabilities once drop_caps.sh has run),
# run.json's netns says "rootless:kept-uid-0", and the reason goes to stderr
# when that is a terminal (or AFM_PRIVILEGE_WARNINGS=1). Nothing was handed
# over (give checks before it chowns), so nothing is taken back.
gave=0
ids=$("$here/run_user.sh" give "${reach[@]}" "${writes[@]}" 2>&1) || gave=$?
if [ "$gave" != 0 ]; then
  why=${ids#run_user: }
  why=${why//$'\n'/; }
  remove_made_empty
  [ -z "$home" ] || rm -rf -- "$home"
  [ "$gave" = 3 ] || { echo "in_netns: refused: $why" >&2; exit 2; }   # not a question of reach: no uid 0 either
  if [ "${AFM_ALLOW_UID_0:-0}" != 1 ]; then
    echo "in_netns: refused: the run would keep uid 0: $why; put the checkout and the run's folders where the run's user reaches them, or allow it (./afm run --allow-uid-0, AFM_ALLOW_UID_0=1; docs/design.md, \"Least privilege\")" >&2
    exit 2
  fi
  if [ -t 2 ] || [ "${AFM_PRIVILEGE_WARNINGS:-0}" = 1 ]; then
    echo "in_netns: warning: the run keeps uid 0 (without capabilities, as AFM_ALLOW_UID_0=1 allows): $why (docs/design.md, \"Least privilege\")" >&2
  fi
  if unshare -rn true 2>/dev/null; then
    AFM_NETNS_MODE=rootless:kept-uid-0 exec unshare -rn sh -c "$inner" "$drop" "$@"
  fi
  ids="0 0"
fi
read -r uid gid <<< "$ids"
export AFM_RUN_UID=$uid AFM_RUN_GID=$gid
[ -z "$home" ] || export HOME=$home MPLCONFIGDIR=$home/.matplotlib XDG_CACHE_HOME=$home/.cache USER=afm-run-$lease LOGNAME=afm-run-$lease
# Files (not folders) the run reads that root made (AFM_RUN_FILES,
# colon-separated: the live view's hand pipe), the run's user's for its life.
IFS=: read -r -a files <<< "${AFM_RUN_FILES:-}"
unset AFM_RUN_FILES
for f in "${files[@]}"; do [ -z "$f" ] || chown -h -- "$uid:$gid" "$f"; done
# run.json "netns": the uid, the lease, the limits (run/drop_caps.sh --limits)
mode_tail=" limits:$("$here/drop_caps.sh" --limits)"
[ -z "$lease" ] || mode_tail=" lease:$("$here/run_uid.sh" range | tr ' ' ':')$mode_tail"
# Each folder held (a shared lock) for the run's life: two runs given one
# folder (the second one refused by the launcher's own lock) give it back
# once, when the last of them ends, never under the other's feet.
locks=()
for d in "${writes[@]}"; do
  if [ -d "$d" ]; then exec {fd}<"$d"; flock -s "$fd"; locks+=("$fd"); else locks+=(""); fi   # (not made: uid 0 keeps it)
done

# The command, in its namespace, with signals passed on; then the folders
# given back.
child=""
pass_on() { [ -z "$child" ] || kill -s "$1" "$child" 2>/dev/null || true; }
for sig in INT TERM HUP; do trap "pass_on $sig" "$sig"; done
# in the background so that this shell may pass signals on, yet as if in the
# foreground: SIGINT and SIGQUIT not ignored, stdin the caller's
fg="env --default-signal=INT,QUIT"
if unshare -U true 2>/dev/null; then
  # Its root says it is in (fd 4), then waits (fd 3) until its maps are written.
  pipes=$(mktemp -d "${TMPDIR:-/tmp}/afm-netns-XXXXXX")
  mkfifo -m 0600 "$pipes/in" "$pipes/go"
  exec 3<>"$pipes/go" 4<>"$pipes/in"
  rm -rf "$pipes"
  AFM_NETNS_MODE="user:$uid$mode_tail" $fg unshare -U -n sh -c "echo >&4 && read -r _ <&3 && exec 3<&- 4>&- && $inner" "$drop" "$@" <&0 &
  child=$!
  # one write() each, as the kernel wants (printf writes line by line)
  maps() { local m="0 0 1"; [ "$2" = 0 ] || m+=$'\n'"$2 $2 1"; cat <<< "$m" > "/proc/$child/$1_map"; }
  { read -r -t 10 _ <&4 && maps uid "$uid" && maps gid "$gid"; } || echo "in_netns: cannot write the user namespace's maps of pid $child" >&2
  echo go >&3
  exec 3>&- 4>&-
else
  unshare -n true 2>/dev/null || { echo "in_netns: cannot create a network namespace here (unshare -n refused as root)" >&2; exit 2; }
  AFM_NETNS_MODE="root:$uid$mode_tail" $fg unshare -n sh -c "$inner" "$drop" "$@" <&0 &
  child=$!
fi
rc=0
while :; do
  wait "$child" && rc=0 || rc=$?
  kill -0 "$child" 2>/dev/null || break   # a signal ended wait, not the command
done
for i in "${!writes[@]}"; do
  if [ -n "${locks[$i]}" ] && flock -n -x "${locks[$i]}"; then "$here/run_user.sh" take "${writes[$i]}"; fi
done
for f in "${files[@]}"; do [ -z "$f" ] || chown -h -- "$(id -u):$(id -g)" "$f" 2>/dev/null || true; done
[ -z "$home" ] || rm -rf -- "$home"
remove_made_empty
exit "$rc"
