"""Name -> steering baseline registry: ``make_policy(name, env, preset="default", **overrides)``.

Names: ``smc`` (paper SMC), ``mpc`` (paper MPC, precomputed gains), ``lqr``, ``stanley``, ``pure_pursuit``,
``mpc_osqp`` (constrained MPC, needs the ``osqp`` package), ``nmpc`` (nonlinear MPC, needs ``casadi``: the
``nmpc`` extra). Controller modules are imported on first use, so ``import vtrack_gym.baselines.registry`` is
cheap and works without osqp or casadi.
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


_TUNING: dict[str, tuple[str, str]] = {
    "smc": ("vtrack_gym.baselines.smc_tuning", "SMC_TUNING"),
    "mpc": ("vtrack_gym.baselines.mpc_tuning", "MPC_TUNING"),
}
"""GA-tunable policies: name -> their tuning declaration (``baselines.tunable.ControllerTuning``)."""


def tunable_policies() -> tuple[str, ...]:
    """Registered policy names with a GA tuning declaration."""
    return tuple(_TUNING)


def policy_tuning(name: str) -> Any:
    """The ``ControllerTuning`` of the registered policy ``name`` (``ValueError`` if it has none)."""
    if name not in _TUNING:
        raise ValueError(f"{name!r} is not GA-tunable; tunable: {', '.join(_TUNING)}")
    module, attr = _TUNING[name]
    return getattr(importlib.import_module(module), attr)


def available_policies() -> tuple[str, ...]:
    """Registered policy names."""
    return tuple(_POLICIES)


def policy_class(name: str) -> type[Policy]:
    """The controller class registered as ``name`` (``ValueError`` listing the valid names if unknown)."""
    if name not in _POLICIES:
        raise ValueError(f"unknown policy {name!r}; valid: {', '.join(_POLICIES)}")
    module, attr = _POLICIES[name]
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
    """
    return policy_class(name).from_env(env, preset=preset, **overrides)
