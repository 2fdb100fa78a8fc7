"""The HTML board shows the columns that explain a verdict first (``failure_reasons`` among them) and says which
policies have figures and why the others have none (``vtrack leaderboard --format html``)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.scoring.rows import ResultRow
from vtrack_gym.evaluation.storage.store import ResultStore

PNG = bytes.fromhex("89504e470d0a1a0a0000000d49484452000000010000000108060000001f15c4890000000d4944415478da63f8ff"
                    "ff3f0005fe02fea7d6a4c80000000049454e44ae426082")


def _row(policy: str, termination: str = "completed", folder: str | None = None) -> ResultRow:
    options = {} if folder is None else {"figures": folder}
    return ResultRow(suite="paper", env_id="DLC120-v0", policy_id=policy, policy_hash=f"h-{policy}", seed=0,
                     metrics={"max_e_y_m": 0.2, "rms_e_y_m": 0.1}, termination=termination,
                     wall_time_per_step_s=1e-5, options=options, success=termination == "completed")


def test_the_html_board_explains_its_verdicts_and_its_figures(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    figures = tmp_path / "figs"
    (figures / "paper" / "lqr-1").mkdir(parents=True)
    (figures / "paper" / "lqr-1" / "dlc120_v0_trajectories.png").write_bytes(PNG)
    store = tmp_path / "s.sqlite"
    ResultStore(store).add([_row("lqr", folder="paper/lqr-1"), _row("stanley", "off_track"),
                            _row("smc", folder="paper/gone-2")])
    html = tmp_path / "board.html"
    assert main(["leaderboard", "--store", str(store), "--format", "html", "--figures", str(figures), "--out",
                 str(html)]) == 0
    text = html.read_text()
    header = re.findall(r'<th scope="col">([^<]*)</th>', text)
    assert header[:7] == ["env_id", "policy_id", "rank", "success_rate", "max_e_y_m", "rms_e_y_m", "failure_reasons"]
    assert len(header) > 20  # every column still there, after the ones that explain the verdict
    assert "off_track" in text
    assert "Figures shown for: lqr." in text
    assert "No figures for stanley: their rows were scored without figures" in text
    assert "No figures for smc: their run&#x27;s figure folder is not under --figures." in text
    assert text.count("data:image/png;base64") == 1


def test_an_output_format_of_your_own_is_one_registration(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    """An ``OutputFormat`` registered from outside is a ``--format`` choice of ``vtrack leaderboard`` and
    ``vtrack benchmark`` and renders the board."""
    from vtrack_gym.evaluation.leaderboard.output_formats import OutputFormat, register_format, unregister_format

    def tsv(board, title, figures, notes):
        cols = list(board[0])
        return "\n".join(["\t".join(cols), *("\t".join(str(e[c]) for c in cols) for e in board)])

    store = tmp_path / "s.sqlite"
    ResultStore(store).add([_row("lqr")])
    register_format(OutputFormat("tsv", "tab-separated values", tsv, trimmed=True))
    try:
        assert main(["leaderboard", "--store", str(store), "--format", "tsv"]) == 0
        lines = capsys.readouterr().out.splitlines()
        assert lines[0].split("\t")[:3] == ["env_id", "policy_id", "rank"] and lines[1].startswith("DLC120-v0\tlqr")
        assert "failure_reasons" in lines[0] and len(lines[0].split("\t")) == 7  # trimmed: the key columns
    finally:
        unregister_format("tsv")
