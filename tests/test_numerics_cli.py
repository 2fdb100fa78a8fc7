"""``--numerics default|fast`` of ``vtrack eval`` and ``vtrack benchmark``: the plant kernel reaches the env, and a
fast row is stored and ranked apart from the default row (recorded as an env made with ``numerics="fast"`` is)."""

from __future__ import annotations

import gymnasium as gym
import pytest

import vtrack_gym  # noqa: F401  (registers the ids)


def test_vtrack_eval_stores_a_fast_numerics_row_apart(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.identity.env_identity import env_identity
    from vtrack_gym.evaluation.leaderboard.board import board_env
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = tmp_path / "rows.db"
    for extra in ([], ["--numerics", "fast"], ["--numerics", "default"]):
        assert main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--store", str(store), *extra]) == 0
    rows = ResultStore(store).rows()
    assert [r["options"] for r in rows] == [{}, {"env_config": {"numerics": "fast"}}, {}]
    assert board_env(rows[0]) == board_env(rows[2]) == "DLC120-v0"
    assert board_env(rows[1]) != "DLC120-v0"
    assert all(r["success"] for r in rows)
    # the same record as an env instance made with the fast plant
    assert env_identity(gym.make("DLC120-v0", numerics="fast"))[1] == rows[1]["options"]
    # the fast row drove the fast plant: its figures are not the default row's bits (the clock's aside)
    from vtrack_gym.evaluation.scoring.metrics import CLOCK_MEASURED

    def episode(row: dict) -> dict:
        return {k: v for k, v in row["metrics"].items() if k not in CLOCK_MEASURED}

    assert episode(rows[2]) == episode(rows[0])
    assert episode(rows[1]) != episode(rows[0])


def test_the_cli_refuses_an_unknown_numerics_and_numerics_with_a_track_file(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--numerics", "quick"])
    assert exit_info.value.code == 2 and "--numerics: invalid choice: 'quick'" in capsys.readouterr().err
    track = tmp_path / "t.csv"
    track.write_text("x_m,y_m\n" + "".join(f"{x},0\n" for x in range(0, 200, 5)))
    code = main(["benchmark", "--policies", "lqr", "--track", str(track), "--numerics", "fast",
                 "--store", str(tmp_path / "b.db"), "--no-figures"])
    assert code != 0 and "--numerics applies to a suite's episodes" in capsys.readouterr().err
