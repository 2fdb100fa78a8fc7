"""This user's run-signing key: one rule for creating it and for accepting it.

The key lives in ``$XDG_CONFIG_HOME/vtrack_gym/trust.key`` (default ``~/.config/vtrack_gym/trust.key``) as the
hex text of 32 random bytes. It is created atomically (a temporary file of mode 0600 in the same folder, written,
fsynced, then linked into place, which never replaces a key another process made first), so a crash or a full
disk leaves no key or a whole one, never an empty file.

An existing key is used only if it is a regular file (not a symlink), owned by this user, readable and writable by
this user alone (no group or other permission bits) and holds exactly 32 bytes as 64 hex digits. Any other key
(empty, short, readable by others, another owner) raises :class:`TrustKeyError` saying how to fix it; it is never
used and never replaced silently.
"""

from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path

KEY_BYTES = 32
"""Length of the key (bytes of randomness)."""
_MAX_FILE_BYTES = 4 * KEY_BYTES
"""A larger file is not a key (read no further)."""


class TrustKeyError(ValueError):
    """The trust key exists but breaks the key rule (see the module docstring); the message says how to fix it."""


def trust_key_path() -> Path:
    """Where this user's key lives (``$XDG_CONFIG_HOME/vtrack_gym/trust.key``)."""
    base = Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config")
    return base / "vtrack_gym" / "trust.key"


def _refuse(path: Path, problem: str, fix: str) -> TrustKeyError:
    return TrustKeyError(f"the trust key {path} {problem}; it was not used. {fix} (runs signed with an old key "
                         "then need `vtrack export --trust`, or a new `vtrack train`)")


def _delete_fix(path: Path) -> str:
    return f"Delete it (rm {path}) and the next `vtrack train` creates a new key"


def _read_key(path: Path) -> bytes | None:
    """The key in ``path`` if it obeys the key rule; None if there is no key; ``TrustKeyError`` otherwise."""
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None
    except OSError as exc:
        if os.path.islink(path):
            raise _refuse(path, "is a symbolic link", _delete_fix(path)) from None
        raise _refuse(path, f"cannot be read ({exc.strerror or exc})", _delete_fix(path)) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise _refuse(path, "is not a regular file", _delete_fix(path))
        if st.st_uid != os.geteuid():
            raise _refuse(path, f"is owned by user id {st.st_uid}, not by you ({os.geteuid()})", _delete_fix(path))
        if stat.S_IMODE(st.st_mode) & 0o077:
            raise _refuse(path, f"has mode {stat.S_IMODE(st.st_mode):04o}: others could read or replace it and "
                          "sign runs as you", _delete_fix(path))
        data = os.read(fd, _MAX_FILE_BYTES + 1)
    finally:
        os.close(fd)
    try:
        key = bytes.fromhex(data.decode("ascii").strip())
    except (UnicodeDecodeError, ValueError):
        key = b""
    if len(key) != KEY_BYTES:
        raise _refuse(path, f"does not hold {KEY_BYTES} bytes as {2 * KEY_BYTES} hex digits ({len(data)} bytes "
                      "in the file: empty, cut short or not a key)", _delete_fix(path))
    return key


def _create_key(path: Path) -> None:
    """Write a new key to ``path`` atomically; a key another process made first is kept."""
    path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(8)}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
    try:
        try:
            os.fchmod(fd, 0o600)
            payload = (secrets.token_bytes(KEY_BYTES).hex() + "\n").encode("ascii")
            if os.write(fd, payload) != len(payload):
                raise OSError(28, "short write")
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(tmp, path)   # atomic, and never replaces a key made meanwhile
        except FileExistsError:
            pass
        _fsync_dir(path.parent)
    finally:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def load_trust_key(create: bool) -> bytes | None:
    """This user's key; with ``create``, a missing key is made first (else None when missing).

    ``TrustKeyError`` for a key that breaks the key rule, or when a new key cannot be written (disk full,
    read-only folder): nothing half-written is left.
    """
    path = trust_key_path()
    key = _read_key(path)
    if key is not None or not create:
        return key
    try:
        _create_key(path)
    except OSError as exc:
        raise TrustKeyError(f"cannot create the trust key {path} ({exc.strerror or exc}); nothing was left "
                            "behind. Free disk space or make the folder writable, then retry") from None
    return _read_key(path)
