"""The signature of a ``vtrack train`` run folder: verify what you load, load what you verified.

A run folder's ``model.zip`` and ``vecnormalize.pkl`` are pickles (loading them runs any code they contain). The
folder's ``vtrack-train.sig`` is an HMAC-SHA256, with this user's key (``trust_key``), of the folder's resolved
path and the SHA-256 of ``config.json``, ``model.zip`` and ``vecnormalize.pkl``. The rules:

* the signature is computed over bytes, never over a path: ``vtrack train`` signs the bytes it serialised before
  any of them is written (each file then goes through a private temporary name and is renamed into place), so no
  one can swap a file between saving and signing;
* a reader reads each file once (:func:`read_run_files`), checks the signature on those bytes
  (:func:`verified_run_files`) and loads from the same bytes: a file swapped after the check is never loaded.
"""

from __future__ import annotations

import hashlib
import hmac
from collections.abc import Mapping
from pathlib import Path

TRUST_MARKER = "vtrack-train.sig"
"""File of a ``vtrack train`` run folder holding its signature (hex, one line)."""
SIGNED_FILES = ("config.json", "model.zip", "vecnormalize.pkl")
"""The files of a run folder the signature covers (a missing one is signed as missing)."""
MAX_RUN_FILE_BYTES = 1 << 30
"""Largest run file read (1 GiB: an SB3 MLP model is a few MB)."""

RunFiles = Mapping[str, "bytes | None"]
"""A run folder's signed files as read once: name -> bytes, ``None`` for a missing file."""


def _trust_key(create: bool) -> bytes | None:
    """This user's run-signing key (``vtrack_gym.agents.trust_key``: a key that breaks the key rule is refused)."""
    from vtrack_gym.agents.trust_key import load_trust_key

    return load_trust_key(create)


def read_run_files(run_dir: str | Path) -> dict[str, bytes | None]:
    """Each of ``SIGNED_FILES`` of ``run_dir`` read once (bounded by ``MAX_RUN_FILE_BYTES``); ``None`` if absent.
    ``ValueError`` for a file that is not a regular file or too large."""
    from vtrack_gym._io import read_regular_file

    run = Path(run_dir)
    files: dict[str, bytes | None] = {}
    for name in SIGNED_FILES:
        if not (run / name).exists() and not (run / name).is_symlink():
            files[name] = None
            continue
        files[name] = read_regular_file(run / name, MAX_RUN_FILE_BYTES, f"run file {name}")
    return files


def signature(run_dir: str | Path, key: bytes, files: RunFiles) -> str:
    """The HMAC-SHA256 (hex) of ``run_dir``'s resolved path and the SHA-256 of each signed file's bytes."""
    mac = hmac.new(key, str(Path(run_dir).resolve()).encode(), hashlib.sha256)
    for name in SIGNED_FILES:
        data = files.get(name)
        mac.update(f"{name}:{hashlib.sha256(data).hexdigest() if data is not None else '-'};".encode())
    return mac.hexdigest()


def sign_bytes(run_dir: str | Path, files: RunFiles) -> str:
    """The signature line for ``files`` (the bytes about to be written to ``run_dir``), with this user's key
    (created if missing)."""
    key = _trust_key(create=True)
    assert key is not None
    return signature(run_dir, key, files) + "\n"


def sign_run(run_dir: str | Path) -> Path:
    """Sign the files ``run_dir`` holds now (each read once) and write ``TRUST_MARKER``; returns its path.
    ``vtrack train`` signs the bytes it serialises instead (``sign_bytes``), before writing them."""
    from vtrack_gym._io import write_atomic

    run = Path(run_dir)
    return write_atomic(run / TRUST_MARKER, sign_bytes(run, read_run_files(run)))


def _marker_text(run: Path) -> str | None:
    """The signature stored in ``run``, or ``None`` if there is none (or it is not a small regular file)."""
    from vtrack_gym._io import read_regular_file

    try:
        return read_regular_file(run / TRUST_MARKER, 200, "run signature").decode("ascii", "replace").strip()
    except ValueError:
        return None


def files_are_trusted(run_dir: str | Path, files: RunFiles) -> bool:
    """True if ``run_dir``'s signature, with this user's key, matches exactly ``files`` (bytes already read).
    ``TrustKeyError`` (a ``ValueError``) if this user's key breaks the key rule: such a key is never used."""
    run = Path(run_dir)
    key = _trust_key(create=False)
    stored = _marker_text(run) if key is not None else None
    return stored is not None and key is not None and hmac.compare_digest(stored, signature(run, key, files))


def run_is_trusted(run_dir: str | Path) -> bool:
    """True if ``run_dir`` holds a valid signature by this user's key over its current path and files."""
    return files_are_trusted(run_dir, read_run_files(run_dir))


def verified_run_files(run_dir: str | Path, *, trust: bool = False) -> dict[str, bytes | None]:
    """``run_dir``'s signed files, read once and checked against its signature (unless ``trust``): the caller
    loads from these bytes and never opens the files again. ``ValueError`` when the signature does not match."""
    run = Path(run_dir)
    files = read_run_files(run)
    if not trust and not files_are_trusted(run, files):
        raise ValueError(f"{run} was not written by `vtrack train` as this user on this machine, or its files "
                         "changed since (no valid vtrack-train.sig). Its model.zip and vecnormalize.pkl are "
                         "pickles that can run code when loaded: pass --trust-code only if you trust where "
                         "they came from")
    return files
