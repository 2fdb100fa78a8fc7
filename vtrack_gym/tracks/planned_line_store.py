"""Shipped planned lines: the version-1 planned lines of the standard ids, stored as data.

``planned_line.plan_line`` solves linear programmes with many optima: a last-bit difference of their inputs (another
CPU's vector code for sin, cos or atan) can move the line it returns. The lines the -v1 ISO 3888 ids drive with
their default car are therefore shipped in ``vtrack_gym/data/planned_lines_v1.npz`` (``STORE_FILE``): the exact
table the planner produced when the ids were pinned, with the planner's inputs recorded beside it (``line_inputs``:
the lanes, gaps, body, approach and run-out, curvature-rate bound, margin, knot spacing, half width, table spacing,
name, version and the planner's constants, every float written exactly as ``float.hex``). ``plan_line`` returns
the shipped line when the request's inputs equal a recorded entry's exactly, and plans otherwise (another car, a
user's own vehicle file, another margin): such a line is the planner's answer on the machine that runs it.

The file also records its table's SHA-256 per entry (checked on load) and the numpy version and CPU features it was
written with (``recorded_on``). ``tests/record_planned_lines.py`` writes an entry for a new configuration; an
existing entry is never rewritten.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path as FilePath
from typing import Any

import numpy as np

from vtrack_gym.tracks import table as tb

STORE_FILE = FilePath(__file__).resolve().parents[1] / "data" / "planned_lines_v1.npz"
"""The shipped lines: ``inputs`` (JSON per entry), ``table_<k>`` (rows, ``STORED_COLS``), ``ds_<k>`` and
``sha256`` (of each full table's bytes), ``recorded_on`` (JSON: numpy version and CPU features), one per entry."""
STORED_COLS = (tb.COL_X, tb.COL_Y, tb.COL_PSI, tb.COL_KAPPA, tb.COL_DKAPPA)
"""The table columns a planned line fills (its elevation columns are zero)."""


def _exact(value: float | None) -> str | None:
    """A float written exactly (``float.hex``), None kept."""
    return None if value is None else float(value).hex()


def line_inputs(lanes: Sequence[Any], gaps_m: Sequence[float], body: Any, *, approach_m: float, run_out_m: float,
                max_curvature_rate_per_m2: float | None, margin_m: float, knot_spacing_m: float,
                half_width_m: float, ds_m: float, name: str, version: str, planner: dict[str, float]) -> str:
    """Canonical JSON of a ``plan_line`` request (lanes [m], body [m], lengths [m], rate bound [1/m^2]; floats
    exact): two requests plan the same line only if these strings are equal."""
    record = {
        "lanes": [[_exact(ln.length_m), _exact(ln.width_m), _exact(ln.centre_y_m), ln.name] for ln in lanes],
        "gaps_m": [_exact(g) for g in gaps_m],
        "body": [_exact(body.length_m), _exact(body.width_m), _exact(body.cg_to_front_m), body.name],
        "approach_m": _exact(approach_m), "run_out_m": _exact(run_out_m),
        "max_curvature_rate_per_m2": _exact(max_curvature_rate_per_m2), "margin_m": _exact(margin_m),
        "knot_spacing_m": _exact(knot_spacing_m), "half_width_m": _exact(half_width_m), "ds_m": _exact(ds_m),
        "name": name, "version": version, "planner": {k: _exact(v) for k, v in sorted(planner.items())}}
    return json.dumps(record, sort_keys=True)


def table_digest(table: np.ndarray, ds_m: float) -> str:
    """SHA-256 of a path table's float64 bytes (C order) and its spacing ``ds_m`` [m]."""
    data = np.ascontiguousarray(table, dtype=np.float64).tobytes() + float(ds_m).hex().encode()
    return hashlib.sha256(data).hexdigest()


@lru_cache(maxsize=1)
def _entries(file: FilePath = STORE_FILE) -> dict[str, tuple[np.ndarray, float, str, str]]:
    """inputs JSON -> (stored columns, ds [m], sha256, recorded_on JSON) of every entry of ``file`` (empty if it
    does not exist)."""
    if not file.exists():
        return {}
    with np.load(file, allow_pickle=False) as data:
        inputs = [str(s) for s in data["inputs"]]
        return {key: (data[f"table_{k}"], float(data["ds"][k]), str(data["sha256"][k]), str(data["recorded_on"][k]))
                for k, key in enumerate(inputs)}


def stored_table(inputs: str, file: FilePath = STORE_FILE) -> tuple[np.ndarray, float] | None:
    """The shipped table (rows, ``tb.N_COLS``) and spacing ``ds`` [m] of the line planned for ``inputs``
    (``line_inputs``), or None when no entry was recorded for exactly these inputs. ValueError if the entry's
    table does not match its recorded SHA-256 (a damaged file)."""
    found = _entries(file).get(inputs)
    if found is None:
        return None
    columns, ds, digest, _ = found
    table = np.zeros((columns.shape[0], tb.N_COLS))
    table[:, STORED_COLS] = columns
    if table_digest(table, ds) != digest:
        raise ValueError(f"{file}: a stored planned line does not match its SHA-256 (the file is damaged)")
    return table, ds


def recorded_on(inputs: str, file: FilePath = STORE_FILE) -> dict[str, Any] | None:
    """The numpy version and its CPU features on the machine that wrote the entry for ``inputs`` (None: none)."""
    found = _entries(file).get(inputs)
    return None if found is None else dict(json.loads(found[3]))


def this_machine() -> dict[str, Any]:
    """The numpy version and the CPU features its vector code uses here (``NPY_DISABLE_CPU_FEATURES`` applied)."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:                      # numpy < 2
        from numpy.core._multiarray_umath import __cpu_features__
    return {"numpy": np.__version__, "cpu_features": sorted(k for k, v in __cpu_features__.items() if v)}


def write_entries(lines: Sequence[tuple[str, np.ndarray, float]], file: FilePath = STORE_FILE) -> int:
    """Add (inputs, table, ds) entries to ``file``; returns how many were new. An entry whose inputs are already
    stored must carry the same table (ValueError otherwise: a shipped line is never rewritten). ValueError if a
    table has non-zero columns outside ``STORED_COLS``."""
    entries = dict(_entries(file))
    added = 0
    for inputs, table, ds in lines:
        other = [c for c in range(tb.N_COLS) if c not in STORED_COLS]
        if np.any(table[:, other] != 0.0) or not math.isfinite(ds):
            raise ValueError("a planned line's table must have zero elevation columns and a finite spacing")
        digest = table_digest(table, ds)
        if inputs in entries:
            if entries[inputs][2] != digest:
                raise ValueError(f"a line is already stored for these inputs with another table: {inputs[:200]}")
            continue
        entries[inputs] = (np.ascontiguousarray(table[:, STORED_COLS]), float(ds), digest,
                           json.dumps(this_machine(), sort_keys=True))
        added += 1
    keys = list(entries)
    arrays = {f"table_{k}": entries[key][0] for k, key in enumerate(keys)}
    np.savez_compressed(file, inputs=np.array(keys), ds=np.array([entries[k][1] for k in keys]),
                        sha256=np.array([entries[k][2] for k in keys]),
                        recorded_on=np.array([entries[k][3] for k in keys]), **arrays)
    _entries.cache_clear()
    return added


__all__ = ["STORE_FILE", "line_inputs", "recorded_on", "stored_table", "table_digest", "this_machine",
           "write_entries"]
