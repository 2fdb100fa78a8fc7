"""Pickling state whose numpy arrays are views of one another (column views of one state block).

``pickle`` and ``copy.deepcopy`` copy every view as an array of its own, so after a round trip a column view no
longer writes into its block and the copy drifts from the original. :func:`encode` replaces each view (an attribute,
or an item of a tuple, named tuple, list or dict up to ``depth`` levels down) by an :class:`ArrayView` naming its
owning array and its place in it; :func:`decode` makes the views again on the unpickled owner (pickle keeps one
copy of an object referenced twice, so every view lands on the same block).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class ArrayView:
    """A view of ``owner``: ``offset`` [bytes] into its data, ``shape``, ``strides`` [bytes], dtype and writeability."""

    owner: np.ndarray
    offset: int
    shape: tuple[int, ...]
    strides: tuple[int, ...]
    dtype: str
    writeable: bool

    def make(self) -> np.ndarray:
        """The view on ``owner``."""
        view = np.ndarray(self.shape, np.dtype(self.dtype), buffer=self.owner, offset=self.offset,
                          strides=self.strides)
        view.flags.writeable = self.writeable and self.owner.flags.writeable
        return view


def _owner(array: np.ndarray) -> np.ndarray | None:
    """The array that owns ``array``'s data (None when a view of something other than an owning ndarray)."""
    base = array.base
    while isinstance(base, np.ndarray) and base.base is not None:
        base = base.base
    if not isinstance(base, np.ndarray) or not base.flags.c_contiguous:
        return None
    return base


def encode(value: Any, depth: int = 3) -> Any:
    """``value`` with every numpy view (in containers up to ``depth`` levels down) replaced by an ``ArrayView``."""
    if isinstance(value, np.ndarray):
        owner = _owner(value) if value.base is not None else None
        if owner is None:
            return value
        offset = value.__array_interface__["data"][0] - owner.__array_interface__["data"][0]
        return ArrayView(owner, offset, value.shape, value.strides, value.dtype.str, bool(value.flags.writeable))
    return _map_items(value, depth, encode)


def decode(value: Any, depth: int = 3) -> Any:
    """The inverse of :func:`encode`: every ``ArrayView`` made a view of its (unpickled) owner again."""
    if isinstance(value, ArrayView):
        return value.make()
    return _map_items(value, depth, decode)


def _map_items(value: Any, depth: int, fn: Callable[[Any, int], Any]) -> Any:
    """A named tuple, tuple, list or dict with ``fn(item, depth - 1)`` applied to each item; anything else, or
    ``depth`` <= 0, as is."""
    if depth <= 0:
        return value
    if isinstance(value, tuple) and hasattr(value, "_fields"):
        return type(value)._make(fn(v, depth - 1) for v in value)
    if type(value) in (tuple, list):
        return type(value)(fn(v, depth - 1) for v in value)
    if type(value) is dict:
        return {k: fn(v, depth - 1) for k, v in value.items()}
    return value
