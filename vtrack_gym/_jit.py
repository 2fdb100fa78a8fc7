"""The one way the package compiles numba kernels: ``@kernel`` (``numba.njit`` with a cache that cannot go stale).

numba's own ``cache=True`` keys a compiled function on its own source file only: after an edit to a function it
calls in another module (or to a constant it reads from one), the cached machine code still runs the old code.
Here every kernel's cache lives in a directory named by one hash of the source files compiled code depends on
(``_kernel_sources``: the modules that define compiled functions, the modules they take functions and constants
from, and this one), not of the import graph. A change to any of them selects a new, empty directory, so
everything is recompiled once; the same hash is also the index stamp numba checks before loading. An edit
anywhere else (a plot, a registry line, the CLI) leaves the cache valid.

Where the cache lives (the first that is writable):

1. ``$NUMBA_CACHE_DIR/vtrack_gym`` when numba's ``NUMBA_CACHE_DIR`` is set;
2. ``vtrack_gym/__pycache__/kernels`` next to the sources (a source checkout, a writable install);
3. the user's cache directory, ``$XDG_CACHE_HOME/vtrack_gym/kernels`` (default ``~/.cache``), for an install in
   a read-only site-packages.

Each holds one sub-directory per source hash; the ``KEEP_DIRS`` most recently used are kept (switching between
a few checkouts or branches recompiles nothing) and older ones are deleted when a new one is created.

Kernels compile without fast-math, so every caller gets the same IEEE operations in the same order.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any, ClassVar

import numba
from numba import prange
from numba.core import caching

from vtrack_gym._kernel_sources import kernel_sources

__all__ = ["KEEP_DIRS", "kernel", "kernel_cache_dir", "prange", "source_hash"]

KEEP_DIRS = 4
"""Source-hash directories kept per cache root (the current one included)."""
HASH_CHARS = 20
"""Hex digits of the source hash used as the directory name."""

_PACKAGE_DIR = Path(__file__).resolve().parent
_PACKAGE = _PACKAGE_DIR.name
_log = logging.getLogger(__name__)


@cache
def source_hash(package_dir: Path = _PACKAGE_DIR) -> str:
    """Hex hash of the kernel sources (``_kernel_sources.kernel_sources``, and this module): their package-relative
    paths and bytes."""
    digest = hashlib.sha256()
    for path in sorted({*kernel_sources(package_dir), package_dir / "_jit.py"}):
        digest.update(path.relative_to(package_dir).as_posix().encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()[:HASH_CHARS]


def _cache_roots(package_dir: Path) -> list[Path]:
    """Candidate cache roots in order of preference (see the module docstring)."""
    if numba.config.CACHE_DIR:
        return [Path(numba.config.CACHE_DIR) / _PACKAGE]
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return [package_dir / "__pycache__" / "kernels", Path(xdg) / _PACKAGE / "kernels"]


def _prune(root: Path, current: str) -> None:
    """Delete all but the ``KEEP_DIRS`` most recently used source-hash directories under ``root``."""
    others = [p for p in root.iterdir() if p.is_dir() and p.name != current]
    others.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    for old in others[KEEP_DIRS - 1:]:
        _log.debug("removing the stale kernel cache %s", old)
        shutil.rmtree(old, ignore_errors=True)


@cache
def kernel_cache_dir(package_dir: Path = _PACKAGE_DIR) -> Path | None:
    """The directory of this process's compiled kernels (created; older ones pruned), or None if no candidate
    root is writable (the kernels then compile on every run)."""
    current = source_hash(package_dir)
    for root in _cache_roots(package_dir):
        path = root / current
        try:
            fresh = not path.is_dir()
            path.mkdir(parents=True, exist_ok=True)
            probe = path / f".probe-{os.getpid()}"
            probe.touch()
            probe.unlink()
            os.utime(path)  # most recently used
            if fresh:
                _prune(root, current)
        except OSError:
            continue
        _log.debug("kernel cache: %s", path)
        return path
    _log.warning("no writable kernel cache directory: the kernels are compiled on every run")
    return None


class _SourceHashLocator(caching._CacheLocator):
    """Places a kernel's cache files in ``kernel_cache_dir()/<package sub-directory>``, stamped with the source
    hash (numba ignores an index written under another stamp)."""

    def __init__(self, py_func: Callable[..., Any], py_file: str, cache_dir: Path) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        relative = Path(py_file).resolve().parent.relative_to(_PACKAGE_DIR)
        self._cache_path = str(cache_dir.joinpath(*relative.parts))

    def get_cache_path(self) -> str:
        return self._cache_path

    def get_source_stamp(self) -> str:
        return source_hash()

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> _SourceHashLocator | None:
        cache_dir = kernel_cache_dir()
        if cache_dir is None or not Path(py_file).resolve().is_relative_to(_PACKAGE_DIR):
            return None
        locator = cls(py_func, py_file, cache_dir)
        try:
            locator.ensure_cache_path()
        except OSError:
            return None
        return locator


class _SourceHashCacheImpl(caching.CompileResultCacheImpl):
    _locator_classes: ClassVar[list[type]] = [_SourceHashLocator]


class _SourceHashCache(caching.FunctionCache):
    """numba's function cache with the source-hash locator."""

    _impl_class = _SourceHashCacheImpl


def _attach_cache(dispatcher: Any) -> Any:
    """Give a numba dispatcher the source-hash cache (no cache when no directory is writable)."""
    if not isinstance(dispatcher, numba.core.dispatcher.Dispatcher):  # NUMBA_DISABLE_JIT: a plain function
        return dispatcher
    if kernel_cache_dir() is None:
        return dispatcher
    try:
        dispatcher._cache = _SourceHashCache(dispatcher.py_func)
    except RuntimeError:  # no locator: a function outside the package's source files
        _log.debug("no kernel cache for %s", dispatcher.py_func.__qualname__)
    return dispatcher


def kernel(func: Callable[..., Any] | None = None, *, parallel: bool = False, inline: bool = False,
           error_model: str = "python", refcount: bool = True) -> Any:
    """Compile ``func`` with ``numba.njit`` (``parallel`` for ``prange`` loops) and the source-hash cache.

    ``inline=True`` inlines the function into every compiled caller at numba's level (numba's
    ``inline="always"``): for the small pieces a model is built from, so that splitting a formula into named
    functions costs nothing at run time (the same operations in the same order, no call and no array reference
    counting). Use as ``@kernel``, ``@kernel(parallel=True)``, ``@kernel(inline=True)`` or
    ``name = kernel(function)``.

    For a loop meant to compile to SIMD code (``vehicle.fast_kernels``): ``error_model="numpy"`` (a float division
    by zero gives inf/NaN instead of raising, so no test and branch per division) and ``refcount=False`` (no array
    reference counting, whose calls stop the vectoriser; only for a function that allocates no array). No
    fast-math: the operations stay the ones written, in their order.
    """
    def build(f: Callable[..., Any]) -> Any:
        options: dict[str, Any] = {"parallel": parallel, "inline": "always" if inline else "never"}
        if error_model != "python":
            options["error_model"] = error_model
        if not refcount:
            options["_nrt"] = False
        return _attach_cache(numba.njit(**options)(f))

    return build if func is None else build(func)
