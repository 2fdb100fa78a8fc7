"""Safe file input and output: regular files only, bounded reads, atomic writes, checked before the work starts.

Every output location the package writes (presets, agent files, leaderboards, the store, figure folders, videos,
run folders) is checked with :func:`check_output_file` or :func:`check_output_dir` when the command starts, and
every file is written through :func:`atomic_output` (a temporary file in the same folder, fsynced, then
``os.replace``; on any failure it is deleted, and a full disk or read-only folder is a ``ValueError`` that says
so) or its shorthand :func:`write_atomic`. Rules, for a path after its
symlinks are resolved:

* an output file is absent or a regular file (never a directory, device, FIFO or socket), and its folder, or the
  nearest existing ancestor of a missing folder, is a folder the process can create files in (a path under a
  regular file is refused);
* an output folder is a folder, or missing with such an ancestor.

Checking creates nothing; :func:`write_atomic` creates the missing folders when it writes.

Every loader reads through :func:`read_regular_file`: the file is opened with ``O_NONBLOCK`` (a FIFO never
blocks), must be a regular file and at most ``max_bytes`` long, and is read in bounded memory.
Errors are ``ValueError`` naming the option (or what the file is) and the path.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

_KINDS = ((stat.S_ISREG, "a regular file"), (stat.S_ISDIR, "a directory"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"))


def _kind(mode: int) -> str:
    """What a file is, for messages ("a FIFO", "a regular file", ...)."""
    return next((name for test, name in _KINDS if test(mode)), "a special file")


def _label(option: str, path: str | os.PathLike[str]) -> str:
    return f"{option} {os.fspath(path)}" if option else os.fspath(path)


def _probe_writable(folder: Path, label: str) -> None:
    """Create and remove a file in ``folder`` (the real test, also for root, read-only mounts and immutable dirs)."""
    try:
        fd, name = tempfile.mkstemp(dir=folder, prefix=".vtrack-probe-")
    except OSError as exc:
        raise ValueError(f"{label}: cannot create files in {folder} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(name)


def _existing_folder(folder: Path, label: str) -> Path:
    """The nearest existing ancestor of ``folder`` (itself included); ``ValueError`` unless it is a directory."""
    for part in (folder, *folder.parents):
        try:
            st = os.stat(part)
        except (FileNotFoundError, NotADirectoryError):  # missing, or under a file (found further up)
            continue
        except OSError as exc:
            raise ValueError(f"{label}: cannot use the folder {part} ({exc.strerror or exc})") from None
        if not stat.S_ISDIR(st.st_mode):
            raise ValueError(f"{label}: {part} is {_kind(st.st_mode)} where a folder is needed")
        return part
    raise ValueError(f"{label}: no existing folder above {folder}")  # pragma: no cover - "/" exists


def _make_dirs(folder: Path, label: str) -> None:
    """``mkdir -p folder``; ``ValueError`` naming ``label`` if it cannot be created."""
    _existing_folder(folder, label)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{label}: cannot create the folder {folder} ({exc.strerror or exc})") from None


_SQLITE_MAGIC = b"SQLite format 3\x00"
_SQLITE_COMPANIONS = ("-wal", "-shm", "-journal")


def _is_sqlite(path: Path) -> bool:
    """True if ``path`` is a regular file starting with SQLite's header (a leaderboard store, for one)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return False
    try:
        return stat.S_ISREG(os.fstat(fd).st_mode) and os.read(fd, len(_SQLITE_MAGIC)) == _SQLITE_MAGIC
    except OSError:
        return False
    finally:
        os.close(fd)


def _check_not_a_database(target: Path, label: str, store: bool) -> None:
    """Refuse an SQLite database (unless ``store``: the output is itself a store) and a database's journal."""
    if not store and _is_sqlite(target):
        raise ValueError(f"{label} is an SQLite database (a leaderboard store?); it was left untouched: pass "
                         "another path")
    for suffix in _SQLITE_COMPANIONS:
        if target.name.endswith(suffix) and _is_sqlite(target.with_name(target.name[: -len(suffix)])):
            raise ValueError(f"{label} is the {suffix[1:]} file of the database "
                             f"{target.name[: -len(suffix)]}; writing it would corrupt that store: pass another path")


def check_output_file(path: str | os.PathLike[str], option: str = "", *, store: bool = False) -> Path:
    """Check that a regular file can be written at ``path``; returns the resolved path (symlinks followed).

    Refuses (``ValueError`` naming ``option`` and the path) a directory, device, FIFO or socket, a symlink to a
    file in a missing folder, an existing SQLite database (unless ``store``: the output is a store) and a
    database's ``-wal``/``-shm``/``-journal`` file, a path under a regular file and a folder the process cannot
    create files in (missing folders: their nearest existing ancestor). Leaves nothing behind: missing folders
    are created only when writing.
    """
    label = _label(option, path)
    target = Path(os.path.realpath(os.fspath(path)))
    if os.path.islink(path) and not os.path.isdir(target.parent):   # never create the folders of a link's target
        raise ValueError(f"{label} is a symbolic link to {os.readlink(path)}, whose folder does not exist; pass "
                         "the target itself or remove the link")
    try:
        st = os.stat(target)
    except (FileNotFoundError, NotADirectoryError):
        st = None
    except OSError as exc:
        raise ValueError(f"{label}: cannot use this path ({exc.strerror or exc})") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{label} is {_kind(st.st_mode)}; an output must be a regular file (or not exist yet)")
    _check_not_a_database(target, label, store)
    _probe_writable(_existing_folder(target.parent, label), label)
    return target


def check_output_dir(path: str | os.PathLike[str], option: str = "") -> Path:
    """Check that ``path`` is (or can be created as) a folder the process can create files in; resolved path.
    Creates nothing."""
    label = _label(option, path)
    target = Path(os.path.realpath(os.fspath(path)))
    _probe_writable(_existing_folder(target, label), label)
    return target


def disk_is_full(folder: str | os.PathLike[str]) -> bool:
    """True if the file system holding ``folder`` has no free block left for this user."""
    try:
        return os.statvfs(folder).f_bavail == 0
    except OSError:
        return False


def _write_problem(exc: OSError, folder: Path) -> str:
    """A sentence for a failed write: disk full (also when a tool reports it as a broken pipe), read-only, or the
    error text."""
    if exc.errno == errno.ENOSPC or disk_is_full(folder):
        return "the disk is full"
    if exc.errno in (errno.EROFS, errno.EACCES, errno.EPERM):
        return f"the folder is read-only or not writable ({exc.strerror or exc})"
    return str(exc.strerror or exc)[:300]


def output_error(exc: OSError, path: str | os.PathLike[str], option: str = "") -> ValueError:
    """The ``ValueError`` for an ``OSError`` while writing ``path`` in place (a log that grows while a command runs,
    checked with :func:`check_output_file` or :func:`check_output_dir` first): names ``option``, the path and the
    cause (the disk is full, a read-only folder, or the error text)."""
    folder = Path(os.path.realpath(os.fspath(path)))
    while not folder.is_dir() and folder != folder.parent:
        folder = folder.parent
    return ValueError(f"{_label(option, path)}: could not write ({_write_problem(exc, folder)})")


def _missing_folders(folder: Path) -> list[Path]:
    """``folder`` and its missing ancestors that do not exist yet, deepest first."""
    missing = []
    for part in (folder, *folder.parents):
        if os.path.lexists(part):
            break
        missing.append(part)
    return missing


def new_file_mode(target: Path) -> int:
    """The permission bits of the file being replaced, else ``0o666`` minus the umask."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except FileNotFoundError:
        umask = os.umask(0o022)
        os.umask(umask)
        return 0o666 & ~umask


def _discard(tmp: str, created: list[Path]) -> None:
    """Remove a temporary file and the (still empty) folders made for it."""
    with contextlib.suppress(FileNotFoundError):
        os.unlink(tmp)
    for folder in created:
        with contextlib.suppress(OSError):
            os.rmdir(folder)


def _publish(tmp: str, target: Path, label: str) -> None:
    """fsync ``tmp`` and rename it over ``target`` (never over a file that became a non-regular file)."""
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    os.chmod(tmp, new_file_mode(target))
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        st = None
    if st is not None and not stat.S_ISREG(st.st_mode):  # appeared since the check: never replace it
        raise ValueError(f"{label} is {_kind(st.st_mode)}; not replaced")
    os.replace(tmp, target)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], option: str = "") -> Iterator[Path]:
    """The one way a file is written: yields a temporary path in the target's folder (same suffix, for tools that
    pick a format by it); when the block ends without error the file is fsynced and renamed over ``path``, else it
    is deleted together with the folders made for it. ``path`` is checked with :func:`check_output_file` first.

    An ``OSError`` while writing (a full disk, a read-only file system) becomes a ``ValueError`` naming ``option``,
    the path and the cause, with nothing left behind.
    """
    label = _label(option, path)
    target = check_output_file(path, option)
    created = _missing_folders(target.parent)
    _make_dirs(target.parent, label)
    tmp = ""
    try:
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=f".tmp{target.suffix}")
        os.close(fd)
        yield Path(tmp)
        _publish(tmp, target, label)
    except OSError as exc:
        _discard(tmp, created)
        raise ValueError(f"{label}: could not write the file ({_write_problem(exc, target.parent)}); nothing was "
                         "written") from None
    except BaseException:
        _discard(tmp, created)
        raise


def write_atomic(path: str | os.PathLike[str], data: bytes | str, option: str = "") -> Path:
    """Write ``data`` (``str`` as UTF-8) to ``path`` through :func:`atomic_output` (a temporary file in the same
    folder, fsynced, then ``os.replace``); an existing file keeps its permission bits, a new one gets ``0o666``
    minus the umask. Returns the resolved path; ``ValueError`` when it cannot be written (nothing left behind).
    """
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    with atomic_output(path, option) as tmp, open(tmp, "wb") as fh:
        fh.write(payload)
    return Path(os.path.realpath(os.fspath(path)))


def read_regular_file(path: str | os.PathLike[str], max_bytes: int, what: str = "file") -> bytes:
    """The bytes of the regular file ``path`` (at most ``max_bytes``), read without blocking on FIFOs or devices.

    ``ValueError`` naming ``what`` and the path when it is missing ("not found"), not a regular file, or larger than
    ``max_bytes``.
    """
    return read_regular_file_stamped(path, max_bytes, what)[0]


def file_stamp(st: os.stat_result) -> tuple[int, ...]:
    """What identifies one version of a file: device, inode, size [bytes], modification and change times [ns]
    (a file replaced by a rename has another inode; one rewritten in place, other times)."""
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def unchanged_since(path: str | os.PathLike[str], stamp: tuple[int, ...]) -> bool:
    """Whether ``path`` is still the version of the file ``stamp`` (``file_stamp``) was taken of."""
    try:
        return file_stamp(os.stat(os.fspath(path))) == stamp
    except OSError:
        return False


def read_regular_file_stamped(path: str | os.PathLike[str], max_bytes: int,
                              what: str = "file") -> tuple[bytes, tuple[int, ...]]:
    """``read_regular_file``'s bytes and the ``file_stamp`` of the open file they were read from (taken before the
    read: a file rewritten while it is read no longer matches it)."""
    name = os.fspath(path)
    try:
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise ValueError(f"{name}: {what} not found") from None
    except IsADirectoryError:
        raise ValueError(f"{name}: {what} not found (it is a directory)") from None
    except OSError as exc:
        raise ValueError(f"{name}: cannot open the {what} ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise ValueError(f"{name}: {what} not found (it is a directory)")
        if not stat.S_ISREG(st.st_mode):
            raise ValueError(f"{name}: the {what} is {_kind(st.st_mode)}, not a regular file")
        if st.st_size > max_bytes:
            raise ValueError(f"{name}: the {what} is {st.st_size} bytes (limit {max_bytes})")
        return _read_bounded(fd, name, max_bytes, what), file_stamp(st)
    finally:
        os.close(fd)


def _read_bounded(fd: int, name: str, max_bytes: int, what: str) -> bytes:
    """The rest of the open file ``fd``, refused once it passes ``max_bytes`` (a file growing while read)."""
    chunks: list[bytes] = []
    total = 0
    while True:
        try:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
        except OSError as exc:
            raise ValueError(f"{name}: cannot read the {what} ({exc.strerror or exc})") from None
        if not chunk:
            break
        chunks.append(chunk)
        total += len(chunk)
        if total > max_bytes:
            raise ValueError(f"{name}: the {what} grew beyond the limit of {max_bytes} bytes while being read")
    return b"".join(chunks)


def check_regular_input(path: str | os.PathLike[str], what: str = "file") -> Path:
    """``path`` if it exists and is a regular file after following symlinks, else ``ValueError`` ("not found" for
    a missing path or a directory)."""
    name = os.fspath(path)
    try:
        st = os.stat(name)
    except FileNotFoundError:
        raise ValueError(f"{name}: {what} not found") from None
    except OSError as exc:
        raise ValueError(f"{name}: cannot use the {what} ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise ValueError(f"{name}: {what} not found (it is a directory)")
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{name}: the {what} is {_kind(st.st_mode)}, not a regular file")
    return Path(name)


_MAGIC = frozenset("*?[")


def _subdirs(folder: Path) -> Iterator[os.DirEntry[str]]:
    """The entries of ``folder`` (sorted by name); an unreadable folder has none."""
    try:
        with os.scandir(folder) as it:
            entries = sorted(it, key=lambda e: e.name)
    except OSError:
        return iter(())
    return iter(entries)


def _visible(name: str, part: str) -> bool:
    """``glob``'s rule: a wildcard never matches a name starting with a dot unless the pattern part does."""
    return not name.startswith(".") or part.startswith(".")


def _first_visit(entry: os.DirEntry[str] | Path, visited: set[tuple[int, int]]) -> bool:
    """True the first time the real folder behind ``entry`` (symlinks followed) is seen; False after, or when it is
    not a folder."""
    try:
        st = os.stat(entry)
    except OSError:
        return False
    if not stat.S_ISDIR(st.st_mode) or (st.st_dev, st.st_ino) in visited:
        return False
    visited.add((st.st_dev, st.st_ino))
    return True


def _matches(folder: Path, parts: tuple[str, ...], visited: set[tuple[int, int]]) -> Iterator[Path]:
    """Paths under ``folder`` matching the pattern ``parts`` (``**``: zero or more folders, each real folder
    entered once however many symlinks lead to it)."""
    import fnmatch

    head, rest = parts[0], parts[1:]
    if head == "**":
        if rest:
            yield from _matches(folder, rest, visited)
        else:   # a last ``**`` matches everything below
            yield from (Path(e.path) for e in _subdirs(folder) if _visible(e.name, ""))
        for entry in _subdirs(folder):
            if _visible(entry.name, "") and _first_visit(entry, visited):
                yield from _matches(Path(entry.path), parts, visited)
        return
    if not _MAGIC & set(head):
        candidates: Iterator[Any] = iter([folder / head])
    else:
        candidates = (Path(e.path) for e in _subdirs(folder)
                      if fnmatch.fnmatchcase(e.name, head) and _visible(e.name, head))
    for candidate in candidates:
        if not rest:
            if os.path.lexists(candidate):
                yield candidate
        elif os.path.isdir(candidate):
            yield from _matches(candidate, rest, visited)


def glob_files(pattern: str, limit: int) -> list[Path]:
    """The regular files ``pattern`` matches, sorted (``*``, ``?``, ``[...]`` in a name, ``**`` for any folder
    depth, as ``glob.glob(recursive=True)``), found without ever entering a real folder twice: a symlink loop
    under ``**`` is walked once. ``ValueError`` when more than ``limit`` files match."""
    parts = Path(pattern).parts
    first_magic = next((i for i, p in enumerate(parts) if _MAGIC & set(p)), len(parts))
    base = Path(*parts[:first_magic]) if first_magic else Path(".")
    if first_magic == len(parts):
        return [base] if base.is_file() else []
    visited: set[tuple[int, int]] = set()
    _first_visit(base, visited)
    found: set[Path] = set()
    for match in _matches(base, parts[first_magic:], visited):
        if match.is_file():
            found.add(match)
            if len(found) > limit:
                raise ValueError(f"{pattern}: more than {limit} files match")
    return sorted(found)
