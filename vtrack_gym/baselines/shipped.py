"""Agents shipped with the package (``vtrack_gym/baselines/shipped/<name>.json`` + ``.npz``), for the benchmark.

Only agents that were actually trained (``provenance.timesteps > 0`` RL steps, or a recorded ``warm_start``)
and pass ``load_agent``'s checks are listed; the directory may be absent or empty. Pure numpy: no torch/SB3
import.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from vtrack_gym.baselines.numpy_policy import NumpyPolicy, load_agent

SHIPPED_DIR = Path(__file__).with_name("shipped")


def shipped_agents(directory: str | Path = SHIPPED_DIR) -> dict[str, Path]:
    """``{name: json path}`` of every ``<name>.json`` with a matching ``<name>.npz`` in ``directory``."""
    d = Path(directory)
    if not d.is_dir():
        return {}
    return {p.stem: p for p in sorted(d.glob("*.json")) if p.with_suffix(".npz").is_file()}


def shipped_agent_factories(directory: str | Path = SHIPPED_DIR) -> dict[str, Callable[[Any], NumpyPolicy]]:
    """``{name: make(env) -> policy}`` for the shipped agents (loaded and checked once, here)."""
    factories: dict[str, Callable[[Any], NumpyPolicy]] = {}
    for name, path in shipped_agents(directory).items():
        policy = load_agent(path)
        prov = policy.spec["provenance"]
        if prov["timesteps"] <= 0 and not prov.get("warm_start"):  # an untrained network
            continue
        factories[name] = (lambda env, _p=policy: _p)
    return factories
