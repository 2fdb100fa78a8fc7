"""A suite is one ``Suite`` object in one registry: a suite written outside the package (an installed package's
``vtrack_gym.suites`` entry point) runs through ``vtrack benchmark --suite``, ``vtrack leaderboard`` (text and
HTML), ``vtrack dataset`` and ``vtrack_gym.evaluate``, ranked on its own metric with its own columns."""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path

import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.suite import suites

PLUGIN = textwrap.dedent('''
    from vtrack_gym.evaluation.suite.suites import Episode, Suite

    def two_seeds(seeds):
        return [Episode("DLC120-v0", s, {"target_speed_mps": 30.0}) for s in seeds]

    MINE = Suite(name="mine", description="the lane change at 108 km/h", episodes=two_seeds, seeds=(3, 4),
                 quick_seeds=(3,), primary_metric="rms_e_y_m", columns=("duration_s",))
''')


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """An installed package ``mysuites`` whose ``vtrack_gym.suites`` entry point is the suite ``mine``."""
    site = tmp_path / "site"
    (site / "mysuites-0.1.dist-info").mkdir(parents=True)
    (site / "mysuites.py").write_text(PLUGIN)
    (site / "mysuites-0.1.dist-info" / "METADATA").write_text("Metadata-Version: 2.1\nName: mysuites\nVersion: 0.1\n")
    (site / "mysuites-0.1.dist-info" / "entry_points.txt").write_text("[vtrack_gym.suites]\nmine = mysuites:MINE\n")
    monkeypatch.syspath_prepend(str(site))
    yield site
    suites.unregister_suite("mine")
    sys.modules.pop("mysuites", None)


def test_a_suite_from_an_installed_package_is_registered(plugin: Path) -> None:
    assert "mine" in suites.suite_names()
    mine = suites.get_suite("mine")
    assert [(e.env_id, e.seed) for e in suites.suite_episodes("mine")] == [("DLC120-v0", 3), ("DLC120-v0", 4)]
    assert suites.suite_label("mine", quick=True) == "mine[quick]"
    assert suites.suite_label("mine", seeds=[4, 3]) == "mine"
    assert suites.primary_metric("mine[seeds=7]") == "rms_e_y_m" and suites.extra_columns("mine") == ("duration_s",)
    assert mine.dataset and "mine: the lane change at 108 km/h" in suites.suite_help()


def test_a_suite_from_outside_runs_through_every_command(plugin: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    store, figures = tmp_path / "s.sqlite", tmp_path / "figs"
    assert main(["benchmark", "--suite", "mine", "--policies", "lqr,stanley", "--store", str(store), "--figures",
                 str(figures), "--workers", "1", "--format", "json", "--columns", "all"]) == 0
    board = json.loads(capsys.readouterr().out)
    assert {e["policy_id"] for e in board} == {"lqr", "stanley"}
    assert all("duration_s" in e for e in board)
    assert main(["leaderboard", "--suite", "mine", "--store", str(store), "--format", "md"]) == 0
    captured = capsys.readouterr()
    assert "rms_e_y_m" in captured.err and "lqr" in captured.out and "duration_s" in captured.out
    html = tmp_path / "board.html"
    assert main(["leaderboard", "--suite", "mine", "--store", str(store), "--format", "html", "--figures",
                 str(figures), "--out", str(html)]) == 0
    text = html.read_text()
    assert "suite mine" in text and "data:image/png;base64" in text
    assert main(["dataset", "--policy", "lqr", "--suite", "mine", "--episodes", "2", "--root",
                 str(tmp_path / "ds"), "--no-progress"]) == 0
    assert capsys.readouterr().out.split() == ["vtrack/DLC120/lqr-mine-v0"]


def test_a_suite_from_outside_through_the_python_api(plugin: Path) -> None:
    import vtrack_gym

    rows = vtrack_gym.evaluate(lambda env: vtrack_gym.make_policy("lqr", env), "mine")
    assert [(r.suite, r.env_id, r.seed) for r in rows] == [("mine", "DLC120-v0", 3), ("mine", "DLC120-v0", 4)]
    assert all(r.options["target_speed_mps"] == 30.0 for r in rows)


def test_a_suite_is_checked_when_it_is_made() -> None:
    from vtrack_gym.evaluation.suite.suite_defs.paper import paper_episodes

    with pytest.raises(ValueError, match=r"Suite\.primary_metric must be a numeric metric"):
        suites.Suite("x", "x", paper_episodes, primary_metric="termination")
    with pytest.raises(ValueError, match=r"Suite\.figures must be one of tracking, maneuver"):
        suites.Suite("x", "x", paper_episodes, figures="bars")
    with pytest.raises(ValueError, match=r"Suite\.seeds must be a non-empty sequence of ints >= 0"):
        suites.Suite("x", "x", paper_episodes, seeds=())
    with pytest.raises(ValueError, match="a suite named 'paper' is registered already"):
        suites.register_suite(suites.Suite("paper", "x", paper_episodes))
