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


def with_latency(episodes: Sequence[Episode], latency: Any) -> list[Episode]:
    """``episodes`` with each decision's compute charged (``envs.latency``): ``"measured"`` (the policy call's
    time) or a fixed budget in seconds, added to their reset options (``latency`` / ``latency_s``), so their rows
    record it and rank apart from the ideal ones; ``None`` or ``"off"``: unchanged. ``ValueError`` for anything
    else."""
    from vtrack_gym.envs.latency import Latency

    chosen = Latency.parse(latency)
    if not chosen.on:
        return list(episodes)
    option = {"latency": "measured"} if chosen.mode == "measured" else {"latency_s": chosen.seconds}
    return [replace(ep, options={**ep.options, **option}) for ep in episodes]
