"""One spelling of an env set-up: an id and its alias are one id, ``45`` and ``45.0`` one number.

Read by ``env_identity`` (what a new row records) and ``board.board_env`` (how stored rows are grouped), so rows
written under an alias or with an int join the rows of the same set-up. Imports nothing of the evaluation
package (the board and the scorers both read it).
"""

from __future__ import annotations

import math
from typing import Any


def canonical_env_id(env_id: str) -> str:
    """The one id of a set-up: a registered alias resolved (``vtrack/DLC120-v0`` -> ``DLC120-v0``, the id the suites
    and existing stores use for the paper scenarios; ``highway-env:lane-keeping-v0`` -> the adapter's id)."""
    from vtrack_gym.envs.scenarios import LEGACY_IDS, NAMESPACE
    from vtrack_gym.interop import ENV_ALIASES

    env_id = ENV_ALIASES.get(env_id, env_id)
    name = env_id.removeprefix(f"{NAMESPACE}/")
    return name if name != env_id and name in LEGACY_IDS else env_id


def normal_numbers(value: Any) -> Any:
    """``value`` (JSON data) with every number as a float (booleans kept), in dicts and lists at any depth, so a
    setting given as ``45`` and as ``45.0`` is one set-up. Integers beyond 2**53 (not exact as floats) are kept."""
    stack: list[Any] = []
    out = _normal_one(value, stack)
    while stack:
        container = stack.pop()
        keys = container.keys() if isinstance(container, dict) else range(len(container))
        for key in keys:
            container[key] = _normal_one(container[key], stack)
    return out


def _normal_one(value: Any, stack: list[Any]) -> Any:
    if isinstance(value, bool) or not isinstance(value, (int, float, dict, list, tuple)):
        return value
    if isinstance(value, int):
        return float(value) if abs(value) <= 2**53 else value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    copied: Any = dict(value) if isinstance(value, dict) else list(value)
    stack.append(copied)
    return copied
