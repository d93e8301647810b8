#!/usr/bin/env bash
# The run's user (issue 35, least privilege; docs/design.md, "Least
# privilege"): who a run's processes are when it was started as root, and
# the folders handed to that user for the run and given back after it.
#   run/run_user.sh id             "UID GID" of the run's user (started as
#                                    another user: that user's own)
#   run/run_user.sh reach PATH...  exit 0 if the run's user can reach each
#                                    PATH (search every folder above it, read
#                                    it); else 3 and one line naming the folder
#   run/run_user.sh give [--reach PATH]... DIR...
#                                    (root) makes each DIR, checks the run's
#                                    user reaches each PATH and the folders
#                                    above each DIR (DIR itself becomes
#                                    theirs), and that an existing DIR holds
#                                    nothing of a third user's; then hands
#                                    DIR and all it holds to the run's user
#                                    (chown -R -P: no link followed, a link
#                                    itself changed), and prints "UID GID"
#                                    of that user (with AFM_RUN_USER=root:
#                                    nothing to do, "0 0"). Refused: nothing
#                                    has changed hands.
#   run/run_user.sh take DIR...    gives each DIR and all it holds back to
#                                    whoever runs this (uid and gid), through
#                                    analysis/safefs.py (take): folder by
#                                    folder from the top, none followed if a
#                                    link; every link, pipe, socket, device
#                                    and hard-linked file the run's user
#                                    left is removed and named on stderr,
#                                    group and other write taken away
# AFM_RUN_USER=NAME|UID[:GID] names the run's user; default nobody. The run's
# user must own nothing else of value: for the run's life it owns the run's
# folders. AFM_RUN_USER=root keeps uid 0 (still without capabilities).
set -euo pipefail
die() { echo "run_user: $*" >&2; exit 2; }
[ $# -ge 1 ] || die "usage: run/run_user.sh id|reach PATH...|give DIR...|take DIR..."

# uid and gid of AFM_RUN_USER, or of the caller when it is not root.
run_ids() {
  if [ "$(id -u)" != 0 ]; then echo "$(id -u) $(id -g)"; return; fi
  local who=${AFM_RUN_USER:-nobody}
  if [[ $who =~ ^[0-9]+(:[0-9]+)?$ ]]; then
    echo "${who%%:*} $([[ $who == *:* ]] && echo "${who#*:}" || echo "${who%%:*}")"
  else
    local u
    u=$(id -u "$who" 2>/dev/null) || die "AFM_RUN_USER: no such user '$who' (a name, or UID[:GID])"
    echo "$u $(id -g "$who")"
  fi
}
read -r uid gid < <(run_ids)
as_run_user() { setpriv --reuid="$uid" --regid="$gid" --clear-groups -- "$@"; }

# Silent and 0 when the run's user reaches each PATH (searches every folder
# above it and reads it; given as above:PATH, only searches the folders
# above it); else 3 and one line naming the first folder (or PATH) it
# cannot. One setpriv for them all.
reach() {
  local checks=() p d above
  for p in "$@"; do
    above=0; [[ $p != above:* ]] || { above=1; p=${p#above:}; }
    [ -e "$p" ] || die "reach: no such file or folder: $p"
    p=$(realpath -- "$p")
    local up=()
    d=$p
    while [ -n "$d" ]; do d=${d%/*}; up=("${d:-/}" "${up[@]}"); done
    checks+=("${up[@]/#/x:}")
    [ $above = 1 ] || checks+=("r:$p")
  done
  local miss
  miss=$(as_run_user sh -c 'for c do case $c in x:*) [ -x "${c#x:}" ] ;; r:*) [ -r "${c#r:}" ] ;; esac || { echo "$c"; exit; }; done' \
         sh "${checks[@]}")
  [ -z "$miss" ] && return 0
  miss=${miss#?:}
  for p in "$@"; do   # the path it stops
    p=$(realpath -- "${p#above:}")
    [[ $p == "$miss" || $p == "${miss%/}"/* ]] && break
  done
  echo "run_user: the run's user (uid $uid) cannot reach $p: $miss is mode $(stat -c %a "$miss"), owned by $(stat -c %U "$miss")" >&2
  return 3
}

# give [--reach PATH]... DIR...: see the header.
give() {
  local paths=() dirs=() d
  while [ $# -gt 0 ]; do
    case "$1" in --reach) paths+=("$2"); shift 2 ;; *) dirs+=("$1"); shift ;; esac
  done
  [ "$uid" != 0 ] || { echo "$uid $gid"; return 0; }
  [ "$(id -u)" = 0 ] || die "give: only root hands folders to the run's user"
  for d in "${dirs[@]}"; do
    mkdir -p -- "$d"
    d=$(realpath -- "$d")
    case "$d" in /|/root|/home|/tmp|/usr|/etc|/var|/proc|/sys|/dev|"$HOME") die "give: will not hand '$d' to the run's user (a run's folder, not a system one)" ;; esac
    local other
    other=$(find -P "$d" ! -uid 0 ! -uid "$uid" -print -quit)
    [ -z "$other" ] || die "give: will not hand $d to the run's user: $other is uid $(stat -c %u -- "$other")'s (neither root's nor the run's)"
    paths+=("above:$d")
  done
  [ ${#paths[@]} = 0 ] || reach "${paths[@]}" || return 3
  [ ${#dirs[@]} = 0 ] || chown -R -P -- "$uid:$gid" "${dirs[@]}"
  echo "$uid $gid"
}

# take DIR...: see the header (stdlib Python alone: no venv needed). The
# system's interpreter, isolated (-I: no PYTHONPATH, user site or working
# folder on its path; -S: no site packages), not whichever python3 comes
# first on root's PATH (a version manager's shim costs 0.2 s a call).
take() {
  local py=/usr/bin/python3
  [ -x "$py" ] || py=$(command -v python3) || die "take: no python3"
  [ $# = 0 ] || "$py" -I -S "$(dirname "$0")/../analysis/safefs.py" take "$@"
}

case "$1" in
  id) echo "$uid $gid" ;;
  reach) shift; reach "$@" || exit 3 ;;
  give) shift; give "$@" ;;
  take) shift; take "$@" ;;
  *) die "unknown command '$1' (id, reach, give, take)" ;;
esac
