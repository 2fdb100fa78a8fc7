"""Policies of the user's own code (``--policy module:Name --trust-code``, ``make_policy(..., trust_code=True)``).

One rule everywhere: ``Name.from_env(env, **policy_kwargs)`` when the class defines it, else
``Name(**policy_kwargs)``: a class whose ``__init__`` has defaults never gets the env as its first argument.
``--policy-kwargs`` is a JSON object with string keys, checked before any work; eval, benchmark, plot and video
all take ``--trust-code``.
"""

from __future__ import annotations

import hashlib
import json
import textwrap
from pathlib import Path

import gymnasium as gym
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultStore

MODULE = textwrap.dedent('''
    import numpy as np
    from vtrack_gym.envs import OBS


    class Gains:
        """Proportional steering on e_y and e_phi; defaults in __init__ (the case that used to get the env)."""

        def __init__(self, k_y=0.08, k_phi=0.9):
            self.k_y, self.k_phi = k_y, k_phi

        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            obs = np.asarray(observation, dtype=np.float64)
            a = -(self.k_y * obs[..., OBS.E_Y] + self.k_phi * obs[..., OBS.E_PHI])
            return np.clip(a, -1.0, 1.0).astype(np.float32)[..., None], state


    class FromEnv(Gains):
        """Built from the env it drives."""

        @classmethod
        def from_env(cls, env, k_y=0.08):
            policy = cls(k_y=k_y)
            policy.env = env
            return policy
''')


@pytest.fixture()
def user_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, request: pytest.FixtureRequest) -> str:
    """A module of user code in the working directory (a fresh name per test: imports are cached)."""
    name = f"my_policies_{hashlib.sha256(request.node.nodeid.encode()).hexdigest()[:12]}"
    (tmp_path / f"{name}.py").write_text(MODULE, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


def test_make_policy_builds_user_classes_by_the_rule(user_module: str) -> None:
    env = gym.make("DLC120-v0")
    with pytest.raises(ValueError, match="trust_code"):
        vtrack_gym.make_policy(f"{user_module}:Gains", env)
    plain = vtrack_gym.make_policy(f"{user_module}:Gains", env, trust_code=True)
    assert (plain.k_y, plain.k_phi) == (0.08, 0.9)  # defaults kept: the env was not passed as k_y
    tuned = vtrack_gym.make_policy(f"{user_module}:Gains", env, trust_code=True, policy_kwargs={"k_y": 0.2})
    assert tuned.k_y == 0.2
    built = vtrack_gym.make_policy(f"{user_module}:FromEnv", env, trust_code=True, policy_kwargs={"k_y": 0.3})
    assert built.env is env and built.k_y == 0.3
    for bad, message in (([1], "object of keyword arguments"), ({"1x": 1}, "argument name"),
                         ({"nope": 1}, "cannot be built with policy_kwargs")):
        with pytest.raises(ValueError, match=message):
            vtrack_gym.make_policy(f"{user_module}:Gains", env, trust_code=True, policy_kwargs=bad)
    with pytest.raises(ValueError, match="policy_kwargs apply to a module:Name"):
        vtrack_gym.make_policy("lqr", env, policy_kwargs={"k_y": 1})
    env.close()


def test_eval_uses_policy_kwargs(user_module: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = f"{user_module}:Gains"
    base = ["eval", "--policy", spec, "--env", "DLC120-v0", "--trust-code"]
    assert main([*base, "--store", str(tmp_path / "a.sqlite")]) == 0
    assert main([*base, "--policy-kwargs", '{"k_y": 0.2}', "--store", str(tmp_path / "b.sqlite")]) == 0
    capsys.readouterr()
    default_row, = ResultStore(tmp_path / "a.sqlite").rows("custom")
    tuned_row, = ResultStore(tmp_path / "b.sqlite").rows("custom")
    env = gym.make("DLC120-v0")
    expected = vtrack_gym.evaluate(vtrack_gym.make_policy(spec, env, trust_code=True, policy_kwargs={"k_y": 0.2}),
                                   "DLC120-v0", seeds=[0], policy_id=spec)[0]
    env.close()
    assert tuned_row["metrics"]["max_e_y_m"] == expected.metrics["max_e_y_m"]
    assert tuned_row["metrics"]["max_e_y_m"] != default_row["metrics"]["max_e_y_m"]  # the gain reached the policy
    assert tuned_row["policy_hash"] != default_row["policy_hash"]


@pytest.mark.parametrize(("kwargs", "message"), [
    ("[1, 2]", "--policy-kwargs must be an object"),
    ("{k_y: 1}", "--policy-kwargs must be a JSON object"),
    ('{"k_y": NaN}', "--policy-kwargs must be a JSON object"),
    ('{"": 1}', "--policy-kwargs: every key must be a Python argument name"),
    ('{"nope": 1}', "cannot be built with policy_kwargs"),
])
def test_bad_policy_kwargs_are_refused_before_any_work(user_module: str, tmp_path: Path, kwargs: str, message: str,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "s.sqlite"
    assert main(["eval", "--policy", f"{user_module}:Gains", "--env", "DLC120-v0", "--trust-code",
                 "--policy-kwargs", kwargs, "--store", str(store)]) == 2
    assert message in capsys.readouterr().err
    assert not store.exists()


def test_policy_kwargs_need_user_code(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--policy-kwargs", '{"k": 1}',
                 "--store", str(tmp_path / "s.sqlite")]) == 2
    assert "--policy-kwargs applies to a --policy MODULE:NAME" in capsys.readouterr().err


def test_benchmark_and_plot_take_user_code(user_module: str, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    spec = f"{user_module}:Gains"
    store = tmp_path / "s.sqlite"
    assert main(["benchmark", "--policies", f"{spec},lqr", "--no-figures", "--store", str(store)]) == 2
    assert "--trust-code" in capsys.readouterr().err
    assert main(["benchmark", "--policies", f"{spec},lqr", "--trust-code", "--policy-kwargs", '{"k_phi": 1.0}',
                 "--no-figures", "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert "| DLC120-v0 | Gains(k_phi=1) |" in out  # named by its class and arguments, as from Python
    assert {r["policy_id"] for r in ResultStore(store).rows("paper")} == {"Gains(k_phi=1)", "lqr"}
    figures = tmp_path / "plots"
    assert main(["plot", "--policies", spec, "--trust-code", "--env", "DLC120-v0", "--out", str(figures)]) == 0
    assert (figures / "dlc120_v0_trajectories.png").is_file()


def test_video_takes_trust_code(user_module: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "clip.gif"
    argv = ["video", "--policy", f"{user_module}:FromEnv", "--env", "DLC120-v0", "--out", str(out),
            "--seconds", "0.4", "--fps", "5", "--width", "64", "--height", "64"]
    assert main(argv) == 2
    assert "--trust-code" in capsys.readouterr().err
    assert main([*argv, "--trust-code", "--policy-kwargs", json.dumps({"k_y": 0.1})]) == 0
    assert out.is_file() and out.stat().st_size > 0
