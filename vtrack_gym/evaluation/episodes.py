"""``Episode``: one scored episode of a suite (env id, seed, reset options, car)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any


@dataclass(frozen=True)
class Episode:
    """One scored episode of a suite: reset with ``seed`` and ``options``, on the env made with ``vehicle`` (a name
    of ``vehicle.list_vehicles()`` or a vehicle file path; ``None``: the default car)."""

    env_id: str
    seed: int
    options: dict[str, Any] = field(default_factory=dict)
    vehicle: str | None = None

    @property
    def make_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of ``gym.make`` for this episode (the vehicle, if one is chosen)."""
        return {} if self.vehicle is None else {"vehicle": self.vehicle}


def with_vehicle(episodes: Sequence[Episode], vehicle: str | None) -> list[Episode]:
    """``episodes`` driven with ``vehicle`` (``None``: unchanged)."""
    return list(episodes) if vehicle is None else [replace(ep, vehicle=str(vehicle)) for ep in episodes]
