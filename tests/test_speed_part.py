"""The speed part is a protocol, like the criteria: the env asks a scenario's speed part for its tables, release
columns, nominal and start speeds and its check against the car, and never dispatches on its type. A part written
outside the package drives an env."""

from __future__ import annotations

import ast
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from vtrack_gym.envs.scenarios import SCENARIOS
from vtrack_gym.envs.speed import SPEED_PART_METHODS, FollowProfile, HoldSpeed, speed_part
from vtrack_gym.envs.tracking_env import TrackingEnv
from vtrack_gym.tracks.speed_profiles import ConstantSpeed

ENVS = Path(__file__).resolve().parents[1] / "vtrack_gym" / "envs"


@dataclass(frozen=True)
class TwoStage:
    """Hold ``first_mps`` on the first half of each path and ``second_mps`` after (a speed part of one's own)."""

    first_mps: float
    second_mps: float
    follows_profile: ClassVar[bool] = True
    takes_entry_speed: ClassVar[bool] = False

    def _profile(self) -> Any:
        return FollowProfile(self)

    def row_speeds(self, path: Any) -> np.ndarray:
        s = np.arange(path.n_samples) * path.ds_m
        return np.where(s < 0.5 * path.length_m, self.first_mps, self.second_mps)

    def tables(self, paths: tuple, vehicle: Any = None) -> tuple:
        return self._profile().tables(paths, vehicle)

    def release_columns(self, paths: tuple) -> np.ndarray:
        return self._profile().release_columns(paths)

    def nominal_speed_mps(self, tables: tuple) -> float:
        return self.first_mps

    def start_speed_mps(self, peak_curvature_per_m: float, table: Any, rng: np.random.Generator) -> float:
        return self.first_mps

    def check_for_car(self, vehicle: Any) -> None:
        if self.second_mps > 45.0:
            raise ValueError(f"TwoStage.second_mps must be <= 45 m/s for {vehicle.name}")


def test_every_speed_part_is_reached_through_the_protocol() -> None:
    hold = HoldSpeed(target_speed_mps=10.0)
    assert speed_part(hold) is hold and speed_part(ConstantSpeed(8.0)) == FollowProfile(ConstantSpeed(8.0))
    for scenario in SCENARIOS.values():
        part = speed_part(scenario.speed)
        assert all(callable(getattr(part, m)) for m in SPEED_PART_METHODS)
    with pytest.raises(ValueError, match=r"Scenario\.speed must be a HoldSpeed, an EntryThenRelease, a tracks speed"):
        speed_part(12.0)


def test_no_isinstance_dispatch_on_the_speed_parts() -> None:
    names = {"HoldSpeed", "EntryThenRelease", "FollowProfile"}
    found = []
    for path in sorted(ENVS.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance":
                if names & {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}:
                    found.append(f"{path.name}:{node.lineno}")
    assert found == []


def test_a_speed_part_of_your_own_drives_an_env() -> None:
    scenario = replace(SCENARIOS["DLC120-v0"], name="TwoStageDLC-v0", speed=TwoStage(20.0, 25.0))
    env = TrackingEnv(scenario)
    _, info = env.reset(seed=0)
    assert info["target_speed_mps"] == 20.0
    table = env._sim.tracks.speed_tables[0]
    np.testing.assert_array_equal(np.unique(table.v_mps), [20.0, 25.0])
    for _ in range(5):
        env.step(np.zeros(1, dtype=np.float32))
    with pytest.raises(ValueError, match=r"TwoStage\.second_mps must be <= 45 m/s"):
        TrackingEnv(replace(scenario, speed=TwoStage(20.0, 50.0)))
