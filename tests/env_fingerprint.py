"""Behaviour pin of a registered env id: a fixed action sequence from fixed seeds, recorded and compared with a
tolerance that holds on any machine and still catches any change of behaviour.

Two episodes: from seed 0, ``STEPS`` control steps of a fixed action sequence (a sinusoid plus fixed pseudo-random
noise: the car steers off its line and often leaves the road); from seed 7, up to ``FOLLOW_STEPS`` steps of a fixed
proportional law on e_y and e_phi defined here (so the car follows the road far enough to reach its curves, gates
and speed changes). An id whose action is [steering, longitudinal demand] (the race) gets a fixed demand as well
(``_demand``); the signals are the keys of the reset's ``info`` (a race's last step adds its lap times).

What is pinned, per episode:

- **exactly**: the step count, the final ``terminated`` / ``truncated`` flags, every step at which
  ``info["termination"]`` or ``info["success"]`` changes (with the new value), and the success criterion's counts
  (``cones_hit``);
- **within a tolerance**: every observation entry (float32), the reward and every numeric ``info`` signal (float64),
  summed over blocks of ``BLOCK_STEPS`` steps, and the success criterion's figures at the episode's end. A block
  matches when ``|now - pinned| <= rtol * sum|x| + BLOCK_STEPS * (RTOL * scale + ATOL)``, with ``rtol`` =
  ``RTOL`` (1e-9) for float64 signals and ``FLOAT32_RTOL`` (two float32 units in the last place) for the
  observation, ``sum|x|`` the block's sum of absolute values, ``scale`` the largest mean ``|x|`` of a block of that
  signal in the episode and ``ATOL`` 1e-11 in the signal's SI unit (a signal that is zero up to rounding). A pin
  compares the signals it was written with: an ``info`` signal added to the env later is not part of it, a pinned
  one that is gone fails it.

Both sides are tested (``tests/test_env_pin_tolerance.py``): a relative 1e-12 error of the plant's output, or
1e-15 of every state entry at every step, passes; a relative 1e-6 change of any vehicle parameter or speed-loop
gain the pinned episodes exercise fails, by 13 to 7,000 times the tolerance. Two pins equal to the bit are a
stronger guarantee that holds on one machine and one install only (``docs/GUARANTEES.md``).

A registered id's behaviour never changes; a change gets the next version (``-v1``). ``tests/test_env_versions.py``
compares every registered id against ``tests/data/env_fingerprints.json`` (the exact part) and
``tests/data/env_fingerprints.npz`` (the block sums); the pin of an id that is no longer registered stays in the
file, and the test checks that making it raises Gymnasium's ``DeprecatedEnv``.

Writing the files (only for an id that is new, never to change an existing entry)::

    python tests/env_fingerprint.py --add vtrack/NewScenario-v0
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pin_compare import BLOCK_STEPS, pin_mismatches

PIN_FILE = Path(__file__).parent / "data" / "env_fingerprints.json"
BLOCK_FILE = PIN_FILE.with_suffix(".npz")
SEQUENCE_SEED = 0
FOLLOW_SEED = 7
STEPS = 300
FOLLOW_STEPS = 3000
EXACT_METRICS = ("cones_hit",)
"""Success-criterion figures that are counts, compared exactly."""


def action_sequence(steps: int = STEPS) -> np.ndarray:
    """The fixed steering commands (fraction of the road-wheel limit), shape (steps,)."""
    k = np.arange(steps)
    noise = np.random.default_rng(20261202).uniform(-0.03, 0.03, steps)
    return (0.08 * np.sin(2.0 * np.pi * k / 150.0) + noise).astype(np.float32)


def _demand(seed: int, k: int, obs: np.ndarray, layout: Any) -> float:
    """The longitudinal demand of an id whose action is [steering, demand] (``vtrack/Race-v0``): a slow wave
    through throttle and brake in the sequence episode, a proportional law on the speed error in the follower's."""
    if seed == SEQUENCE_SEED:
        return float(np.float32(0.4 * np.cos(2.0 * np.pi * k / 100.0) + 0.1))
    return float(np.clip(-0.5 * obs[layout.index("speed_error")], -1.0, 1.0))


@dataclass
class Episode:
    """One recorded episode: ``exact`` (JSON-able, compared with ==), ``sums`` / ``abs_sums`` (blocks x signals)."""

    exact: dict[str, Any]
    signals: list[str]
    float32: np.ndarray
    """bool per signal: an observation entry (compared at ``FLOAT32_RTOL``)."""
    sums: np.ndarray
    abs_sums: np.ndarray
    end_metrics: dict[str, float] = field(default_factory=dict)


def _signal_row(obs: np.ndarray, reward: float, info: dict[str, Any]) -> tuple[list[str], np.ndarray]:
    """Names and float64 values of one step's signals: observation entries, reward, numeric info (an array entry
    is summed over all but its last axis)."""
    names = [f"obs[{i}]" for i in range(obs.size)] + ["reward"]
    values = [np.asarray(obs, dtype=np.float64).ravel(), np.array([reward], dtype=np.float64)]
    for key in sorted(info):
        value = info[key]
        if isinstance(value, (bool, np.bool_, str)):
            continue
        arr = np.asarray(value, dtype=np.float64)
        arr = arr.reshape(-1, arr.shape[-1]).sum(axis=0) if arr.ndim > 1 else arr.ravel()
        names += [key] if arr.ndim == 0 or arr.size == 1 else [f"{key}[{i}]" for i in range(arr.size)]
        values.append(arr.ravel())
    return names, np.concatenate(values)


def _blocks(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Block sums and block sums of absolute values of ``rows`` (steps x signals), ``BLOCK_STEPS`` per block."""
    starts = np.arange(0, len(rows), BLOCK_STEPS)
    return np.add.reduceat(rows, starts, axis=0), np.add.reduceat(np.abs(rows), starts, axis=0)


def _episode(env: Any, seed: int, steps: int) -> Episode:
    """Run one pinned episode of ``env`` (the sequence from ``SEQUENCE_SEED``, the follower otherwise)."""
    layout = env.unwrapped.observation_layout
    e_y, e_phi = layout.index("e_y"), layout.index("e_phi")
    obs, info = env.reset(seed=seed)
    names, row = _signal_row(obs, 0.0, info)
    rows, events, last = [row], [], ("", False)
    sequence = action_sequence()
    terminated = truncated = False
    k = 0
    at_reset = set(info)   # an id's last step may carry more (a race's lap times): the rows keep the reset's keys
    pair = env.action_space.shape == (2,)
    for k in range(steps):
        if seed == SEQUENCE_SEED:
            action = sequence[k]
        else:  # fixed follower: 0.5 rad of command per metre of e_y, 1.5 per radian of e_phi
            action = np.clip(-0.5 * obs[e_y] - 1.5 * obs[e_phi], -1.0, 1.0)
        act = [action, _demand(seed, k, obs, layout)] if pair else [action]
        obs, reward, terminated, truncated, info = env.step(np.array(act, dtype=np.float32))
        rows.append(_signal_row(obs, reward, {key: v for key, v in info.items() if key in at_reset})[1])
        now = (str(info["termination"]), bool(info["success"]))
        if now != last:
            events.append([k + 1, *now])
            last = now
        if terminated or truncated:
            break
    sums, abs_sums = _blocks(np.array(rows))
    metrics = {key: float(v) for key, v in env.unwrapped.success_metrics().items() if np.isfinite(v)}
    exact = {"seed": seed, "steps": k + 1, "terminated": bool(terminated), "truncated": bool(truncated),
             "events": events, "counts": {key: metrics.pop(key) for key in EXACT_METRICS if key in metrics}}
    float32 = np.array([name.startswith("obs[") for name in names])
    return Episode(exact, names, float32, sums, abs_sums, metrics)


def record(env_id: str, **make_kwargs: Any) -> list[Episode]:
    """The two pinned episodes of ``gym.make(env_id, **make_kwargs)``."""
    import gymnasium as gym

    import vtrack_gym  # noqa: F401  (registers the ids)

    env = gym.make(env_id, **make_kwargs)
    try:
        return [_episode(env, seed, steps) for seed, steps in ((SEQUENCE_SEED, STEPS), (FOLLOW_SEED, FOLLOW_STEPS))]
    finally:
        env.close()


def mismatches(env_id: str, episodes: list[Episode]) -> list[str]:
    """What differs between ``episodes`` and the pin of ``env_id`` (empty: the behaviour is unchanged)."""
    return pin_mismatches(episodes, pinned()[env_id]["episodes"], BLOCK_FILE)


def pinned() -> dict[str, dict[str, Any]]:
    """The pins, id -> {"episodes": [...]} (a deprecated id's entry may hold only ``legacy_sha256``)."""
    return json.loads(PIN_FILE.read_text())["pins"]


def pin_entries(env_id: str, episodes: list[Episode], arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """The JSON entry of ``env_id``; its block sums go into ``arrays`` under the id's own key ``id|n``, which is
    overwritten (a re-pin never keeps a stale array), or under another key that holds an identical array (stored
    once)."""
    entry: dict[str, Any] = {"episodes": []}
    for n, ep in enumerate(episodes):
        own = f"{env_id}|{n}"
        key = next((k for k, a in arrays.items() if k != own and np.array_equal(a, ep.sums)), own)
        if key == own:
            arrays[own] = ep.sums
        entry["episodes"].append({"exact": ep.exact, "signals": ep.signals, "blocks": key,
                                  "end_metrics": ep.end_metrics})
    return entry


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Pin the behaviour of a new env id.")
    parser.add_argument("--add", nargs="+", required=True, metavar="ENV_ID", help="new ids to pin")
    args = parser.parse_args(argv)
    data = json.loads(PIN_FILE.read_text()) if PIN_FILE.exists() else {"pins": {}}
    arrays = dict(np.load(BLOCK_FILE)) if BLOCK_FILE.exists() else {}
    for env_id in args.add:
        if env_id in data["pins"]:
            print(f"{env_id} is pinned already; a behaviour change needs a new version, not a new pin",
                  file=sys.stderr)
            return 2
        data["pins"][env_id] = pin_entries(env_id, record(env_id), arrays)
    data["pins"] = dict(sorted(data["pins"].items()))
    used = {ep["blocks"] for pin in data["pins"].values() for ep in pin.get("episodes", [])}
    arrays = {k: a for k, a in arrays.items() if k in used}   # a re-pinned id's own key no longer used
    PIN_FILE.write_text(json.dumps(data, indent=1) + "\n")
    np.savez_compressed(BLOCK_FILE, **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main())
