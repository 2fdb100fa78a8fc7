"""Behaviour pins of the ``fast`` numerics mode (``gym.make(..., numerics="fast")``, ``vehicle.numerics``).

``tests/env_fingerprint.py`` pins registered ids in the default numerics; the fast mode is a make kwarg, so its
pins live here, recorded and compared with the same machinery and tolerance (the step count, the final flags and
every change of ``info["termination"]`` / ``info["success"]`` exactly; the observation within two float32 units in
the last place, the reward and every numeric ``info`` signal within rtol 1e-9, as sums over blocks of steps), the
fingerprint's two episodes per case (its steering sequence from seed 0, its follower from seed 7).

Writing the files (only for a case that is new, never to change a pinned one)::

    python tests/test_numerics_pins.py --add DLC120-v0
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from env_fingerprint import Episode, pin_entries, record
from pin_compare import RTOL, pin_mismatches

PIN_FILE = Path(__file__).parent / "data" / "numerics_pins.json"
BLOCK_FILE = PIN_FILE.with_suffix(".npz")
NUMERICS = "fast"
CASES = ("DLC120-v0", "LateralTracking-v0")


def fast_record(env_id: str) -> list[Episode]:
    """The two pinned episodes of ``gym.make(env_id, numerics="fast")``."""
    return record(env_id, numerics=NUMERICS)


def mismatches(env_id: str, episodes: list[Episode]) -> list[str]:
    """What differs between ``episodes`` and the fast-mode pin of ``env_id`` (empty: unchanged)."""
    return pin_mismatches(episodes, json.loads(PIN_FILE.read_text())["pins"][env_id]["episodes"], BLOCK_FILE)


@pytest.mark.parametrize("env_id", CASES)
def test_fast_numerics_behaviour_unchanged(env_id: str) -> None:
    found = mismatches(env_id, fast_record(env_id))
    assert not found, f"{env_id} (numerics='fast') behaves differently from its pin: {found[:8]}"


def test_the_fast_pins_catch_a_change_of_the_tyres() -> None:
    """A relative 1e-6 change of the front cornering stiffness fails the fast mode's pin."""
    import dataclasses

    import gymnasium as gym
    from env_fingerprint import FOLLOW_SEED, FOLLOW_STEPS, SEQUENCE_SEED, STEPS, _episode

    from vtrack_gym.vehicle.params import VehicleParams

    car = VehicleParams()
    changed = dataclasses.replace(car, tyres=dataclasses.replace(
        car.tyres, front_cornering_stiffness_npr=car.tyres.front_cornering_stiffness_npr * (1.0 + 1e-6)))
    env = gym.make("DLC120-v0", numerics=NUMERICS, vehicle=changed)
    assert mismatches("DLC120-v0", [_episode(env, SEQUENCE_SEED, STEPS), _episode(env, FOLLOW_SEED, FOLLOW_STEPS)])
    assert RTOL == 1e-9


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Pin a new env id in the fast numerics mode.")
    parser.add_argument("--add", nargs="+", required=True, metavar="ENV_ID")
    args = parser.parse_args(argv)
    data = json.loads(PIN_FILE.read_text()) if PIN_FILE.exists() else {"pins": {}}
    arrays = dict(np.load(BLOCK_FILE)) if BLOCK_FILE.exists() else {}
    for env_id in args.add:
        if env_id in data["pins"]:
            print(f"{env_id} is pinned already; a behaviour change is not re-pinned", file=sys.stderr)
            return 2
        data["pins"][env_id] = pin_entries(env_id, fast_record(env_id), arrays)
    data["pins"] = dict(sorted(data["pins"].items()))
    PIN_FILE.write_text(json.dumps(data, indent=1) + "\n")
    np.savez_compressed(BLOCK_FILE, **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main())
