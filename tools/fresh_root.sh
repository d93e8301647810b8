#!/usr/bin/env bash
# The README's promise on a fresh machine, tried by hand (not by the suite):
# a pristine Debian bookworm root made with mmdebstrap (minbase: apt and the
# essential packages, no Java, no git, no Python), this tree copied in
# without .git, build/, .venv/ or runs/ (as a tree got as an archive is),
# then ./afm test run in it as root (./afm installs what is missing and
# builds first). Run it before each stop that changes tools/setup.sh.
#   tools/fresh_root.sh [--root DIR] [--keep] [--reuse] [--only REGEX]
#     --root DIR     where the root is made (default /var/tmp/afm-fresh-root;
#                    made anew: an existing DIR is refused unless it is one
#                    this script made, which is then removed first)
#     --keep         leave the root in place afterwards (default: removed)
#     --reuse        a root this script made and kept: copy the tree in anew
#                    (its build/ and .venv/ go) but keep its packages
#     --only REGEX   ./afm build, then ctest -R REGEX in the root instead of
#                    the whole ./afm test (e.g. --only 'spy|contract')
# Needs root, mmdebstrap (apt-get install mmdebstrap) and Debian's mirror
# (the one in /etc/apt's sources). The host's own added certificate
# authorities (/usr/local/share/ca-certificates, where a network that
# inspects TLS puts its CA) are trusted in the root too, and pip is
# pointed at the root's bundle: nothing else of the host goes in.
# Exit status: ./afm test's (or ctest's);
# 2 when the root could not be made.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
root=/var/tmp/afm-fresh-root; keep=0; reuse=0; only=""
die() { echo "fresh_root: $*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case "$1" in
    --root) root=${2:?--root needs a folder}; shift 2 ;;
    --keep) keep=1; shift ;;
    --reuse) reuse=1; shift ;;
    --only) only=${2:?--only needs a ctest regex}; shift 2 ;;
    -h|--help) sed -n '2,25p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown option '$1' (tools/fresh_root.sh [--root DIR] [--keep] [--reuse] [--only REGEX])" ;;
  esac
done
[ "$(id -u)" = 0 ] || die "needs root (mmdebstrap, chroot and the runs' network namespaces)"
command -v mmdebstrap >/dev/null || die "mmdebstrap missing: apt-get install mmdebstrap"
marker=.afm-fresh-root
if [ -e "$root" ]; then
  [ -e "$root/$marker" ] || die "$root exists and is not a root this script made: choose another --root"
  findmnt -R -n -o TARGET "$root" >/dev/null 2>&1 && die "$root has mounts still under it: umount -R $root first"
  if [ $reuse = 1 ]; then rm -rf --one-file-system "$root/src/afm"; else rm -rf --one-file-system "$root"; fi
elif [ $reuse = 1 ]; then
  die "--reuse: no root in $root (run once with --keep first)"
fi

if [ ! -e "$root/$marker" ]; then
  echo "fresh_root: making a bookworm root in $root (mmdebstrap, minbase)" >&2
  mmdebstrap --variant=minbase --include=ca-certificates bookworm "$root" >&2 || die "mmdebstrap failed"
  touch "$root/$marker"
fi
if compgen -G "/usr/local/share/ca-certificates/*.crt" >/dev/null; then
  cp /usr/local/share/ca-certificates/*.crt "$root/usr/local/share/ca-certificates/"
  chroot "$root" update-ca-certificates >/dev/null || die "update-ca-certificates failed in the root"
fi
mkdir -p "$root/src/afm"
echo "fresh_root: copying $top into $root/src/afm without .git, build/, .venv/, runs/" >&2
tar -C "$top" --exclude=./.git --exclude=./build --exclude=./.venv --exclude=./runs -cf - . | tar -C "$root/src/afm" -xf -

cleanup() {
  if [ $keep = 0 ]; then rm -rf --one-file-system "$root"; else echo "fresh_root: kept $root" >&2; fi
}
trap cleanup EXIT
cp /etc/resolv.conf "$root/etc/resolv.conf"

if [ -n "$only" ]; then
  body="./afm build && ctest --test-dir build/main -R '$only' --output-on-failure"
else
  body="./afm test"
fi
echo "fresh_root: in the root: $body" >&2
# Into the root by pivot_root in a mount namespace of its own, not chroot:
# the kernel refuses a user namespace to a chrooted process (unshare -r:
# EPERM), which the runs' own namespaces need, and under chroot / is no
# mount point (unshare --propagation fails). The mounts below live and die
# with that namespace: nothing is left mounted on the host.
set +e
unshare --mount --propagation private -- /bin/bash -c '
set -e
root=$1 body=$2 term=$3
mount --bind "$root" "$root"
mount -t proc proc "$root/proc"
mount --rbind /sys "$root/sys"
mount --rbind /dev "$root/dev"
mount -t tmpfs tmpfs "$root/dev/shm"
mount -t tmpfs tmpfs "$root/run"
mount -t tmpfs -o size=8g tmpfs "$root/tmp"
mkdir -p "$root/.oldroot"
cd "$root"
pivot_root . .oldroot
umount -l /.oldroot
cd /src/afm
exec /usr/bin/env -i HOME=/root TERM="$term" PATH=/usr/sbin:/usr/bin:/sbin:/bin \
  PIP_CERT=/etc/ssl/certs/ca-certificates.crt /bin/bash -c "$body"
' fresh_root "$root" "$body" "${TERM:-dumb}"
status=$?
set -e
echo "fresh_root: exit $status" >&2
exit $status
