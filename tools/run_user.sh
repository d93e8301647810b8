#!/usr/bin/env bash
# The run's user (issue 35, least privilege; docs/design.md, "Least
# privilege"): who a run's processes are when it was started as root, and
# the folders handed to that user for the run and given back after it.
#   tools/run_user.sh id             "UID GID" of the run's user (started as
#                                    another user: that user's own)
#   tools/run_user.sh reach PATH...  exit 0 if the run's user can reach each
#                                    PATH (search every folder above it, read
#                                    it); else 3 and one line naming the folder
#   tools/run_user.sh give DIR...    (root) makes each DIR, checks the run's
#                                    user reaches it, and hands DIR and all it
#                                    holds to the run's user
#   tools/run_user.sh take DIR...    gives each DIR and all it holds back to
#                                    whoever runs this (uid and gid)
# AFM_RUN_USER=NAME|UID[:GID] names the run's user; default nobody. The run's
# user must own nothing else of value: for the run's life it owns the run's
# folders. AFM_RUN_USER=root keeps uid 0 (still without capabilities).
set -euo pipefail
die() { echo "run_user: $*" >&2; exit 2; }
[ $# -ge 1 ] || die "usage: tools/run_user.sh id|reach PATH...|give DIR...|take DIR..."

# uid and gid of AFM_RUN_USER, or of the caller when it is not root.
run_ids() {
  if [ "$(id -u)" != 0 ]; then echo "$(id -u) $(id -g)"; return; fi
  local who=${AFM_RUN_USER:-nobody}
  if [[ $who =~ ^[0-9]+(:[0-9]+)?$ ]]; then
    echo "${who%%:*} $([[ $who == *:* ]] && echo "${who#*:}" || echo "${who%%:*}")"
  else
    id -u "$who" >/dev/null 2>&1 || die "AFM_RUN_USER: no such user '$who' (a name, or UID[:GID])"
    echo "$(id -u "$who") $(id -g "$who")"
  fi
}
read -r uid gid < <(run_ids)
as_run_user() { setpriv --reuid="$uid" --regid="$gid" --clear-groups -- "$@"; }

# Names the first folder above PATH (or PATH itself) the run's user cannot
# search or read; silent and 0 when it reaches PATH.
reach() {
  local p=$1 up=() d
  [ -e "$p" ] || die "reach: no such file or folder: $p"
  p=$(realpath -- "$p")
  d=$p
  while [ "$d" != / ]; do d=$(dirname "$d"); up=("$d" "${up[@]}"); done
  local miss
  miss=$(as_run_user sh -c 'for d do [ -x "$d" ] || { echo "$d"; exit; }; done' sh "${up[@]}")
  if [ -z "$miss" ] && ! as_run_user test -r "$p"; then miss=$p; fi
  [ -z "$miss" ] && return 0
  echo "run_user: the run's user (uid $uid) cannot reach $p: $miss is mode $(stat -c %a "$miss"), owned by $(stat -c %U "$miss")" >&2
  return 3
}

give() {
  local d
  [ "$(id -u)" = 0 ] || die "give: only root hands folders to the run's user"
  for d in "$@"; do
    mkdir -p -- "$d"
    d=$(realpath -- "$d")
    case "$d" in /|/root|/home|/tmp|/usr|/etc|/var|/proc|/sys|/dev|"$HOME") die "give: will not hand '$d' to the run's user (a run's folder, not a system one)" ;; esac
    reach "$d" || return 3
    chown -R -- "$uid:$gid" "$d"
  done
}

take() {
  local d
  for d in "$@"; do
    [ -e "$d" ] && chown -R -- "$(id -u):$(id -g)" "$d"
  done
  return 0
}

case "$1" in
  id) echo "$uid $gid" ;;
  reach) shift; for p in "$@"; do reach "$p" || exit 3; done ;;
  give) shift; give "$@" ;;
  take) shift; take "$@" ;;
  *) die "unknown command '$1' (id, reach, give, take)" ;;
esac
