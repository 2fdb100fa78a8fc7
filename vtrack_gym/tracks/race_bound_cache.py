"""The racing line and its lap-time bound, solved once per content in a process (what every race env is made with).

The key is the SHA-256 of the inputs' bytes: every array and scalar of the track's ``Path`` (its rows, widths,
speed column, cones and gates, its ``closed`` flag and spacing; not its name), every field of the car's
``VehicleParams`` (nested dataclasses, floats by ``repr``: exact), the solver settings (``RacingLineSpec``) and
``CACHE_FORMAT``. Two tracks or cars with the same name and other content never share an entry; the same content
under another name does (its ``RacingLine.track`` is the caller's path).

Only in memory (``bound_cache().get``, at most ``MAX_ENTRIES`` entries, least recently used dropped): the line
and the bound are frozen dataclasses whose arrays are made read-only before they are stored, so an env cannot
change what another one is given.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np

CACHE_FORMAT = "race-bound-1"
"""Part of every key: changed when the solver's output for the same inputs changes."""
MAX_ENTRIES = 16
"""Entries kept in a process (each a line and a bound: a few MB on a 2 km track)."""


def _feed(digest: Any, value: Any) -> None:
    """Add ``value``'s bytes to ``digest``: arrays by dtype, shape and bytes, dataclasses field by field (their
    ``name`` fields left out), sequences element by element, scalars by ``repr``."""
    if isinstance(value, np.ndarray):
        digest.update(f"a{value.dtype.str}{value.shape}".encode())
        digest.update(np.ascontiguousarray(value).tobytes())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        digest.update(f"d{type(value).__qualname__}(".encode())
        for f in dataclasses.fields(value):
            if f.name != "name" and f.init:
                digest.update(f"{f.name}=".encode())
                _feed(digest, getattr(value, f.name))
        digest.update(b")")
    elif isinstance(value, (tuple, list)):
        digest.update(f"t{len(value)}[".encode())
        for item in value:
            _feed(digest, item)
        digest.update(b"]")
    else:
        digest.update(f"s{type(value).__name__}:{value!r};".encode())


def content_key(path: Any, vehicle: Any, spec: Any) -> str:
    """The hex SHA-256 of the track's, the car's and the solver settings' content (module docstring)."""
    digest = hashlib.sha256(CACHE_FORMAT.encode())
    for part in (path, vehicle, spec):
        _feed(digest, part)
    return digest.hexdigest()


def _freeze(obj: Any, seen: set[int] | None = None) -> None:
    """Make every numpy array reachable through ``obj``'s dataclass fields read-only."""
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        obj.flags.writeable = False
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            _freeze(getattr(obj, f.name), seen)
    elif isinstance(obj, (tuple, list)):
        for item in obj:
            _freeze(item, seen)


class BoundCache:
    """Solved (racing line, lap-time bound) pairs by content key, least recently used dropped past ``size``."""

    def __init__(self, size: int = MAX_ENTRIES) -> None:
        self.size = size
        self._entries: OrderedDict[str, tuple[Any, Any]] = OrderedDict()
        self.hits = 0
        self.misses = 0

    def get(self, path: Any, vehicle: Any, spec: Any, solve: Callable[[], tuple[Any, Any]]) -> tuple[Any, Any]:
        """The stored pair for this content, else ``solve()``'s, stored; ``RacingLine.track`` is ``path``."""
        key = content_key(path, vehicle, spec)
        found = self._entries.get(key)
        if found is None:
            self.misses += 1
            found = solve()
            _freeze(found)
            self._entries[key] = found
            while len(self._entries) > self.size:
                self._entries.popitem(last=False)
        else:
            self.hits += 1
            self._entries.move_to_end(key)
        line, bound = found
        return (line if line.track is path else dataclasses.replace(line, track=path)), bound

    def clear(self) -> None:
        """Forget every entry (and the counts)."""
        self._entries.clear()
        self.hits = self.misses = 0


@functools.lru_cache(maxsize=1)
def bound_cache() -> BoundCache:
    """The process's cache (one per process; worker processes each have their own)."""
    return BoundCache()
