"""A run folder's files, as root may touch them (issue 46; docs/design.md,
"Least privilege"): the one owner of how the bench opens, writes and gives
back what a run's user had in hand.

While a run runs, its folder is the run's user's, who may plant anything in
it: a symbolic link to a root-only file, a named pipe, a device, a hard link
to a file of its own elsewhere, a folder open to all. Whatever root does
with the folder afterwards goes through here:

  open_dir(path)            the folder, as a descriptor (O_DIRECTORY |
                            O_NOFOLLOW: the folder itself not a link)
  open_file(dfd, rel)       a file under it, every component opened from the
                            one above with O_NOFOLLOW, the last with
                            O_NONBLOCK, and refused unless it is a regular
                            file (a pipe never blocks the reader)
  read_bytes(dfd, rel)      its bytes (at most `limit`)
  checked(dfd, rel)         the path of a file that was checked so, for a
                            reader that takes a path (afm_replay, afmlog):
                            /proc/self/fd/N/rel (the folder as opened)
  atomic(dfd, rel)          the one atomic writer: a binary file to write
                            `rel` through (a context manager): a temporary
                            file this process created in the same folder
                            (O_CREAT | O_EXCL | O_NOFOLLOW in the folder's
                            descriptor, a name of its own), fsync'd, then
                            renamed over `rel` and the folder fsync'd: a
                            reader sees the old file whole or the new one
                            whole, and a crash mid-write leaves the old one
                            (and at most a hidden .NAME.*.tmp); an error in
                            the block removes the temporary file. A link,
                            pipe or device planted at `rel` is replaced,
                            never followed (renameat); one planted as a
                            folder on the way is Refused, as is a folder
                            standing at `rel`
  write_atomic(dfd, rel, b) `b` (bytes or str) written through atomic()
  atomic_path(path)         atomic() for a path: its folder as the caller
  write_path(path, b)       names it (the folders on the way are the
                            caller's choice, as open_dir's), the file itself
                            never followed; for the bench's writers
                            (export.py, gwy.py, point.py, paper/)
  make_dir(dfd, rel)        a folder under it, made or found (a real folder)
  give_back(path)           the folder handed back to the caller (root):
                            top-down, each folder made the caller's and
                            closed to others' writes before what it holds is
                            looked at; every symbolic link, pipe, socket and
                            device and every file with another hard link
                            is removed (each named in the returned list),
                            every other file made the caller's, without
                            group or other write, setuid or setgid bits.
  write_digests(dfd)        digests.json in the folder: the SHA-256 of every
                            regular file under it (report.html, being
                            rewritten, and digests.json aside), computed once
                            it is given back (./afm run), so that a file
                            altered since is found (issue 46, item 9)
  check_digests(dfd, rels)  Refused, naming the file and both digests, when
                            one of `rels` differs from what digests.json
                            recorded; None when it holds none of them (a run
                            made before), else the number checked

Started as root, a folder on the way (the run folder and each one under it)
must be root's and closed to others' writes, and a file must have no other
hard link: else Refused, whose message names the path and why. Started as
anyone else, only the links, pipes and devices are refused (no privilege
to lose). A Refused is a ValueError with a one-line message.

    python -m analysis.safefs take DIR...          give_back, one line per removal (stderr)
    python -m analysis.safefs check DIR FILE...    exit 2 with one line unless each FILE under DIR passes open_file
    python -m analysis.safefs mkdir DIR SUB        make_dir; exit 2 with one line when refused
    python -m analysis.safefs digest DIR           write_digests
    python -m analysis.safefs verify DIR FILE...   check_digests; exit 2 with one line when one was altered
"""
import contextlib
import errno
import hashlib
import json
import os
import secrets
import stat
import sys

KINDS = {stat.S_IFLNK: "a symbolic link", stat.S_IFIFO: "a named pipe", stat.S_IFSOCK: "a socket",
         stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device", stat.S_IFDIR: "a folder"}
_DIR = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC


class Refused(ValueError):
    """A path in a run folder that root will not follow, read or write."""


def _kind(mode):
    return KINDS.get(stat.S_IFMT(mode), "not a regular file")


def _strict():
    return os.geteuid() == 0


def _check_dir(fd, shown):
    """Root: the folder must be root's and closed to others' writes."""
    if not _strict():
        return
    st = os.fstat(fd)
    if st.st_uid != 0 or st.st_mode & 0o022:
        raise Refused(f"{shown}: a folder of uid {st.st_uid}, mode {stat.S_IMODE(st.st_mode):o}: root reads and writes "
                      "only in folders of its own that others cannot write (a run's folder is given back first)")


def _open_at(dfd, name, flags, shown):
    try:
        return os.open(name, flags, dir_fd=dfd)
    except OSError as e:
        if e.errno in (errno.ELOOP, errno.ENOTDIR):
            try:
                kind = _kind(os.stat(name, dir_fd=dfd, follow_symlinks=False).st_mode)
            except OSError:
                kind = "changed under us"
            raise Refused(f"{shown}: refused: {kind}, not followed") from None
        raise


def open_dir(path):
    """The folder `path` as a descriptor: not a link itself (the folders
    above it are the caller's choice); root: root's, closed to others."""
    try:
        fd = os.open(path, _DIR)
    except OSError as e:
        if e.errno in (errno.ELOOP, errno.ENOTDIR):
            raise Refused(f"{path}: refused: {_kind(os.lstat(path).st_mode)}, not a folder") from None
        raise
    try:
        _check_dir(fd, path)
    except Refused:
        os.close(fd)
        raise
    return fd


def _parts(rel):
    parts = [p for p in rel.split("/") if p not in ("", ".")]
    if not parts or ".." in parts:
        raise Refused(f"{rel}: not a path inside the folder")
    return parts


def _walk_dirs(dfd, parts, shown):
    """The descriptor of the folder holding parts[-1] (a new one, or dfd itself)."""
    cur = dfd
    for i, p in enumerate(parts[:-1]):
        nxt = _open_at(cur, p, _DIR, os.path.join(shown, *parts[:i + 1]))
        if cur != dfd:
            os.close(cur)
        cur = nxt
        try:
            _check_dir(cur, os.path.join(shown, *parts[:i + 1]))
        except Refused:
            os.close(cur)
            raise
    return cur


def open_file(dfd, rel, shown=""):
    """A regular file under the folder `dfd`, opened for reading (see the
    module's contract); `shown` names the folder in messages."""
    parts = _parts(rel)
    where = os.path.join(shown, rel)
    parent = _walk_dirs(dfd, parts, shown)
    try:
        fd = _open_at(parent, parts[-1], os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY, where)
    finally:
        if parent != dfd:
            os.close(parent)
    st = os.fstat(fd)
    why = None
    if not stat.S_ISREG(st.st_mode):
        why = _kind(st.st_mode)
    elif _strict() and st.st_nlink != 1:
        why = f"a file with {st.st_nlink} hard links (one may be outside the run)"
    if why:
        os.close(fd)
        raise Refused(f"{where}: refused: {why}, not read")
    os.set_blocking(fd, True)
    return fd


def read_bytes(dfd, rel, shown="", limit=None):
    """The bytes of a regular file under `dfd` (at most `limit`)."""
    fd = open_file(dfd, rel, shown)
    with os.fdopen(fd, "rb") as f:
        return f.read() if limit is None else f.read(limit)


def is_file(dfd, rel):
    """True when `rel` under `dfd` is there at all (a link counts: it is
    refused when read, and named)."""
    try:
        parent = _walk_dirs(dfd, _parts(rel), "")
    except (OSError, Refused):
        return False
    try:
        os.stat(_parts(rel)[-1], dir_fd=parent, follow_symlinks=False)
        return True
    except OSError:
        return False
    finally:
        if parent != dfd:
            os.close(parent)


def checked(dfd, rel, shown=""):
    """The path of `rel` under `dfd` once it passes open_file, for a reader
    that takes a path: /proc/self/fd/N/rel, N the folder as opened here (its
    own path is not looked up again)."""
    os.close(open_file(dfd, rel, shown))
    return f"/proc/self/fd/{dfd}/{rel}"


def make_dir(dfd, rel, shown=""):
    """A folder `rel` under `dfd`, made (0755) or found: a real folder
    (root: its own, closed to others); its descriptor."""
    parts = _parts(rel)
    parent = _walk_dirs(dfd, parts, shown)
    try:
        try:
            os.mkdir(parts[-1], 0o755, dir_fd=parent)
        except FileExistsError:
            pass
        fd = _open_at(parent, parts[-1], _DIR, os.path.join(shown, rel))
    finally:
        if parent != dfd:
            os.close(parent)
    try:
        _check_dir(fd, os.path.join(shown, rel))
    except Refused:
        os.close(fd)
        raise
    return fd


def _refuse_standing(parent, name, where):
    """Refused when a folder stands at `name` (anything else is replaced)."""
    try:
        mode = os.stat(name, dir_fd=parent, follow_symlinks=False).st_mode
    except FileNotFoundError:
        return
    if stat.S_ISDIR(mode):
        raise Refused(f"{where}: refused: a folder stands there, not replaced")


def _temporary(parent, name):
    """A new file of this process's beside `name`: (its name, its descriptor)."""
    for _ in range(16):
        tmp = f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
        try:
            return tmp, os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644, dir_fd=parent)
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary name", name)


@contextlib.contextmanager
def atomic(dfd, rel, shown=""):
    """A binary file whose bytes replace `rel` under `dfd` at the block's end
    (the module's contract); 0644."""
    parts = _parts(rel)
    where = os.path.join(shown, rel)
    parent = _walk_dirs(dfd, parts, shown)
    try:
        _refuse_standing(parent, parts[-1], where)
        tmp, fd = _temporary(parent, parts[-1])
        try:
            with os.fdopen(fd, "wb") as f:
                yield f
                f.flush()
                os.fsync(f.fileno())
            _refuse_standing(parent, parts[-1], where)   # planted while it was written
            os.rename(tmp, parts[-1], src_dir_fd=parent, dst_dir_fd=parent)
        except BaseException:
            try:
                os.unlink(tmp, dir_fd=parent)
            except OSError:
                pass
            raise
        os.fsync(parent)
    finally:
        if parent != dfd:
            os.close(parent)


def write_atomic(dfd, rel, data, shown=""):
    """`data` (bytes or str) into `rel` under `dfd` through atomic()."""
    with atomic(dfd, rel, shown) as f:
        f.write(data.encode() if isinstance(data, str) else data)


@contextlib.contextmanager
def atomic_path(path):
    """atomic() for a path (the module's contract): its folder opened as
    named, the file itself never followed."""
    folder = os.path.dirname(os.path.abspath(path))
    dfd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        with atomic(dfd, os.path.basename(path), folder) as f:
            yield f
    finally:
        os.close(dfd)


def write_path(path, data):
    """`data` (bytes or str) into `path` through atomic_path()."""
    with atomic_path(path) as f:
        f.write(data.encode() if isinstance(data, str) else data)


def _give_back_dir(fd, shown, uid, gid, removed):
    os.fchown(fd, uid, gid)
    os.fchmod(fd, stat.S_IMODE(os.fstat(fd).st_mode) & 0o755)   # closed first: nothing new appears in it
    for name in os.listdir(fd):
        where = os.path.join(shown, name)
        st = os.stat(name, dir_fd=fd, follow_symlinks=False)
        if stat.S_ISDIR(st.st_mode):
            sub = os.open(name, _DIR, dir_fd=fd)
            try:
                _give_back_dir(sub, where, uid, gid, removed)
            finally:
                os.close(sub)
            continue
        why = None
        if not stat.S_ISREG(st.st_mode):
            why = _kind(st.st_mode) + (f" to {os.readlink(name, dir_fd=fd)}" if stat.S_ISLNK(st.st_mode) else "")
        elif st.st_nlink != 1:
            why = f"a file with {st.st_nlink} hard links"
        if why:
            os.unlink(name, dir_fd=fd)
            removed.append(f"{where} ({why})")
            continue
        f = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY, dir_fd=fd)
        try:
            os.fchown(f, uid, gid)
            os.fchmod(f, stat.S_IMODE(os.fstat(f).st_mode) & 0o755)
        finally:
            os.close(f)


def give_back(path, uid=None, gid=None):
    """The folder `path` and all it holds made the caller's (see the
    module's contract); the list of what was removed, each "PATH (why)"."""
    uid = os.geteuid() if uid is None else uid
    gid = os.getegid() if gid is None else gid
    try:
        fd = os.open(path, _DIR)
    except OSError as e:
        if e.errno in (errno.ELOOP, errno.ENOTDIR):
            os.unlink(path)
            return [f"{path} ({_kind(stat.S_IFLNK)}, in place of the run's folder)"]
        raise
    removed = []
    try:
        _give_back_dir(fd, path, uid, gid, removed)
    finally:
        os.close(fd)
    return removed


DIGESTS = "digests.json"
UNDIGESTED = {DIGESTS, "report.html"}


def _sha256(dfd, rel, shown):
    h = hashlib.sha256()
    with os.fdopen(open_file(dfd, rel, shown), "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _files(dfd, prefix=""):
    """The relative paths of the regular files under `dfd` (links and the rest left out)."""
    out = []
    for e in os.scandir(dfd):
        rel = prefix + e.name
        if e.is_dir(follow_symlinks=False):
            sub = os.open(e.name, _DIR, dir_fd=dfd)
            try:
                out += _files(sub, rel + "/")
            finally:
                os.close(sub)
        elif e.is_file(follow_symlinks=False) and not (prefix == "" and (e.name in UNDIGESTED or e.name.startswith("."))):
            out.append(rel)
    return out


def write_digests(dfd, shown=""):
    """digests.json (see the module's contract); the number of files."""
    sums = {rel: _sha256(dfd, rel, shown) for rel in sorted(_files(dfd))}
    write_atomic(dfd, DIGESTS, json.dumps({"sha256": sums}, indent=1) + "\n", shown)
    return len(sums)


def check_digests(dfd, rels, shown=""):
    """See the module's contract."""
    if not is_file(dfd, DIGESTS):
        return None
    try:
        sums = json.loads(read_bytes(dfd, DIGESTS, shown))["sha256"]
    except (ValueError, KeyError, TypeError) as e:
        raise Refused(f"{os.path.join(shown, DIGESTS)}: unreadable ({e}): the run's record cannot be checked") from None
    n = 0
    for rel in rels:
        if rel not in sums:
            continue
        have = _sha256(dfd, rel, shown) if is_file(dfd, rel) else "missing"
        if have != sums[rel]:
            raise Refused(f"{os.path.join(shown, rel)}: altered since the run: sha256 {have}, "
                          f"{DIGESTS} recorded {sums[rel]}")
        n += 1
    return n


def _say(msg):
    print(msg.replace("\n", " "), file=sys.stderr)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    try:
        if argv[:1] == ["take"] and len(argv) >= 2:
            for d in argv[1:]:
                if os.path.lexists(d):
                    for r in give_back(d):
                        _say(f"safefs: removed {r}: the run's user left it there (a root step reads only regular files of its own)")
            return 0
        if argv[:1] == ["check"] and len(argv) >= 3:
            fd = open_dir(argv[1])
            for rel in argv[2:]:
                if is_file(fd, rel):
                    os.close(open_file(fd, rel, argv[1]))
            return 0
        if argv[:1] == ["digest"] and len(argv) == 2:
            write_digests(open_dir(argv[1]), argv[1])
            return 0
        if argv[:1] == ["verify"] and len(argv) >= 3:
            if check_digests(open_dir(argv[1]), argv[2:], argv[1]) is None:
                _say(f"safefs: {argv[1]}: no {DIGESTS} (a run made before digests): not checked")
            return 0
        if argv[:1] == ["mkdir"] and len(argv) == 3:
            os.close(make_dir(open_dir(argv[1]), argv[2], argv[1]))
            return 0
    except (Refused, OSError) as e:
        _say(f"safefs: {e}")
        return 2
    _say("usage: python -m analysis.safefs take DIR... | check DIR FILE... | mkdir DIR SUB | digest DIR | verify DIR FILE...")
    return 2


if __name__ == "__main__":
    sys.exit(main())
