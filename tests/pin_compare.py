"""Comparing recorded episodes with their behaviour pins: the one set of rules and tolerances of every pin file of
the tests (``env_fingerprint``: the registered ids; ``test_numerics_pins``: the fast numerics;
``test_control_mode_pins``: the longitudinal control modes). What is pinned and why these tolerances:
``env_fingerprint``'s docstring.

An episode is an ``env_fingerprint.Episode``; its pin a JSON entry ``{"exact", "signals", "blocks"}`` (the key of
its block sums in the pin file's ``.npz``), with ``"end_metrics"`` where the success criterion's figures are pinned.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from env_fingerprint import Episode

BLOCK_STEPS = 50
"""Steps summed into one compared value."""
RTOL = 1e-9
"""Relative tolerance of float64 signals (and the floor of every signal, relative to its scale)."""
FLOAT32_RTOL = 2.0 ** -22
"""Relative tolerance of the float32 observation: two units in the last place (a rounding flip is one)."""
ATOL = 1e-11
"""Absolute tolerance per step, in the signal's SI unit: a signal that is zero up to rounding (the curvature
preview on a straight, ~1e-14 1/m) is compared as zero."""


def block_mismatches(now: Episode, pinned_sums: np.ndarray) -> list[str]:
    """The signals of ``now`` whose block sums differ from ``pinned_sums`` beyond the tolerance (empty: a match)."""
    if pinned_sums.shape != now.sums.shape:
        return [f"block shape {now.sums.shape} != pinned {pinned_sums.shape}"]
    scale = now.abs_sums.max(axis=0) / BLOCK_STEPS
    rtol = np.where(now.float32, FLOAT32_RTOL, RTOL)
    allowed = rtol * now.abs_sums + BLOCK_STEPS * (RTOL * scale + ATOL)
    with np.errstate(invalid="ignore", divide="ignore"):
        excess = np.abs(now.sums - pinned_sums) / allowed
    # equal sums match (the same infinity included); anything else must be within the tolerance, so a NaN or an
    # infinity on one side only is a mismatch, never a silent pass
    same = (now.sums == pinned_sums) | (np.isnan(now.sums) & np.isnan(pinned_sums))
    bad = np.flatnonzero((~same & ~(excess <= 1.0)).any(axis=0))
    return [f"{now.signals[j]}: {np.nanmax(np.where(same[:, j], 0.0, excess[:, j])):.3g} x the tolerance"
            for j in bad]


def pinned_columns(now: Episode, names: list[str]) -> Episode | None:
    """``now`` restricted to the pinned signals ``names``, in their order (None when one is missing). A signal
    added to the env later is not part of an old pin."""
    if not set(names) <= set(now.signals):
        return None
    idx = [now.signals.index(name) for name in names]
    return dataclasses.replace(now, signals=names, float32=now.float32[idx], sums=now.sums[:, idx],
                               abs_sums=now.abs_sums[:, idx])


def episode_mismatches(now: Episode, want: dict[str, Any], pinned_sums: np.ndarray, *,
                       same_signals: bool = False) -> list[str]:
    """What differs between one recorded episode and its pin ``want`` (block sums ``pinned_sums``): the exact part
    first, then the signals (``same_signals``: the recorded signals must be the pinned ones, in order; otherwise the
    pinned ones must be among them), then the block sums and the pinned end metrics."""
    if now.exact != want["exact"]:
        return [f"discrete outcome {now.exact} != pinned {want['exact']}"]
    if same_signals:
        if now.signals != want["signals"]:
            return [f"signals {now.signals} != pinned {want['signals']}"]
        columns: Episode | None = now
    else:
        columns = pinned_columns(now, want["signals"])
        if columns is None:
            return [f"pinned signals missing: {sorted(set(want['signals']) - set(now.signals))}"]
    found = block_mismatches(columns, pinned_sums)
    for key, value in want.get("end_metrics", {}).items():
        got = now.end_metrics.get(key, np.nan)
        if not abs(got - value) <= RTOL * max(abs(value), abs(got)):
            found.append(f"{key} {got!r} != pinned {value!r}")
    return found


def pin_mismatches(episodes: list[Episode], pins: list[dict[str, Any]], block_file: Path, *,
                   same_signals: bool = False) -> list[str]:
    """What differs between ``episodes`` and their pins ``pins`` (one entry per episode, in order; block sums in
    ``block_file``), each line prefixed ``episode n:`` (empty: the behaviour is unchanged)."""
    blocks = np.load(block_file)
    return [f"episode {n}: {m}" for n, (now, want) in enumerate(zip(episodes, pins, strict=True))
            for m in episode_mismatches(now, want, blocks[want["blocks"]], same_signals=same_signals)]
