#!/usr/bin/env bash
# A user of its own for every run (issue 46, item 2; docs/design.md, "Least
# privilege"): the range of uids (and gids, the same numbers) the machine
# reserves for the bench's runs, and which of them are free.
#   run/run_uid.sh state-dir   (root) /run/afm, made 0755 and root's if
#                                missing; refused (exit 2, one line) if it
#                                is a link, not a folder, not root's or open
#                                to others' writes. The build lock and the
#                                runs' leases live there.
#   run/run_uid.sh range       "FIRST COUNT" of the range: the afm-runs
#                                line of /etc/subuid (and the same of
#                                /etc/subgid); exit 3 when none is reserved
#   run/run_uid.sh reserve     (root; tools/setup.sh) reserves the range
#                                when none is: the first block of COUNT ids
#                                from FIRST_TRY up that no other line of
#                                /etc/subuid or /etc/subgid, no user and no
#                                group holds
#   run/run_uid.sh free [N]    up to N (8) uids of the range, from a random
#                                start, that no process holds (real,
#                                effective, saved or filesystem uid or gid,
#                                /proc) and that own no file in the places a
#                                run writes (/tmp, /var/tmp, /dev/shm): for
#                                root, by the record of uids used
#                                (/run/afm/uids-used, below), for others by
#                                walking those places
#   run/run_uid.sh rescan      (root) walks those places anew into the record
#   run/run_uid.sh lease [N]   (root) leases N (1) free uids: a lock on
#                                /run/afm/uid-UID.lock each, taken without
#                                waiting; prints them, one a line, then holds
#                                the locks until its stdin ends (the caller
#                                closes the pipe, or dies). SIGINT, SIGTERM
#                                and SIGHUP are ignored: the caller ends the
#                                lease once it has given the uids' folders
#                                back; the lock files are removed as it
#                                ends. Refused (exit 2, one line, nothing
#                                printed on stdout) when fewer are free.
# The one owner of the lease: run/in_netns.sh leases one uid for a run's
# life, analysis/sweep.py one for a sweep's client and scheduler and one per
# worker.
set -euo pipefail
NAME=afm-runs
COUNT=65536
FIRST_TRY=1879048192   # 0x70000000: far above the ids of users and of the usual subordinate ranges
die() { echo "run_uid: $*" >&2; exit 2; }

state_dir() {
  local d=/run/afm
  [ "$(id -u)" = 0 ] || die "state-dir: root's alone"
  [ -e "$d" ] || [ -L "$d" ] || mkdir -m 0755 "$d"
  [ ! -L "$d" ] && [ -d "$d" ] || die "$d is not a folder (a link?): remove it"
  [ "$(stat -c %u -- "$d")" = 0 ] || die "$d is uid $(stat -c %u -- "$d")'s, not root's: remove it"
  (( (8#$(stat -c %a -- "$d") & 8#022) == 0 )) || die "$d is mode $(stat -c %a -- "$d"): others may write in it"
  echo "$d"
}

range() {
  local line
  line=$(grep -m1 "^$NAME:" /etc/subuid 2>/dev/null) || return 3
  IFS=: read -r _ first count <<< "$line"
  grep -qx "$NAME:$first:$count" /etc/subgid 2>/dev/null || die "/etc/subgid: no line '$NAME:$first:$count' to match /etc/subuid's"
  echo "$first $count"
}

# 0 when [first, first+count) meets none of the ids already taken.
overlaps_none() {
  local first=$1 count=$2
  awk -F: -v a="$first" -v b="$((first + count))" -v me="$NAME" '
    FILENAME ~ /sub[ug]id$/ && $1 != me && $2 < b && $2 + $3 > a { bad = 1 }
    FILENAME ~ /(passwd|group)$/ && $3 >= a && $3 < b { bad = 1 }
    END { exit bad }' /etc/subuid /etc/subgid /etc/passwd /etc/group 2>/dev/null
}

reserve() {
  [ "$(id -u)" = 0 ] || die "reserve: root's alone"
  range >/dev/null 2>&1 && return 0
  touch /etc/subuid /etc/subgid
  local first=$FIRST_TRY
  while ! overlaps_none "$first" "$COUNT"; do
    first=$((first + COUNT))
    [ "$first" -lt 4026531840 ] || die "reserve: no free block of $COUNT ids found"
  done
  echo "$NAME:$first:$COUNT" >> /etc/subuid
  echo "$NAME:$first:$COUNT" >> /etc/subgid
  echo "$first $COUNT"
}

# The uids of the range that own a file where a run writes, by walking
# /tmp, /var/tmp and /dev/shm (its cost grows with what they hold: 0.6 s
# for 240k files).
owners_of_files() {
  local first=$1 count=$2
  { find /tmp /var/tmp /dev/shm -xdev -printf '%U\n%G\n' 2>/dev/null || true; } \
    | awk -v a="$first" -v b="$((first + count))" '$1 >= a && $1 < b' | sort -un
}

# Root's record of the uids that may own such a file (STATE/uids-used):
# its first line the boot it was made in, then the owners one walk found
# and every uid leased since, a line each. A run's user can leave files
# only under a uid it was leased, so the record stays a superset of the
# owners without walking again; it is walked anew when missing, made in
# another boot, or when too few uids outside it remain. A file root
# chowns into the range is seen at the next walk (run/run_uid.sh rescan).
used_record() { echo "$(state_dir)/uids-used"; }

rescan() {
  local first=$1 count=$2 rec tmp
  rec=$(used_record); tmp="$rec.$$"
  # a uid leased now is held by its lock until its lease ends, and marked
  # again then (lease), so the walk need not see it
  { cat /proc/sys/kernel/random/boot_id
    owners_of_files "$first" "$count"
  } > "$tmp"
  mv -f -- "$tmp" "$rec"
}

# The record's uids (walking first if it is missing or of another boot).
used_uids() {
  local first=$1 count=$2 rec
  rec=$(used_record)
  if [ -L "$rec" ] || [ ! -f "$rec" ] || [ "$(head -n1 -- "$rec")" != "$(cat /proc/sys/kernel/random/boot_id)" ]; then
    rm -f -- "$rec"; rescan "$first" "$count"
  fi
  tail -n +2 -- "$rec"
}

# Up to WANT uids from a random start that are in none of the lists on stdin.
pick_free() {
  local first=$1 count=$2 want=$3 start
  start=$(( $(od -An -N4 -tu4 /dev/urandom) % count ))
  awk -v a="$first" -v c="$count" -v s="$start" -v w="$want" '
    NF { h[$1] = 1 }
    END { for (i = 0; i < c && n < w; i++) { u = a + (s + i) % c; if (!(u in h)) { print u; n++ } } }'
}

free() {
  local want=${1:-8} first count held got lk
  read -r first count < <(range) || { echo "run_uid: no range reserved (tools/setup.sh reserves $NAME in /etc/subuid)" >&2; exit 3; }
  held=$(awk '/^(Uid|Gid):/ { for (i = 2; i <= 5; i++) print $i }' /proc/[0-9]*/status 2>/dev/null || true)
  if [ "$(id -u)" != 0 ]; then   # no record to read: walk
    printf '%s\n%s\n' "$held" "$(owners_of_files "$first" "$count")" | pick_free "$first" "$count" "$want"
    return
  fi
  exec {lk}>>"$(state_dir)/uids-used.lock"; flock "$lk"
  got=$(printf '%s\n%s\n' "$held" "$(used_uids "$first" "$count")" | pick_free "$first" "$count" "$want")
  if [ "$(printf '%s' "$got" | grep -c .)" -lt "$want" ]; then   # the record has filled: walk again
    rescan "$first" "$count"
    got=$(printf '%s\n%s\n' "$held" "$(used_uids "$first" "$count")" | pick_free "$first" "$count" "$want")
  fi
  exec {lk}>&-
  [ -z "$got" ] || printf '%s\n' "$got"
}

# Adds UIDS (arguments) to the record of uids that may own files.
mark_used() {
  local rec lk
  rec=$(used_record)
  exec {lk}>>"$(state_dir)/uids-used.lock"; flock "$lk"
  [ -f "$rec" ] && [ ! -L "$rec" ] && printf '%s\n' "$@" >> "$rec"
  exec {lk}>&-
}

lease() {
  local want=${1:-1} state n fd got=()
  [[ $want =~ ^[1-9][0-9]*$ ]] || die "lease: how many uids? (a whole number >= 1, not '$want')"
  range >/dev/null || { echo "run_uid: no range reserved (tools/setup.sh reserves $NAME in /etc/subuid)" >&2; exit 3; }
  state=$(state_dir)
  for n in $(free $((want + 16))); do
    : >> "$state/uid-$n.lock"
    exec {fd}<"$state/uid-$n.lock"
    # held, and still the file of that name (a lease that ended removes its
    # file: a lock taken on the removed one leases nothing)
    if flock -n "$fd" && [ "$(stat -L -c %i "/proc/self/fd/$fd")" = "$(stat -c %i -- "$state/uid-$n.lock" 2>/dev/null)" ]; then
      got+=("$n"); [ ${#got[@]} -lt "$want" ] || break
    else
      exec {fd}<&-
    fi
  done
  [ ${#got[@]} = "$want" ] || die "refused: $want uid(s) wanted, ${#got[@]} free in the range for runs ($(range)): every other one is leased, held by a process or owns a file in /tmp, /var/tmp or /dev/shm"
  mark_used "${got[@]}"
  trap '' INT TERM HUP
  printf '%s\n' "${got[@]}"
  exec >&-
  while IFS= read -r _; do :; done
  # the lease ends: its files go while still held (so /run/afm keeps no
  # file a lease per run), the locks with this process
  mark_used "${got[@]}"   # a walk made during the lease may have missed its files
  for n in "${got[@]}"; do rm -f -- "$state/uid-$n.lock"; done
}

case "${1:-}" in
  state-dir) state_dir ;;
  range) range ;;
  reserve) reserve ;;
  free) shift; free "$@" ;;
  rescan) [ "$(id -u)" = 0 ] || die "rescan: root's alone"; read -r f c < <(range) || exit 3; rescan "$f" "$c" ;;
  lease) shift; lease "$@" ;;
  *) die "usage: run/run_uid.sh state-dir|range|reserve|free [N]|rescan|lease [N]" ;;
esac
