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
    control modes are ranked apart. In ``steer`` an episode's launch is the step (``envs.launch``: the paper's
    PD-FLC holds the set speed from the start)."""
    if control is None:
        return list(episodes)
    from vtrack_gym.envs.control import check_control

    chosen = check_control(control)
    return [replace(ep, control=chosen, launch="step" if chosen == "steer" else ep.launch) for ep in episodes]


def with_launch(episodes: Sequence[Episode], launch: str | None, where_it_applies: bool = False) -> list[Episode]:
    """``episodes`` with their reference leaving a standing start as ``launch`` says (``envs.launch``; ``None``:
    unchanged); the env refuses it where it does not apply, and the rows record it (``options["protocol"]``).
    ``where_it_applies``: only the episodes of an id that holds one set speed from rest (``launch_applies``) take
    it, the others are left as they are; ``ValueError`` when none does, or when one of
    them is driven in ``steer``."""
    if launch is None:
        return list(episodes)
    from vtrack_gym.envs.launch import check_launch

    check_launch(launch)
    if not where_it_applies:
        return [replace(ep, launch=launch) for ep in episodes]
    takes = [launch_applies(ep.env_id) for ep in episodes]
    if not any(takes):
        raise ValueError(f"launch={launch!r} applies to an id that holds one set speed from rest "
                         "(LateralTracking-v0); none of these episodes does")
    if launch != "step" and any(t and ep.control == "steer" for t, ep in zip(takes, episodes, strict=True)):
        raise ValueError(f"launch={launch!r} applies in a longitudinal control mode (control='steer_accel' or "
                         "'steer_rate_accel'); in 'steer' the paper's PD-FLC holds the set speed from the start")
    return [replace(ep, launch=launch) if t else ep for t, ep in zip(takes, episodes, strict=True)]


def launch_applies(env_id: str) -> bool:
    """Whether the registered scenario of ``env_id`` holds one set speed from a standing start (where
    ``launch="powertrain"`` applies, ``envs.launch.held_from_rest``); False for an id that is not a scenario's (a
    user's track id)."""
    from vtrack_gym.envs.launch import held_from_rest
    from vtrack_gym.envs.scenarios import scenario_named

    try:
        scenario = scenario_named(env_id)
    except ValueError:
        return False
    return held_from_rest(scenario) is not None


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
