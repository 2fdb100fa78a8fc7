"""Every setting of an env is in its rows' identity, spelled one way: an id and its alias are one scenario, ``45``
and ``45.0`` one entry speed, a user wrapper's parameters part of the set-up, and an env whose configuration
cannot be identified a row of its own (never sharing one with another env)."""

from __future__ import annotations

import re
import threading
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.observation import OBS
from vtrack_gym.evaluation.storage.store import ResultStore


class Steer:
    """Curvature feed-forward and error feedback (enough to finish the slow set-ups)."""

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        o = np.asarray(obs, dtype=float)
        delta = 2.91 * o[OBS.CURVATURE] - 0.1 * o[OBS.E_Y] - 0.8 * o[OBS.E_PHI]
        return np.clip(np.array([delta / 0.6], dtype=np.float32), -1.0, 1.0), state


class Gain(gym.ActionWrapper):
    """A user's wrapper that does not record its constructor arguments (a plain ``gymnasium.Wrapper``)."""

    def __init__(self, env: gym.Env, gain: float = 1.0) -> None:
        super().__init__(env)
        self.gain = gain

    def action(self, action):
        return np.clip(self.gain * np.asarray(action), -1.0, 1.0)


def board_envs(store: Path) -> list[str]:
    return sorted({r["env_id"] for r in vtrack_gym.leaderboard(store, "custom")})


def test_an_id_and_its_alias_are_one_scenario_from_python_and_the_cli(tmp_path: Path) -> None:
    from vtrack_gym.cli import main

    store = tmp_path / "s.sqlite"
    for env_id in ("vtrack/DLC120-v0", "DLC120-v0"):
        assert main(["eval", "--policy", "lqr", "--env", env_id, "--seeds", "0", "--store", str(store)]) == 0
    rows = vtrack_gym.evaluate(Steer(), gym.make("vtrack/DLC120-v0"))
    assert rows[0].env_id == "DLC120-v0"
    assert {r["env_id"] for r in ResultStore(store).rows()} == {"DLC120-v0"}
    assert len(vtrack_gym.leaderboard(store, "custom")) == 1


def test_a_row_stored_under_the_alias_joins_its_scenario_on_the_board() -> None:
    from vtrack_gym.evaluation.leaderboard.board import board_env

    old = {"env_id": "vtrack/DLC120-v0", "options": {"protocol": {"entry_speed_kmh": 45}}}
    new = {"env_id": "DLC120-v0", "options": {"protocol": {"entry_speed_kmh": 45.0}}}
    assert board_env(old) == board_env(new) == "DLC120-v0 [entry_speed_kmh=45.0]"


def test_an_entry_speed_as_int_or_float_is_one_set_up(tmp_path: Path) -> None:
    store = tmp_path / "s.sqlite"
    options = []
    for speed in (45, 45.0, 50):
        row, = vtrack_gym.evaluate(Steer(), gym.make("vtrack/ISO3888-1-v1", entry_speed_kmh=speed), store=store)
        options.append(row.options)
    assert options[0] == options[1] == {"protocol": {"entry_speed_kmh": 45.0}} != options[2]
    assert len(vtrack_gym.leaderboard(store, "custom")) == 2


def test_a_user_wrappers_parameters_are_part_of_the_set_up(tmp_path: Path) -> None:
    store = tmp_path / "s.sqlite"
    ids = []
    for gain in (2.0, 3.0, 2.0):
        row, = vtrack_gym.evaluate(Steer(), Gain(gym.make("DLC120-v0"), gain=gain), store=store)
        ids.append(row.options["wrappers"])
    assert ids[0] == ids[2] != ids[1]
    assert ids[0][0]["name"] == "Gain" and ids[0][0]["entry_point"].endswith(":Gain")
    assert len(board_envs(store)) == 2


def test_an_env_whose_configuration_cannot_be_identified_never_shares_a_row(tmp_path: Path) -> None:
    from vtrack_gym.envs.tracking_env import TrackingEnv

    store = tmp_path / "s.sqlite"
    bare = [vtrack_gym.evaluate(Steer(), TrackingEnv("DLC120-v0"), store=store)[0].env_id for _ in range(2)]
    locked = Gain(gym.make("DLC120-v0"))
    locked.lock = threading.Lock()          # a wrapper whose attributes cannot be read
    wrapped = vtrack_gym.evaluate(Steer(), locked, store=store)[0].env_id
    pattern = re.compile(r"(TrackingEnv|DLC120-v0) \[unidentified configuration [0-9a-f]{8}\]")
    assert all(pattern.fullmatch(e) for e in (*bare, wrapped)), (bare, wrapped)
    assert len({*bare, wrapped}) == 3
    assert len(vtrack_gym.leaderboard(store, "custom")) == 3


@pytest.mark.parametrize("value", [45, 45.0, [1, 2.0, {"a": 3}], True, 2**60])
def test_numbers_are_normalised_at_any_depth(value) -> None:
    from vtrack_gym.evaluation.identity.env_names import normal_numbers

    out = normal_numbers({"x": value})["x"]
    if value is True:
        assert out is True
    elif value == 2**60:
        assert out == 2**60 and isinstance(out, int)
    elif isinstance(value, list):
        assert out == [1.0, 2.0, {"a": 3.0}] and isinstance(out[0], float) and isinstance(out[2]["a"], float)
    else:
        assert out == 45.0 and isinstance(out, float)
