"""A class of your own is named by its class and the arguments it was built with, the same from Python
(``vtrack_gym.evaluate(Gains(k_y=0.2))``) and from the CLI (``--policy MODULE:Gains --policy-kwargs``): one
policy is one row whichever way it was scored, two settings are two named rows."""

from __future__ import annotations

import importlib
from pathlib import Path

from test_cli_user_policy import user_module  # noqa: F401  (the fixture: a module of user code, class Gains)

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.evaluation.identity.policy_names import class_label, instance_label
from vtrack_gym.evaluation.storage.store import ResultStore


def test_python_and_the_cli_give_one_name_and_one_row(user_module: str, tmp_path: Path) -> None:  # noqa: F811
    store = tmp_path / "s.sqlite"
    spec = f"{user_module}:Gains"
    for kwargs in ('{"k_y": 0.2}', '{"k_y": 0.3}'):
        assert main(["eval", "--policy", spec, "--trust-code", "--policy-kwargs", kwargs, "--env", "DLC120-v0",
                     "--seeds", "0", "--store", str(store)]) == 0
    gains = importlib.import_module(user_module).Gains
    row, = vtrack_gym.evaluate(gains(k_y=0.2), "DLC120-v0", store=store)
    assert row.policy_id == "Gains(k_y=0.2)"
    rows = ResultStore(store).rows()
    assert sorted(r["policy_id"] for r in rows) == ["Gains(k_y=0.2)", "Gains(k_y=0.2)", "Gains(k_y=0.3)"]
    assert len({r["policy_hash"] for r in rows if r["policy_id"] == "Gains(k_y=0.2)"}) == 1
    board = vtrack_gym.leaderboard(store, "custom")
    assert sorted(e["policy_id"] for e in board) == ["Gains(k_y=0.2)", "Gains(k_y=0.3)"]


def test_the_name_rule() -> None:
    class Gains:
        def __init__(self, k_y=0.1, k_phi=0.8, label="plain", table=None):
            self.k_y, self.k_phi, self.label, self.table = k_y, k_phi, label, table

    assert instance_label(Gains()) == "Gains"                        # every argument at its default
    assert instance_label(Gains(k_y=1)) == instance_label(Gains(k_y=1.0)) == "Gains(k_y=1)"
    assert instance_label(Gains(0.25, label="x")) == 'Gains(k_y=0.25, label="x")'
    assert instance_label(Gains(table=[1, 2])) == "Gains"             # containers are left to the hash
    assert class_label(Gains, {"k_y": 0.1, "k_phi": 0.5}) == "Gains(k_phi=0.5)"   # a default given is not shown
