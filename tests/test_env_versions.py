"""A registered id's behaviour never changes: every id's recorded episodes match its pin within the pin tolerance,
and its discrete outcomes exactly (``tests/env_fingerprint.py``).

A failure here means a change altered what an existing id does. Do not re-pin: register the changed behaviour as
the next version (``-v1``) and keep the old id as it was (or make it raise Gymnasium's deprecation error: a pinned
id that is no longer registered must be listed in ``envs.scenarios.DEPRECATED_IDS`` and raise
``gymnasium.error.DeprecatedEnv`` naming its successor).
"""

from __future__ import annotations

import gymnasium as gym
import pytest
from env_fingerprint import mismatches, pinned, record

import vtrack_gym
from vtrack_gym.envs.scenarios import DEPRECATED_IDS


def test_every_registered_id_is_pinned() -> None:
    missing = sorted(set(vtrack_gym.ALL_ENV_IDS) - set(pinned()))
    assert not missing, f"ids without a behaviour pin: {missing} (python tests/env_fingerprint.py --add ID)"


@pytest.mark.parametrize("env_id", sorted(vtrack_gym.ALL_ENV_IDS))
def test_behaviour_unchanged(env_id: str) -> None:
    found = mismatches(env_id, record(env_id))
    assert not found, (f"{env_id} behaves differently from its pinned version (register the change as a new "
                       f"version): {found[:8]}")


def test_pinned_ids_no_longer_registered_are_deprecated_and_raise() -> None:
    gone = set(pinned()) - set(vtrack_gym.ALL_ENV_IDS)
    assert gone == set(DEPRECATED_IDS), f"pinned ids neither registered nor deprecated: {gone - set(DEPRECATED_IDS)}"
    for old, new in DEPRECATED_IDS.items():
        assert new in vtrack_gym.ALL_ENV_IDS and new in pinned()
        with pytest.raises(gym.error.DeprecatedEnv, match=f"Please use `{new}` instead"):
            gym.make(old)
