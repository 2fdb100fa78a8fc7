"""The rows of the "where to add things" table of ``docs/architecture.md`` that no other test demonstrates.

A speed profile and a vehicle file need no edit of the package; a shipped vehicle is one JSON file; a CLI command
is its module plus its entry in ``cli.COMMANDS``; a suite is one registry entry the CLI reads (a suite from outside
the package: ``tests/test_suite_registry.py``).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.vehicle import catalog


@dataclass(frozen=True)
class TwoSpeeds:
    """A speed profile written outside the package: ``low_mps`` on the first half of the path, ``high_mps`` after."""

    low_mps: float
    high_mps: float

    def row_speeds(self, path) -> np.ndarray:
        s = np.arange(path.n_samples) * path.ds_m
        return np.where(s < 0.5 * path.length_m, self.low_mps, self.high_mps)


def test_a_speed_profile_is_one_class_in_your_own_code() -> None:
    env = gym.make("vtrack/Track-v0", speed_profile=TwoSpeeds(8.0, 12.0))
    _, info = env.reset(seed=0)
    assert info["target_speed_mps"] == 8.0
    table = env.unwrapped._sim.tracks.speed_tables[0]
    assert table.profile == TwoSpeeds(8.0, 12.0)
    np.testing.assert_array_equal(np.unique(table.v_mps), [8.0, 12.0])


def test_a_shipped_vehicle_is_one_json_file_in_the_data_folder(tmp_path: Path, monkeypatch) -> None:
    data = tmp_path / "data"
    shutil.copytree(catalog._data_dir(), data)
    shutil.copy(data / "hatchback.json", data / "throwaway.json")
    monkeypatch.setattr(catalog, "_data_dir", lambda: data)
    assert "throwaway" in catalog.list_vehicles()
    assert catalog.load_vehicle("throwaway") == catalog.load_vehicle("hatchback")


def test_a_vehicle_file_of_your_own_drives_like_the_shipped_one(tmp_path: Path) -> None:
    mine = tmp_path / "mine.json"
    shutil.copy(catalog._data_dir() / "hatchback.json", mine)
    runs = []
    for vehicle in ("hatchback", str(mine)):
        env = gym.make("LateralTracking-v0", vehicle=vehicle)
        obs, _ = env.reset(seed=4)
        rows = [obs]
        for _ in range(50):
            rows.append(env.step(np.array([0.05], np.float32))[0])
        runs.append(np.array(rows))
    np.testing.assert_array_equal(runs[0], runs[1])


def test_every_command_module_is_listed_once() -> None:
    """A command is its module in ``cli/`` and its entry in ``cli.COMMANDS``; this finds a forgotten entry."""
    import vtrack_gym.cli as cli

    folder = Path(cli.__file__).parent
    modules = sorted(p.stem for p in folder.glob("*.py") if not p.stem.startswith("_"))
    names = sorted(c.__name__.rsplit(".", 1)[1] for c in cli.COMMANDS)
    assert names == modules
    assert len({c.NAME for c in cli.COMMANDS}) == len(cli.COMMANDS)


def _choices(parser, command: str, option: str) -> tuple[str, ...]:
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return tuple(next(a for a in sub._actions if option in a.option_strings).choices)


def test_a_suite_is_one_registry_entry_read_by_the_cli() -> None:
    """Every suite is one ``Suite`` in ``evaluation.suite.suites``; ``vtrack benchmark --suite`` and ``vtrack dataset
    --suite`` list the registry (a suite registered later is listed too)."""
    from vtrack_gym.cli import build_parser
    from vtrack_gym.evaluation.suite import suites
    from vtrack_gym.evaluation.suite.suite_defs.paper import paper_episodes

    assert _choices(build_parser(), "benchmark", "--suite") == suites.suite_names()
    for name in suites.suite_names():
        if "highway_env" not in suites.get_suite(name).needs:
            assert suites.suite_episodes(name, quick=True)
    with pytest.raises(ValueError, match="unknown suite 'throwaway'; valid: paper, robust"):
        suites.suite_episodes("throwaway")
    suites.register_suite(suites.Suite("throwaway", "one paper seed", paper_episodes))
    try:
        parser = build_parser()
        assert "throwaway" in _choices(parser, "benchmark", "--suite")
        assert "throwaway" in _choices(parser, "dataset", "--suite")
    finally:
        suites.unregister_suite("throwaway")
