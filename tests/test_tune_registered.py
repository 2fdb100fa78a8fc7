"""A GA-tunable controller registered from outside (``registry.register_policy``) is tuned by ``vtrack tune
--controller NAME`` with its own spaces and budgets, its preset saved and loaded by name; a controller whose
preset cannot be saved is refused before any GA work."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import ClassVar

import pytest
from test_tuning_protocol import TinyConfig, TinyGain

from vtrack_gym.baselines import registry
from vtrack_gym.baselines.preset_files import PresetError, load_preset, preset_config_type
from vtrack_gym.cli import build_parser, main


@pytest.fixture
def tiny():
    registry.register_policy(TinyGain)
    yield TinyGain
    registry.unregister_policy("tiny_gain")


@pytest.fixture
def no_ga(monkeypatch: pytest.MonkeyPatch) -> None:
    """Any GA run fails the test: a refusal must come before it."""
    import vtrack_gym.tuning.ga as ga

    def refuse(*args, **kwargs):
        raise AssertionError("the GA ran")

    monkeypatch.setattr(ga, "tune", refuse)


def _choices(command: str, option: str) -> tuple[str, ...]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return tuple(next(a for a in sub._actions if option in a.option_strings).choices)


def test_the_cli_lists_a_registered_controller_and_its_spaces(tiny) -> None:
    assert "tiny_gain" in _choices("tune", "--controller") and "gains" in _choices("tune", "--space")
    assert "tiny_gain" in registry.available_policies() and registry.policy_tuning("tiny_gain").spaces["gains"]


def test_vtrack_tune_tunes_a_registered_controller_and_saves_its_preset(tiny, tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "tiny.json"
    assert main(["tune", "--controller", "tiny_gain", "--generations", "1", "--pop-size", "2", "--max-steps", "200",
                 "--out", str(out), "--no-progress"]) == 0
    best = json.loads(capsys.readouterr().out)
    preset = load_preset(out)
    assert preset["controller"] == "tiny_gain" and isinstance(preset["config"], TinyConfig)
    assert (preset["config"].k_y, preset["config"].k_phi) == (best["params"]["k_y"], best["params"]["k_phi"])
    assert preset["provenance"]["space"]["name"] == "gains" and preset["provenance"]["budget"]["generations"] == 1


def test_a_space_the_controller_does_not_declare_is_refused_before_the_ga(tiny, no_ga, tmp_path: Path,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tune", "--controller", "tiny_gain", "--space", "working", "--out", str(tmp_path / "t.json")]) == 2
    assert "unknown search space tiny_gain/working; valid: " in capsys.readouterr().err


@dataclasses.dataclass(frozen=True)
class ListConfig:
    gains: list = dataclasses.field(default_factory=lambda: [0.1, 0.5])


class Unsavable(TinyGain):
    name: ClassVar[str] = "unsavable"
    config_type: ClassVar[type] = ListConfig


def test_an_unsavable_controller_is_refused_before_the_ga(no_ga, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    registry.register_policy(Unsavable)
    try:
        assert main(["tune", "--controller", "unsavable", "--out", str(tmp_path / "u.json")]) == 2
        assert "ListConfig.gains is a list; a preset holds bool, int, float, str" in capsys.readouterr().err
    finally:
        registry.unregister_policy("unsavable")
    assert not (tmp_path / "u.json").exists()
    with pytest.raises(PresetError, match="controller must be a GA-tunable registered policy: smc, mpc"):
        preset_config_type("unsavable")
