"""``--seed`` says what it seeds: the random generator of ``vtrack train``/``vtrack tune`` (also ``--rng-seed``), the
episode (the env's reset) of ``video``, ``dataset`` and ``entry-speed`` (also ``--episode-seed``); and ``vtrack
export --model`` refuses an env whose decision period differs from the one the model's run folder records."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from vtrack_gym.cli import build_parser, main

REQUIRED = {"train": ["--algo", "ppo", "--run-dir", "r"], "tune": ["--controller", "smc"],
            "video": ["--out", "v.mp4", "--env", "DLC120-v0"],
            "dataset": ["--policy", "lqr", "--env", "DLC120-v0"],
            "entry-speed": ["--policy", "lqr", "--env", "vtrack/ISO3888-2-v1"]}


def _help(command: str) -> str:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return " ".join(sub.format_help().split())


@pytest.mark.parametrize(("command", "alias", "meaning"), [
    ("train", "--rng-seed", "random seed of the training run"),
    ("tune", "--rng-seed", "random seed of the genetic algorithm"),
    ("video", "--episode-seed", "episode seed: the env's reset seed"),
    ("dataset", "--episode-seed", "episode seed of the first episode"),
    ("entry-speed", "--episode-seed", "episode seed: the env's reset seed"),
])
def test_seed_says_what_it_seeds_and_its_clearer_name_is_the_same_option(command: str, alias: str,
                                                                        meaning: str) -> None:
    parser = build_parser()
    assert parser.parse_args([command, *REQUIRED[command], "--seed", "7"]).seed == 7
    assert parser.parse_args([command, *REQUIRED[command], alias, "7"]).seed == 7
    assert meaning in _help(command)


def test_seeds_of_eval_and_benchmark_are_episode_seeds() -> None:
    assert "episode seeds (the env's reset seeds" in _help("eval")
    assert "episode seeds to score (the env's reset seeds)" in _help("benchmark")


def _run_folder(tmp_path: Path, env_kwargs: dict | None) -> Path:
    """A ``vtrack train`` run folder's record (``config.json``) beside a model file (never loaded here)."""
    run = tmp_path / "run"
    run.mkdir()
    config = {"algo": "ppo", "env_id": "TrainingMix-v0", "seed": 0,
              "hyperparams": {} if env_kwargs is None else {"env_kwargs": env_kwargs}}
    (run / "config.json").write_text(json.dumps(config))
    (run / "model.zip").write_bytes(b"PK")
    return run / "model.zip"


def test_export_refuses_an_env_of_another_decision_period_naming_both(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    model = _run_folder(tmp_path, {"control_period_s": 0.05})
    out = tmp_path / "agent"
    assert main(["export", "--trust-code", "--model", str(model), "--algo", "ppo", "--env", "DLC120-v0",
                 "--out", str(out), "--raw-observations"]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "trained deciding every 0.05 s" in err and "DLC120-v0 decides every 0.01 s" in err
    assert "--control-period-s 0.05" in err and not (tmp_path / "agent.json").exists()
    # the recorded period given: the check passes, and the (fake) model itself is what fails next
    assert main(["export", "--trust-code", "--model", str(model), "--algo", "ppo", "--env", "DLC120-v0",
                 "--control-period-s", "0.05", "--out", str(out), "--raw-observations"]) == 2
    err = capsys.readouterr().err
    assert "decides every" not in err and not (tmp_path / "agent.json").exists()


def test_export_python_api_checks_the_run_record_too(tmp_path: Path) -> None:
    from vtrack_gym.agents.export import export_model

    model = _run_folder(tmp_path, None)   # TrainingMix-v0 at its own period
    with pytest.raises(ValueError, match=r"trained deciding every 0\.01 s .* decides every 0\.05 s"):
        export_model(model, tmp_path / "agent", "ppo", env_id="DLC120-v0", env_kwargs={"control_period_s": 0.05},
                     raw_observations=True)
