"""Name -> steering baseline registry: ``make_policy(name, env, preset="default", **overrides)``.

Names: ``available_policies()`` (the keys of ``_POLICIES``, then those registered from outside with
``register_policy`` or the ``vtrack_gym.policies`` entry point); each policy's page in ``docs/baselines/`` says
what it is and which extra it needs (``mpc_osqp``: osqp; ``nmpc``: casadi for its ``casadi`` and ``converged``
presets). Controller modules are imported on first use, so ``import vtrack_gym.baselines.registry`` is cheap and
works without osqp or casadi.
"""

from __future__ import annotations

import importlib
from typing import Any

from vtrack_gym.baselines.base import Policy

_POLICIES: dict[str, tuple[str, str]] = {
    "smc": ("vtrack_gym.baselines.smc", "SMC"),
    "mpc": ("vtrack_gym.baselines.mpc", "MPC"),
    "lqr": ("vtrack_gym.baselines.lqr", "LQR"),
    "stanley": ("vtrack_gym.baselines.stanley", "Stanley"),
    "pure_pursuit": ("vtrack_gym.baselines.pure_pursuit", "PurePursuit"),
    "mpc_osqp": ("vtrack_gym.baselines.mpc_osqp", "OSQPMPC"),
    "nmpc": ("vtrack_gym.baselines.nmpc", "NMPC"),
}
_RACE_POLICIES: dict[str, tuple[str, str]] = {
    "raceline": ("vtrack_gym.baselines.race_line", "RaceLine"),
    "centreline": ("vtrack_gym.baselines.race_line", "CentreLine"),
    "raceline_coupled": ("vtrack_gym.baselines.race_line_coupled", "CoupledRaceLine"),
}
"""The race baselines (``baselines.race_line``): steering and pedals on the race env (``vtrack/Race-v0``) only, so
they are not among ``available_policies()`` (the steering baselines every env takes) but ``race_policies()``."""
_PEDAL_POLICIES: dict[str, tuple[str, str]] = {
    "nmpc_coupled": ("vtrack_gym.baselines.nmpc_coupled", "CoupledNMPC"),
}
"""Baselines that send the steering command and the longitudinal demand themselves (``control="steer_accel"``
only): not among ``available_policies()`` (which every env takes) but ``pedal_policies()``."""


_TUNING: dict[str, tuple[str, str]] = {
    "smc": ("vtrack_gym.baselines.smc_tuning", "SMC_TUNING"),
    "mpc": ("vtrack_gym.baselines.mpc_tuning", "MPC_TUNING"),
}
"""GA-tunable policies: name -> their tuning declaration (``baselines.tunable.ControllerTuning``)."""


ENTRY_POINT_GROUP = "vtrack_gym.policies"
"""Entry-point group of policies from installed packages (each entry point loads a ``Policy`` subclass, registered
under its ``name``)."""
_ADDED: dict[str, type[Policy]] = {}
"""Policies registered from outside the package (``register_policy``, entry points)."""
_LOADED_ENTRY_POINTS: dict[str, str] = {}


def register_policy(cls: type[Policy], replace: bool = False) -> type[Policy]:
    """Register the ``Policy`` subclass ``cls`` under ``cls.name`` (a lowercase identifier, not a built-in name);
    a ``tuning()`` classmethod returning a ``baselines.tunable.ControllerTuning`` makes it GA-tunable
    (``vtrack tune --controller NAME``). Returns ``cls``."""
    if not (isinstance(cls, type) and issubclass(cls, Policy)):
        raise ValueError(f"register_policy takes a Policy subclass (got {cls!r})")
    name = cls.name
    if not isinstance(name, str) or not name.isidentifier() or name != name.lower():
        raise ValueError(f"{cls.__name__}.name must be a lowercase identifier such as my_law (got {name!r})")
    if name in _POLICIES or (name in _ADDED and not replace and _ADDED[name] is not cls):
        raise ValueError(f"a policy named {name!r} is registered already; choose another {cls.__name__}.name")
    _ADDED[name] = cls
    return cls


def unregister_policy(name: str) -> None:
    """Remove a policy registered with ``register_policy`` (a no-op for other names)."""
    from vtrack_gym._plugins import forget

    _ADDED.pop(name, None)
    forget(_LOADED_ENTRY_POINTS, name)


def _register_entry_point(cls: Any, where: str) -> str:
    if not (isinstance(cls, type) and issubclass(cls, Policy)):
        raise ValueError(f"{where} must be a vtrack_gym Policy subclass (got {cls!r})")
    return register_policy(cls, replace=True).name


def _added() -> dict[str, type[Policy]]:
    """The policies registered from outside, entry points of installed packages loaded first."""
    from vtrack_gym._plugins import load_group

    load_group(ENTRY_POINT_GROUP, _register_entry_point, _LOADED_ENTRY_POINTS)
    return _ADDED


def tunable_policies() -> tuple[str, ...]:
    """Registered policy names with a GA tuning declaration (built-in ones first)."""
    return (*_TUNING, *(n for n, cls in _added().items() if callable(getattr(cls, "tuning", None))))


def policy_tuning(name: str) -> Any:
    """The ``ControllerTuning`` of the registered policy ``name`` (``ValueError`` if it has none)."""
    if name not in tunable_policies():
        raise ValueError(f"{name!r} is not GA-tunable; tunable: {', '.join(tunable_policies())}")
    if name in _TUNING:
        module, attr = _TUNING[name]
        return getattr(importlib.import_module(module), attr)
    return _ADDED[name].tuning()  # type: ignore[attr-defined]


def available_policies() -> tuple[str, ...]:
    """Registered policy names (built-in ones first)."""
    return (*_POLICIES, *_added())


def race_policies() -> tuple[str, ...]:
    """The race baselines' names (the decoupled ones and the coupled form): they drive the race env only."""
    return tuple(_RACE_POLICIES)


def pedal_policies() -> tuple[str, ...]:
    """The baselines that drive steering and pedals in ``steer_accel`` envs (``nmpc_coupled``)."""
    return tuple(_PEDAL_POLICIES)


def known_policies() -> tuple[str, ...]:
    """Every name ``make_policy`` takes: ``available_policies()``, ``race_policies()`` and ``pedal_policies()``."""
    return (*available_policies(), *race_policies(), *pedal_policies())


def policy_class(name: str) -> type[Policy]:
    """The controller class registered as ``name`` (``ValueError`` listing the valid names if unknown)."""
    added = _added()
    if name in added:
        return added[name]
    known = {**_POLICIES, **_RACE_POLICIES, **_PEDAL_POLICIES}
    if name not in known:
        raise ValueError(f"unknown policy {name!r}; valid: {', '.join(known_policies())}")
    module, attr = known[name]
    return getattr(importlib.import_module(module), attr)


def available_presets(name: str) -> tuple[str, ...]:
    """Preset names of policy ``name``."""
    return policy_class(name).preset_names()


def make_policy(name: str, env: Any, preset: str = "default", **overrides: Any) -> Policy:
    """Build policy ``name`` for ``env`` from ``preset`` with config-field ``overrides``.

    Unknown names, presets or fields raise ``ValueError`` listing the valid ones. For smc and mpc, ``default``
    and ``tuned`` are the packaged GA result ``vtrack_gym/baselines/presets/<name>_tuned.json`` (JSON only,
    strict schema; ``ValueError`` if the file is missing or invalid; see ``vtrack_gym.baselines.preset_files``),
    ``hand`` the hand-tuned config and ``paper`` the paper's Table 3.

    For an env in a longitudinal control mode (``steer_accel``, ``steer_rate_accel``) the steering law is paired
    with a speed law built on the paper's PD-FLC (``baselines.decoupled.Decoupled``, ``baselines.speed_law``), and
    a policy may build its own preset for those modes instead of ``default`` (``Policy.preset_for_control``: smc's
    ``accel``, high-speed gains; ``preset="tuned"`` is the steer mode's default in any mode).
    """
    from vtrack_gym.baselines.decoupled import control_of, for_control

    cls = policy_class(name)
    chosen = cls.preset_for_control(preset, control_of(env)) if hasattr(cls, "preset_for_control") else preset
    return for_control(cls.from_env(env, preset=chosen, **overrides), env)
