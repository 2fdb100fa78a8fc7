"""Readable output: key columns in the terminal table, all with ``--columns all`` (csv/json always all), log lines
kept apart from the progress bars, figure legends naming why a run failed, agents' figure titles naming the agent.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.benchmarking.benchmark import score_policy
from vtrack_gym.evaluation.figures.plots import figure_subtitle, run_label, title_preset
from vtrack_gym.evaluation.leaderboard.board_view import board_view
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore
from vtrack_gym.evaluation.suite.suites import Episode

ROOT = Path(__file__).resolve().parents[1]
KEY = ["env_id", "policy_id", "rank", "success_rate", "max_e_y_m", "rms_e_y_m", "failure_reasons"]


def _store(path: Path, suite: str = "highway") -> Path:
    rows = [ResultRow(suite, "DLC120-v0", p, f"h{p}", s, {"max_e_y_m": 0.1 + 0.01 * s + k, "rms_e_y_m": 0.02,
                                                         "itae": 1.0 + s, "cones_hit": float(p == "b" and s == 0)},
                      "completed", 1e-5, success=not (p == "b" and s == 0))  # the cone hit fails its episode
            for k, p in enumerate("ab") for s in range(3)]
    ResultStore(path).add(rows)
    return path


def _md_header(text: str) -> list[str]:
    line = next(x for x in text.splitlines() if x.startswith("| env_id"))
    return [c.strip() for c in line.strip("|").split("|")]


def test_leaderboard_shows_key_columns_by_default(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = _store(tmp_path / "s.sqlite")
    assert main(["leaderboard", "--store", str(store), "--suite", "highway"]) == 0
    out = capsys.readouterr().out
    assert _md_header(out) == [*KEY[:-1], "itae", "failure_reasons"]  # highway ranks on itae: shown with it
    assert re.search(r"\| 0\.1\d* \[0\.1\d*, 0\.1\d*\] \|", out)  # intervals kept in the cells
    assert "cones_hit x1" in out
    assert main(["leaderboard", "--store", str(store), "--suite", "highway", "--columns", "all"]) == 0
    header = _md_header(capsys.readouterr().out)
    assert {"rms_e_phi_deg", "comfort_a_v_mps2", "tied_with", "policy_hash"} <= set(header) and len(header) > 20
    for extra in ([], ["--columns", "key"]):
        assert main(["leaderboard", "--store", str(store), "--suite", "highway", "--format", "csv", *extra]) == 0
        rows = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
        assert {"rms_e_phi_deg", "itae_lo", "tied_with"} <= set(rows[0])
        assert main(["leaderboard", "--store", str(store), "--suite", "highway", "--format", "json", *extra]) == 0
        assert {"rms_e_phi_deg", "itae_hi"} <= set(json.loads(capsys.readouterr().out)[0])


def test_board_view_keeps_the_primary_metric_once() -> None:
    entry = {c: 1.0 for c in [*KEY, "itae", "policy_hash", "tied_with"]}
    assert list(board_view([entry], "max_e_y_m")[0]) == KEY
    assert list(board_view([entry], "itae")[0]) == [*KEY[:-1], "itae", "failure_reasons"]
    assert board_view([entry], "itae", "all") == [entry]
    entry["mu_g_mps2"] = 9.0  # a column of the suite's own (the manoeuvres' circle) is a key column there
    assert list(board_view([entry], "max_e_y_m", "key", ("mu_g_mps2",))[0]) == [*KEY[:-1], "mu_g_mps2", KEY[-1]]
    with pytest.raises(ValueError, match="columns must be one of key, all"):
        board_view([entry], "itae", "some")


def test_benchmark_prints_key_columns(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["benchmark", "--policies", "stanley", "--no-figures", "--store", str(tmp_path / "s.sqlite")]) == 0
    out = capsys.readouterr().out
    assert _md_header(out) == KEY
    assert "| DLC120-v0 | stanley | 1 | 0 | – | – | cones_hit x1 |" in out


def test_failed_runs_are_named_in_legends_and_agents_in_titles() -> None:
    rows, traces = score_policy("stanley", _maker("stanley"), [Episode("DLC120-v0", 0)], "custom")
    assert not rows[0].verdict() and rows[0].termination == "completed"
    assert run_label(traces[0]) == "stanley (failed: cones_hit)"
    rows, traces = score_policy("lqr", _maker("lqr"), [Episode("DLC120-v0", 0)], "custom")
    assert rows[0].verdict() and run_label(traces[0]) == "lqr (completed)"
    assert figure_subtitle("DLC120-v0", 0, None, ["ppo"]) == "DLC120-v0 | agent ppo | seed 0"
    assert figure_subtitle("DLC120-v0", 0, None) == "DLC120-v0 | preset default | seed 0"
    assert figure_subtitle("DLC120-v0", 3, "tuned", ["ppo"]) == "DLC120-v0 | preset tuned | seed 3"


def test_titles_of_figures_with_several_policies_name_their_presets() -> None:
    _, traces = score_policy("lqr", _maker("lqr"), [Episode("DLC120-v0", 0)], "custom")
    [trace] = traces

    def named(*ids: str) -> list:
        return [dataclasses.replace(trace, policy_id=i) for i in ids]

    assert title_preset(named("smc", "mpc"), None) == "default"
    assert title_preset(named("smc:paper", "mpc:paper"), None) == "paper"
    assert title_preset(named("smc:paper", "mpc"), None) == "as in the legend"
    assert title_preset(named("ppo", "mpc"), None) == "default (baselines)"
    assert title_preset(named("ppo", "sac"), None) is None
    assert title_preset(named("smc:paper", "mpc"), "tuned") == "tuned"


def _maker(name: str):
    from vtrack_gym.baselines.resolve import policy_factory

    return policy_factory(name)


def test_agent_figure_titles_name_the_agent(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import matplotlib.figure

    titles: list[str] = []
    original = matplotlib.figure.Figure.suptitle

    def record(self, text, **kwargs):
        titles.append(text)
        return original(self, text, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "suptitle", record)
    assert main(["plot", "--policies", "ppo", "--env", "DLC120-v0", "--out", str(tmp_path)]) == 0
    assert titles and all("| agent ppo |" in t and "preset" not in t for t in titles)


def test_log_lines_never_break_into_progress_bars(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "vtrack_gym.cli", "-v", "benchmark", "--policies", "lqr,stanley",
                           "--no-figures", "--store", str(tmp_path / "s.sqlite")], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=600)
    assert proc.returncode == 0, proc.stderr
    fragments = re.split(r"[\r\n]", proc.stderr)
    logged = [f for f in fragments if re.search(r"(DEBUG|INFO) ", f)]
    assert any("lqr on DLC120-v0" in f for f in logged)  # the episode lines are there ...
    assert all(re.match(r"(DEBUG|INFO) ", f) for f in logged), logged  # ... each on a line of its own
    assert any("vtrack benchmark (paper)" in f for f in fragments)  # and the bar too
