"""``Episode``: one scored episode of a suite (env id, seed, reset options, car)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any


@dataclass(frozen=True)
class Episode:
    """One scored episode of a suite: reset with ``seed`` and ``options``, on the env made with ``vehicle`` (a name
    of ``vehicle.list_vehicles()``, a vehicle file path or a ``vehicle.catalog.VehicleFile`` read once; ``None``:
    the default car), in the control mode ``control`` (``envs.control``: ``"steer"``, the default, or a
    longitudinal mode), its reference leaving a standing start as ``launch`` says (``envs.launch``), its cars
    integrated by the plant's ``numerics`` mode (``vehicle.numerics``: ``"default"`` or ``"fast"``)."""

    env_id: str
    seed: int
    options: dict[str, Any] = field(default_factory=dict)
    vehicle: Any = None
    control: str = "steer"
    launch: str = "step"
    numerics: str = "default"

    @property
    def make_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of ``gym.make`` for this episode (the vehicle, if one is chosen; the control mode, if
        not ``steer``)."""
        kwargs: dict[str, Any] = {} if self.vehicle is None else {"vehicle": self.vehicle}
        if self.control != "steer":
            kwargs["control"] = self.control
        if self.launch != "step":
            kwargs["launch"] = self.launch
        if self.numerics != "default":
            kwargs["numerics"] = self.numerics
        return kwargs


def with_vehicle(episodes: Sequence[Episode], vehicle: Any) -> list[Episode]:
    """``episodes`` driven with ``vehicle`` (a name, a path, a ``vehicle.catalog.VehicleFile``; ``None``:
    unchanged)."""
    if vehicle is None:
        return list(episodes)
    from vtrack_gym.vehicle.catalog import VehicleFile

    chosen = vehicle if isinstance(vehicle, VehicleFile) else str(vehicle)   # a file read once stays as read
    return [replace(ep, vehicle=chosen) for ep in episodes]


def with_control(episodes: Sequence[Episode], control: str | None) -> list[Episode]:
    """``episodes`` driven in the control mode ``control`` (``envs.control``; ``None``: unchanged); ``ValueError``
    naming ``control`` and the allowed values for anything else. Their rows record it (``options["control"]``), so
    control modes are ranked apart."""
    if control is None:
        return list(episodes)
    from vtrack_gym.envs.control import check_control

    return [replace(ep, control=check_control(control)) for ep in episodes]


def with_launch(episodes: Sequence[Episode], launch: str | None) -> list[Episode]:
    """``episodes`` with their reference leaving a standing start as ``launch`` says (``envs.launch``; ``None``:
    unchanged); the env refuses it where it does not apply, and the rows record it (``options["protocol"]``)."""
    if launch is None:
        return list(episodes)
    from vtrack_gym.envs.launch import check_launch

    return [replace(ep, launch=check_launch(launch)) for ep in episodes]


def with_numerics(episodes: Sequence[Episode], numerics: str | None) -> list[Episode]:
    """``episodes`` with their cars integrated by the plant's ``numerics`` mode (``vehicle.numerics``; ``None``:
    unchanged); ``ValueError`` naming the allowed values for anything else. Their rows record a mode other than
    ``default`` (``options["env_config"]["numerics"]``, as ``env_identity`` records an env made with it), so the
    two modes are ranked apart."""
    if numerics is None:
        return list(episodes)
    from vtrack_gym.vehicle.numerics import check_numerics

    return [replace(ep, numerics=check_numerics(numerics)) for ep in episodes]


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
