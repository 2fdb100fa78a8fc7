"""Behaviour pins of the longitudinal control modes (``control="steer_accel"`` / ``"steer_rate_accel"``).

``tests/env_fingerprint.py`` pins registered ids with a one-element action sequence; a control mode is a make
kwarg with a two-element action, so its pins live here, recorded and compared with the same machinery and
tolerance: the step count, the final flags and every change of ``info["termination"]`` / ``info["success"]``
exactly; the observation (float32: two units in the last place), the reward and every numeric ``info`` signal
(float64: rtol 1e-9) as sums over blocks of ``BLOCK_STEPS`` steps.

Two episodes per case: from seed 0, ``STEPS`` steps of a fixed sequence (the fingerprint's steering sequence and a
fixed demand wave); from seed 7, up to ``FOLLOW_STEPS`` steps of a fixed follower defined here (the fingerprint's
proportional steering law and a proportional law on the observation's speed error).

Writing the files (only for a case that is new, never to change a pinned one)::

    python tests/test_control_mode_pins.py --add DLC120-v0:steer_accel
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from env_fingerprint import Episode, _blocks, _signal_row, action_sequence
from pin_compare import RTOL, pin_mismatches

PIN_FILE = Path(__file__).parent / "data" / "control_mode_pins.json"
BLOCK_FILE = PIN_FILE.with_suffix(".npz")
STEPS = 300
FOLLOW_STEPS = 1500
CASES = ("DLC120-v0:steer_accel", "DLC120-v0:steer_rate_accel", "LateralTracking-v0:steer_accel",
         "vtrack/TrainingMix-v0:steer_rate_accel")


def demand_sequence(steps: int = STEPS) -> np.ndarray:
    """The fixed longitudinal demands of the sequence episode: a slow wave through throttle and brake."""
    k = np.arange(steps)
    return (0.4 * np.cos(2.0 * np.pi * k / 100.0) + 0.1).astype(np.float32)


def _action(seed: int, k: int, obs: np.ndarray, layout: Any) -> np.ndarray:
    if seed == 0:
        return np.array([action_sequence()[k], demand_sequence()[k]], dtype=np.float32)
    steer = np.clip(-0.5 * obs[layout.index("e_y")] - 1.5 * obs[layout.index("e_phi")], -1.0, 1.0)
    demand = np.clip(-0.5 * obs[layout.index("speed_error")], -1.0, 1.0)
    return np.array([steer, demand], dtype=np.float32)


def _episode(env: Any, seed: int, steps: int) -> Episode:
    layout = env.unwrapped.observation_layout
    obs, info = env.reset(seed=seed)
    rows, events, last = [_signal_row(obs, 0.0, info)[1]], [], ("", False)
    names = _signal_row(obs, 0.0, info)[0]
    terminated = truncated = False
    k = 0
    for k in range(steps):
        obs, reward, terminated, truncated, info = env.step(_action(seed, k, obs, layout))
        rows.append(_signal_row(obs, reward, info)[1])
        now = (str(info["termination"]), bool(info["success"]))
        if now != last:
            events.append([k + 1, *now])
            last = now
        if terminated or truncated:
            break
    sums, abs_sums = _blocks(np.array(rows))
    exact = {"seed": seed, "steps": k + 1, "terminated": bool(terminated), "truncated": bool(truncated),
             "events": events}
    return Episode(exact, names, np.array([n.startswith("obs[") for n in names]), sums, abs_sums)


def record(case: str) -> list[Episode]:
    """The two pinned episodes of ``case`` (``ENV_ID:CONTROL``)."""
    import gymnasium as gym

    import vtrack_gym  # noqa: F401  (registers the ids)

    env_id, control = case.rsplit(":", 1)
    env = gym.make(env_id, control=control)
    try:
        return [_episode(env, 0, STEPS), _episode(env, 7, FOLLOW_STEPS)]
    finally:
        env.close()


def mismatches(case: str, episodes: list[Episode]) -> list[str]:
    """What differs between ``episodes`` and the pin of ``case`` (empty: unchanged); the recorded signals must be
    the pinned ones."""
    return pin_mismatches(episodes, json.loads(PIN_FILE.read_text())["pins"][case], BLOCK_FILE, same_signals=True)


@pytest.mark.parametrize("case", CASES)
def test_control_mode_behaviour_unchanged(case: str) -> None:
    found = mismatches(case, record(case))
    assert not found, f"{case} behaves differently from its pin: {found[:8]}"


def test_the_pins_catch_a_change_of_the_brake_map() -> None:
    """A relative 1e-6 change of the brake pedal force (what demand -1 brakes with) fails the pin."""
    import dataclasses

    import gymnasium as gym

    from vtrack_gym.vehicle.params import VehicleParams

    car = VehicleParams()
    changed = dataclasses.replace(car, brakes=dataclasses.replace(
        car.brakes, max_pedal_force_n=car.brakes.max_pedal_force_n * (1.0 + 1e-6)))
    env = gym.make("DLC120-v0", control="steer_accel", vehicle=changed)
    assert mismatches("DLC120-v0:steer_accel", [_episode(env, 0, STEPS), _episode(env, 7, FOLLOW_STEPS)])
    assert RTOL == 1e-9


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Pin a new control-mode case (ENV_ID:CONTROL).")
    parser.add_argument("--add", nargs="+", required=True, metavar="ENV_ID:CONTROL")
    args = parser.parse_args(argv)
    data = json.loads(PIN_FILE.read_text()) if PIN_FILE.exists() else {"pins": {}}
    arrays = dict(np.load(BLOCK_FILE)) if BLOCK_FILE.exists() else {}
    for case in args.add:
        if case in data["pins"]:
            print(f"{case} is pinned already; a behaviour change is not re-pinned", file=sys.stderr)
            return 2
        entry = []
        for n, ep in enumerate(record(case)):
            key = f"{case}|{n}"
            arrays[key] = ep.sums
            entry.append({"exact": ep.exact, "signals": ep.signals, "blocks": key})
        data["pins"][case] = entry
    data["pins"] = dict(sorted(data["pins"].items()))
    PIN_FILE.write_text(json.dumps(data, indent=1) + "\n")
    np.savez_compressed(BLOCK_FILE, **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main())
