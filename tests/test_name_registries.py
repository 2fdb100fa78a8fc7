"""One registry per name list (policies, suites, tracks, output formats, vehicles, criteria, vehicle models): every
help text, docstring, error message and ``choices=`` reads it, and no string of the package lists three or more of
a registry's names by hand (such a list goes stale: ``vtrack eval --help`` once omitted ``nmpc``)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from vtrack_gym.baselines.registry import available_policies, tunable_policies
from vtrack_gym.cli import build_parser
from vtrack_gym.envs.criteria import CRITERIA
from vtrack_gym.evaluation.benchmarking.dataset import dataset_suites
from vtrack_gym.evaluation.leaderboard.output_formats import format_names
from vtrack_gym.evaluation.suite.suites import suite_names
from vtrack_gym.tracks.track_registry import track_names
from vtrack_gym.vehicle.catalog import list_vehicles
from vtrack_gym.vehicle.layout import MODEL_IDS

PACKAGE = Path(__file__).resolve().parents[1] / "vtrack_gym"
REGISTRIES = {"policies": available_policies, "suites": suite_names, "tracks": track_names,
              "output formats": format_names, "vehicles": list_vehicles, "criteria": lambda: tuple(CRITERIA),
              "vehicle models": lambda: tuple(MODEL_IDS)}


def _enumeration(names: tuple[str, ...]) -> re.Pattern[str]:
    """Three or more of ``names`` in a row, separated by commas, slashes, bars, "or" or "and" (backticks allowed)."""
    alt = "|".join(sorted(map(re.escape, names), key=len, reverse=True))
    item = rf"`{{0,2}}(?<![\w/.-])(?:{alt})(?![\w-])`{{0,2}}"
    return re.compile(rf"{item}(?:\s*(?:,|/|\||or|and|, or|, and)\s*{item}){{2,}}")


def _hand_lists(names: tuple[str, ...]) -> list[str]:
    pattern = _enumeration(names)
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                match = pattern.search(node.value)
                if match:
                    found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}: {match.group()!r}")
    return found


@pytest.mark.parametrize("registry", sorted(REGISTRIES))
def test_no_name_list_is_written_by_hand(registry: str) -> None:
    names = tuple(REGISTRIES[registry]())
    assert len(names) >= 2
    assert _hand_lists(names) == [], f"read these from the {registry} registry instead"


def test_the_scan_finds_a_list_written_by_hand() -> None:
    pattern = _enumeration(("smc", "mpc", "lqr", "nmpc"))
    assert pattern.search("a baseline name (smc, mpc, lqr, stanley)")
    assert pattern.search("``smc``, ``mpc`` or ``lqr``")
    assert not pattern.search("SMC-vs-MPC deviation bars (smc and mpc)")


def _choices(command: str, option: str) -> tuple[str, ...]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return tuple(next(a for a in sub._actions if option in a.option_strings).choices)


def test_every_choices_list_is_a_registry() -> None:
    assert _choices("benchmark", "--suite") == suite_names()
    assert _choices("dataset", "--suite") == dataset_suites()
    assert _choices("leaderboard", "--format") == format_names()
    assert _choices("benchmark", "--format") == format_names(reports=False)
    assert _choices("tune", "--controller") == tunable_policies()


def test_one_track_registry_and_one_criterion_vocabulary() -> None:
    import vtrack_gym.tracks as tracks
    from vtrack_gym.envs.scenarios import maneuver_criterion
    from vtrack_gym.envs.track_sources import TRACKS
    from vtrack_gym.tracks.maneuvers import MANEUVERS, SUCCESS_CRITERIA, build_maneuver

    assert tracks.load_track("iso3888_1").length_m == pytest.approx(build_maneuver("iso3888_1").path.length_m)
    assert set(track_names()) <= set(TRACKS) and set(MANEUVERS) <= set(track_names())
    assert set(SUCCESS_CRITERIA) <= set(CRITERIA)
    for name in MANEUVERS:
        spec = build_maneuver(name).spec
        assert maneuver_criterion(spec).name == spec.success_criterion
    tracks.register_track("throwaway_loop", lambda width: tracks.handling_course())
    try:
        assert "throwaway_loop" in TRACKS and tracks.load_track("throwaway_loop").closed
    finally:
        tracks.unregister_track("throwaway_loop")
