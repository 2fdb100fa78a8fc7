"""One native thread per worker process: the BLAS libraries and torch of a forked worker run single-threaded.

A forked worker inherits its parent's thread settings: numpy's and scipy's OpenBLAS start one thread per core, and
with N workers on N cores every small matrix product (an LQR table, the PD-FLC surface, a fit) wakes threads that
compete with the other workers for the same cores. The episodes are the unit of parallelism, so each worker keeps
one thread. The libraries are found among the shared objects this process has mapped (``/proc/self/maps``: Linux,
where the local backend forks); elsewhere nothing is changed. The thread count never changes a result here: the
rows of ``workers=1`` and ``workers=N`` are compared by the tests.
"""

from __future__ import annotations

import ctypes
import logging
import sys
from pathlib import Path

log = logging.getLogger(__name__)

OPENBLAS_SETTERS = ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
                    "openblas_set_num_threads64_", "openblas_set_num_threads")
"""The thread-count setters an OpenBLAS build may export (scipy-openblas wheels prefix and suffix them)."""


def loaded_openblas(maps: Path = Path("/proc/self/maps")) -> list[str]:
    """Paths of the OpenBLAS shared objects mapped in this process (none when ``maps`` cannot be read)."""
    try:
        lines = maps.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return []
    paths = (parts[5] for parts in (line.split(maxsplit=5) for line in lines) if len(parts) == 6)
    return sorted({p for p in paths if "openblas" in Path(p).name.lower() and ".so" in Path(p).name})


def limit_native_threads(threads: int = 1) -> list[str]:
    """Set every loaded OpenBLAS (and torch, when imported) to ``threads`` threads; the libraries set."""
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be an integer >= 1 (got {threads!r})")
    done = []
    for path in loaded_openblas():
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        setter = next((getattr(lib, name) for name in OPENBLAS_SETTERS if hasattr(lib, name)), None)
        if setter is not None:
            setter(ctypes.c_int(threads))
            done.append(path)
    torch = sys.modules.get("torch")
    if torch is not None and hasattr(torch, "set_num_threads"):
        torch.set_num_threads(threads)
        done.append("torch")
    log.debug("native threads per process: %d (%s)", threads, ", ".join(Path(p).name for p in done) or "none")
    return done
