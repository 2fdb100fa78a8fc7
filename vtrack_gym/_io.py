"""Safe file input and output: regular files only, bounded reads, atomic writes, checked before the work starts.

Every output location the package writes (presets, agent files, leaderboards, the store, figure folders) is checked
with :func:`check_output_file` or :func:`check_output_dir` when the command starts, and every file is written with
:func:`write_atomic` (a temporary file in the same folder, then ``os.replace``). Rules, for a path after its
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

import os
import stat
import tempfile
from pathlib import Path

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


def check_output_file(path: str | os.PathLike[str], option: str = "") -> Path:
    """Check that a regular file can be written at ``path``; returns the resolved path (symlinks followed).

    Refuses (``ValueError`` naming ``option`` and the path) a directory, device, FIFO or socket, a path under a
    regular file and a folder the process cannot create files in (missing folders: their nearest existing
    ancestor). Leaves nothing behind: missing folders are created only when writing.
    """
    label = _label(option, path)
    target = Path(os.path.realpath(os.fspath(path)))
    try:
        st = os.stat(target)
    except (FileNotFoundError, NotADirectoryError):
        st = None
    except OSError as exc:
        raise ValueError(f"{label}: cannot use this path ({exc.strerror or exc})") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{label} is {_kind(st.st_mode)}; an output must be a regular file (or not exist yet)")
    _probe_writable(_existing_folder(target.parent, label), label)
    return target


def check_output_dir(path: str | os.PathLike[str], option: str = "") -> Path:
    """Check that ``path`` is (or can be created as) a folder the process can create files in; resolved path.
    Creates nothing."""
    label = _label(option, path)
    target = Path(os.path.realpath(os.fspath(path)))
    _probe_writable(_existing_folder(target, label), label)
    return target


def write_atomic(path: str | os.PathLike[str], data: bytes | str, option: str = "") -> Path:
    """Write ``data`` (``str`` as UTF-8) to ``path`` atomically: a temporary file in the same folder, then
    ``os.replace``. ``path`` is checked with :func:`check_output_file` first (a non-regular file is never replaced);
    an existing file keeps its permission bits, a new one gets ``0o666`` minus the umask. Returns the resolved path.
    """
    target = check_output_file(path, option)
    _make_dirs(target.parent, _label(option, path))
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        mode = stat.S_IMODE(os.stat(target).st_mode)
    except FileNotFoundError:
        umask = os.umask(0o022)
        os.umask(umask)
        mode = 0o666 & ~umask
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(payload)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)
        try:
            st = os.lstat(target)
        except FileNotFoundError:
            st = None
        if st is not None and not stat.S_ISREG(st.st_mode):  # appeared since the check: never replace it
            raise ValueError(f"{_label(option, path)} is {_kind(st.st_mode)}; not replaced")
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return target


def read_regular_file(path: str | os.PathLike[str], max_bytes: int, what: str = "file") -> bytes:
    """The bytes of the regular file ``path`` (at most ``max_bytes``), read without blocking on FIFOs or devices.

    ``ValueError`` naming ``what`` and the path when it is missing ("not found"), not a regular file, or larger than
    ``max_bytes``.
    """
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
    finally:
        os.close(fd)


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
