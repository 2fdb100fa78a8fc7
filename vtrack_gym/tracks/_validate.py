"""Range checks for the frozen parameter dataclasses of the tracks subpackage."""

from __future__ import annotations

import math


def check_range(owner: object, name: str, low: float, high: float, *, low_open: bool = True,
                high_open: bool = False) -> None:
    """Raise ValueError naming ``Owner.name`` and the allowed range unless the value is a finite number in it."""
    value = getattr(owner, name)
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        ok = (value > low if low_open else value >= low) and (value < high if high_open else value <= high)
    if not ok:
        interval = f"{'(' if low_open else '['}{low}, {high}{')' if high_open else ']'}"
        raise ValueError(f"{type(owner).__name__}.{name} must be in {interval} (got {value!r})")
