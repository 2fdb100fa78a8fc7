"""``Episode``: one scored episode of a suite (env id, seed, reset options, car)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any


@dataclass(frozen=True)
class Episode:
    """One scored episode of a suite: reset with ``seed`` and ``options``, on the env made with ``vehicle`` (a name
    of ``vehicle.list_vehicles()``, a vehicle file path or a ``vehicle.catalog.VehicleFile`` read once; ``None``:
    the default car)."""

    env_id: str
    seed: int
    options: dict[str, Any] = field(default_factory=dict)
    vehicle: Any = None

    @property
    def make_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of ``gym.make`` for this episode (the vehicle, if one is chosen)."""
        return {} if self.vehicle is None else {"vehicle": self.vehicle}


def with_vehicle(episodes: Sequence[Episode], vehicle: Any) -> list[Episode]:
    """``episodes`` driven with ``vehicle`` (a name, a path, a ``vehicle.catalog.VehicleFile``; ``None``:
    unchanged)."""
    if vehicle is None:
        return list(episodes)
    from vtrack_gym.vehicle.catalog import VehicleFile

    chosen = vehicle if isinstance(vehicle, VehicleFile) else str(vehicle)   # a file read once stays as read
    return [replace(ep, vehicle=chosen) for ep in episodes]
