"""The decision period a model was trained at, where its files record it, against the env an export records.

An SB3 ``model.zip`` does not record its env's decision period, but a ``vtrack train`` run folder does: its
``config.json`` names the training env id and the hyperparameters' ``env_kwargs`` (``control_period_s`` when the
recipe changed it). ``check_export_period`` refuses an export of such a model (``vtrack export --model
RUN/model.zip --env X``) whose env decides at another period than the model was trained at, naming both: the agent
file would record the export env's period, and the agent would be driven at a timing it never saw.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

MAX_CONFIG_BYTES = 1 << 20
"""Largest ``config.json`` read next to a model [bytes]."""


def _period(env_id: str, env_kwargs: dict[str, Any]) -> float:
    """The decision period [s] of ``env_id`` made with ``env_kwargs`` (``baselines.base.env_contract``); a scenario
    name that is not an id of its own (``TrainingMix-v0``, as training records it) is its ``vtrack/`` id."""
    import gymnasium as gym

    from vtrack_gym.baselines.base import env_contract
    from vtrack_gym.envs.scenarios import NAMESPACE

    if env_id not in gym.registry and f"{NAMESPACE}/{env_id}" in gym.registry:
        env_id = f"{NAMESPACE}/{env_id}"
    env = gym.make(env_id, **env_kwargs)
    try:
        return float(env_contract(env)[2])
    finally:
        env.close()


def recorded_training_period(model_zip: str | Path) -> tuple[float, str] | None:
    """``(decision period [s], where it is recorded)`` of a model that lies in a ``vtrack train`` run folder (a
    ``config.json`` with its training env id next to it); None when no such record is there or its env cannot be
    made here (nothing is guessed)."""
    from vtrack_gym._io import read_regular_file

    config_file = Path(model_zip).parent / "config.json"
    if not config_file.is_file():
        return None
    try:
        config = json.loads(read_regular_file(config_file, MAX_CONFIG_BYTES, "run config"))
        env_id = str(config.get("env_id") or config.get("env") or "")
        hyper = config.get("hyperparams")
        raw = hyper.get("env_kwargs") if isinstance(hyper, dict) else None
        period = raw.get("control_period_s") if isinstance(raw, dict) else None
        kwargs = {} if period is None else {"control_period_s": float(period)}   # the one setting read here
        if not env_id:
            return None
        where = f"{config_file}: env {env_id}" + (f", control_period_s {kwargs['control_period_s']:g}"
                                                  if "control_period_s" in kwargs else "")
        return _period(env_id, kwargs), where
    except Exception:  # a malformed record, or an env id of another installation: nothing to compare with
        return None


def check_export_period(model_zip: str | Path, env_id: str, env_kwargs: dict[str, Any] | None) -> None:
    """``ValueError`` naming both periods when ``model_zip``'s run records a training decision period other than
    that of ``env_id`` made with ``env_kwargs`` (the env the export records)."""
    recorded = recorded_training_period(model_zip)
    if recorded is None or not env_id:
        return
    trained, where = recorded
    exported = _period(env_id, dict(env_kwargs or {}))
    if not math.isclose(trained, exported, rel_tol=1e-9):
        raise ValueError(f"--model {model_zip} was trained deciding every {trained:g} s ({where}), but the export "
                         f"env {env_id} decides every {exported:g} s: the agent file would record the wrong decision "
                         f"period. Pass --control-period-s {trained:g} (or the training --env), or export the run "
                         "folder with --run-dir")
