"""What a newcomer expects of every ``vtrack`` command: no abbreviated options, global options after the command
too, one option name per concept across commands, and exports that never guess a model's decision period."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from vtrack_gym.cli import build_parser, main

SYNONYMS: dict[str, tuple[str, ...]] = {
    "--trust-code": ("--trust", "--trust-pickles", "--allow-code"),
    "--seeds": ("--episode-seeds", "--seed-list"),
    "--policies": ("--policy-list",),
    "--out": ("--output", "--out-file", "--output-file"),
    "--store": ("--db", "--database", "--results"),
    "--format": ("--fmt", "--output-format"),
    "--vehicle": ("--car",),
    "--no-progress": ("--quiet-progress", "--no-bar"),
}
"""Concept -> the names it must not also go by as a command's primary option name (an old name may stay an alias
of the same option)."""


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    return next(a for a in parser._actions if a.dest == "command").choices


def _options() -> list[tuple[str, argparse.Action]]:
    return [(name, a) for name, sub in _commands().items() for a in sub._actions
            if a.option_strings and a.dest != "help"]


def test_one_name_per_concept_across_commands() -> None:
    """An option name means one thing (one dest) everywhere; one dest has one primary name everywhere; no command
    uses a known synonym of a concept's name as its primary name."""
    by_dest: dict[str, set[str]] = {}
    by_name: dict[str, set[str]] = {}
    for _, action in _options():
        by_dest.setdefault(action.dest, set()).add(action.option_strings[0])
        for option in action.option_strings:
            by_name.setdefault(option, set()).add(action.dest)
    assert {d: n for d, n in by_dest.items() if len(n) > 1} == {}
    assert {o: d for o, d in by_name.items() if len(d) > 1} == {}
    banned = {alias: name for name, aliases in SYNONYMS.items() for alias in aliases}
    assert [(cmd, a.option_strings[0]) for cmd, a in _options() if a.option_strings[0] in banned] == []


def test_no_command_takes_an_abbreviated_option(capsys: pytest.CaptureFixture[str]) -> None:
    for command in _commands().values():
        assert command.allow_abbrev is False
    with pytest.raises(SystemExit) as exc:
        main(["benchmark", "--policy", "lqr"])  # was read as --policy-kwargs
    assert exc.value.code == 2 and "unrecognized arguments: --policy lqr" in capsys.readouterr().err


@pytest.mark.parametrize("command", sorted(_commands()))
def test_verbose_is_accepted_before_and_after_every_command(command: str) -> None:
    required = {"eval": ["--policy", "lqr", "--env", "DLC120-v0"], "train": ["--algo", "ppo", "--run-dir", "r"],
                "tune": ["--controller", "smc"], "dataset": ["--policy", "lqr", "--env", "DLC120-v0"],
                "entry-speed": ["--policy", "lqr", "--env", "vtrack/ISO3888-2-v1"],
                "lap-bound": ["--track", "handling_course"],
                "export": ["--run-dir", "r", "--out", "a"],
                "video": ["--out", "v.mp4", "--env", "DLC120-v0"]}.get(command, [])
    parser = build_parser()
    assert parser.parse_args([command, *required]).verbose is False
    assert parser.parse_args(["-v", command, *required]).verbose is True
    assert parser.parse_args([command, *required, "-v"]).verbose is True
    assert parser.parse_args([command, "--verbose", *required]).verbose is True


def test_export_of_a_model_file_never_guesses_its_decision_period(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "zoo.zip"
    model.write_bytes(b"PK")
    assert main(["export", "--trust-code", "--model", str(model), "--algo", "ppo", "--out",
                 str(tmp_path / "agent")]) == 2
    err = capsys.readouterr().err
    assert "does not record the decision period it was trained at" in err and "--control-period-s" in err
    assert not (tmp_path / "agent.json").exists()


def test_the_cli_reference_page_lists_every_command_and_option() -> None:
    """The docs' CLI reference is generated from the parser (``docs/gen_cli_page.py``, listed in ``mkdocs.yml``)."""
    from vtrack_gym.cli._reference import cli_reference

    page = cli_reference()
    for name, sub in _commands().items():
        assert f"## vtrack {name}\n" in page
        section = page.split(f"## vtrack {name}\n", 1)[1].split("\n## ", 1)[0]
        for action in sub._actions:
            for option in action.option_strings:
                assert f"`{option}`" in section or option in ("-h", "--help"), (name, option)
    mkdocs = (Path(__file__).resolve().parents[1] / "mkdocs.yml").read_text()
    assert "docs/gen_cli_page.py" in mkdocs and "CLI reference: cli.md" in mkdocs


def test_nothing_but_the_result_on_stdout(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """What a library prints to stdout while a command runs (Ray forwards its workers' logs there) goes to stderr:
    ``--format json`` on stdout stays one JSON document."""
    import json

    import vtrack_gym.evaluation.api as api
    from vtrack_gym.evaluation.scoring.rows import ResultRow
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = tmp_path / "s.sqlite"
    ResultStore(store).add([ResultRow(suite="paper", env_id="DLC120-v0", policy_id="lqr", policy_hash="h", seed=0,
                                      metrics={"max_e_y_m": 0.2}, termination="completed",
                                      wall_time_per_step_s=1e-5)])
    board_of = api.board_of

    def noisy(*args, **kwargs):
        print("(run_task pid=4242) INFO worker log line")
        return board_of(*args, **kwargs)

    monkeypatch.setattr(api, "board_of", noisy)
    assert main(["leaderboard", "--store", str(store), "--format", "json"]) == 0
    captured = capsys.readouterr()
    assert [e["policy_id"] for e in json.loads(captured.out)] == ["lqr"]
    assert "(run_task pid=4242) INFO worker log line" in captured.err
