"""Train PPO / SAC / TD3 on the native vector env and write a run folder.

``train("ppo", timesteps=1_000_000, seed=0, run_dir="runs/ppo_s0")`` trains on ``TrackingSB3VecEnv`` (one compiled
call steps every car) wrapped in ``VecNormalize`` (observation statistics are saved with the agent), with the
hyperparameters of ``vtrack_gym/agents/hyperparams/<algo>.yaml`` for ``env_id`` (rl-zoo style, read with
``yaml.safe_load``; ``activation_fn`` is a name from a fixed table, nothing is evaluated).

The run folder holds:

* ``config.json``: algo, env id, hyperparameters (+ their file version), overrides, seed, timesteps, command,
  package / SB3 / torch versions, start time, ``timesteps_effective`` (``timesteps`` rounded up to whole PPO
  rollouts or vector steps) and the warnings of ``check_hyperparams``; at the end ``timesteps_done`` (the steps
  actually trained) and ``interrupted`` (true if Ctrl+C stopped the run early, with ``interrupted_during``: warm
  start or learning)
* ``logs/``: TensorBoard events if ``tensorboard`` is installed, else SB3's ``progress.csv`` (+ stdout log)
* ``evaluations.jsonl``: one line per periodic evaluation (deterministic policy, seed 0, nonlinear plant) on
  the two paper scenarios. ``DLC120-v0`` (<= 3000 steps) runs in full every ``eval_freq`` steps;
  ``LateralTracking-v0`` (one lap is ~21,500 steps, ~10-20 s of wall time) runs capped at
  ``case1_max_steps`` steps (default 3000 = 30 s of driving) at the same times and in full only every
  ``case1_full_every``-th evaluation and at the end. Each line records the metrics, the termination and
  the number of steps so a capped run is never mistaken for a full lap.
* ``model.zip`` + ``vecnormalize.pkl`` (SB3's own formats, for resuming; trusted local files only) and
  ``agent.json`` + ``agent.npz`` (the weights-only export of the final model, loaded by ``load_agent``)
* ``best_agent.json`` + ``best_agent.npz``: the weights-only export of the checkpoint with the best
  ``selection_score`` among the periodic evaluations after RL updates (absent if none completed the lane
  change without a failure on the handling course; a ``--bc-expert`` warm start is evaluated at timestep 0
  but is not eligible), and ``best_model.zip``, the same checkpoint in SB3's format. Note: this selects on
  the two paper scenarios, which training never drives on, as rl-zoo's ``best_model`` selects on its
  evaluation env.
"""

from __future__ import annotations

import json
import logging
import math
import os
import shlex
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from vtrack_gym._io import atomic_output, check_output_dir, write_atomic

log = logging.getLogger(__name__)

ALGOS = ("ppo", "sac", "td3")
DEFAULT_ENV_ID = "vtrack/TrainingMix-v0"
"""Training env of the from-scratch recipes (``envs.scenarios.TRAINING_MIX``)."""
IMITATION_ENV_ID = "LateralTrackingRandom-v0"
"""Training env of the behaviour-cloning recipes (``bc``), whose ``bc_finetune`` settings live under it."""
REGULARISED_SAC_KEYS = frozenset({"bc_weight", "temporal_smoothness", "spatial_smoothness", "spatial_noise"})
"""SAC hyperparameters that select ``regularised_sac.RegularisedSAC`` (extra actor-loss terms)."""
HYPERPARAMS_DIR = Path(__file__).with_name("hyperparams")
EVAL_ENV_IDS = ("DLC120-v0", "LateralTracking-v0")
_ACTIVATIONS = ("tanh", "relu")
RUN_FILES = ("config.json", "model.zip", "vecnormalize.pkl", "best_model.zip", "agent.json", "agent.npz",
             "best_agent.json", "best_agent.npz", "bc.json", "evaluations.jsonl", "vtrack-train.sig")
"""Files ``train`` writes at the top of its run folder."""
LOG_FILE_PATTERNS = ("progress.csv", "log.txt", "events.out.tfevents.*")
"""Files SB3's logger writes into ``<run>/logs`` (CSV, text log, TensorBoard events)."""


def previous_run_files(run_dir: str | Path) -> list[Path]:
    """The files of an earlier ``train`` run in ``run_dir``: its ``RUN_FILES``, the logger's files in ``logs/``
    (``LOG_FILE_PATTERNS``) and temporary files left by an interrupted atomic write. Nothing else."""
    run = Path(run_dir)
    if not run.is_dir():
        return []
    found = [run / name for name in RUN_FILES if (run / name).is_file() or (run / name).is_symlink()]
    found += [f for name in RUN_FILES for f in run.glob(f".{name}.*.tmp") if f.is_file()]
    logs = run / "logs"
    if logs.is_dir() and not logs.is_symlink():
        found += sorted(f for pattern in LOG_FILE_PATTERNS for f in logs.glob(pattern) if f.is_file())
    return found


def check_run_dir(run_dir: str | Path, overwrite: bool = False) -> list[Path]:
    """``ValueError`` naming the folder if ``run_dir`` already holds a run and ``overwrite`` is false (mixing two
    runs' evaluations, logs and checkpoints in one folder); returns the files ``--overwrite`` would remove."""
    logs = Path(run_dir) / "logs"
    if logs.is_symlink():
        raise ValueError(f"--run-dir {run_dir}: logs is a symbolic link (to {os.readlink(logs)}); training writes "
                         "its logs only into a real folder of the run: remove the link")
    check_output_dir(logs, "--run-dir")
    files = previous_run_files(run_dir)
    if files and not overwrite:
        names = ", ".join(str(f.relative_to(run_dir)) for f in files[:6]) + (", ..." if len(files) > 6 else "")
        raise ValueError(f"--run-dir {run_dir} already holds a `vtrack train` run ({names}); train into a new "
                         "folder, or pass --overwrite to delete that run's files first")
    return files


def _clear_previous_run(run_dir: Path, overwrite: bool) -> None:
    """Remove the previous run's files (``previous_run_files``, only with ``overwrite``; else ``check_run_dir``
    refuses), and ``logs/`` if that leaves it empty."""
    files = check_run_dir(run_dir, overwrite)
    for f in files:
        f.unlink()
    if files:
        log.info("--overwrite: removed %d files of the previous run in %s", len(files), run_dir)
        try:
            (run_dir / "logs").rmdir()  # only if empty: anything else the user keeps there stays
        except OSError:
            pass


def load_hyperparams(algo: str, env_id: str = DEFAULT_ENV_ID) -> tuple[dict[str, Any], int]:
    """``(hyperparameters for env_id, file version)`` from ``hyperparams/<algo>.yaml`` (``yaml.safe_load``; the
    file's keys are scenario names, ``vtrack/`` ids are looked up without the namespace)."""
    import yaml

    env_id = env_id.removeprefix("vtrack/")
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS} (got {algo!r})")
    path = HYPERPARAMS_DIR / f"{algo}.yaml"
    with path.open(encoding="utf-8") as fh:
        data = yaml.safe_load(fh)
    if not isinstance(data, dict) or not isinstance(data.get("version"), int):
        raise ValueError(f"{path}: expected a mapping with an integer 'version'")
    if env_id not in data:
        known = sorted(k for k in data if k != "version")
        raise ValueError(f"{path}: no hyperparameters for {env_id!r} (have {known})")
    params = data[env_id]
    if not isinstance(params, dict):
        raise ValueError(f"{path}: entry {env_id!r} must be a mapping")
    return dict(params), int(data["version"])


MAX_BATCH_SIZE = 2**17
"""Largest ``batch_size`` [transitions] (beyond what fits a 2-core machine's memory and time budget)."""
MAX_BUFFER_SIZE = 10**8
"""Largest off-policy ``buffer_size`` [transitions]."""
SB3_DEFAULTS = {"ppo": {"n_steps": 2048, "batch_size": 64},
                "sac": {"buffer_size": 1_000_000, "batch_size": 256, "learning_starts": 100},
                "td3": {"buffer_size": 1_000_000, "batch_size": 256, "learning_starts": 100}}
"""SB3's defaults of the hyperparameters ``check_hyperparams`` relates to each other, when a set omits them."""


def _number(key: str, value: Any, low: float, high: float, low_open: bool = False) -> float:
    """``value`` as a float if it is a finite real number in [low, high] (``(low, high]`` if ``low_open``), else
    ``ValueError`` naming the hyperparameter and its range."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)
    ok = ok and (value > low if low_open else value >= low) and value <= high
    if not ok:
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}]" if np.isfinite(high) else \
            f"{'> ' if low_open else '>= '}{low:g}"
        raise ValueError(f"hyperparameter {key} must be a number {'in ' if np.isfinite(high) else ''}{interval} "
                         f"(got {value!r})")
    return float(value)


def _integer(key: str, value: Any, low: int, high: int) -> int:
    """``value`` if it is an int in [low, high], else ``ValueError`` naming the hyperparameter and its range."""
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"hyperparameter {key} must be an integer in [{low}, {high}] (got {value!r})")
    return value


def _batch_size(value: Any, low: int, limit: int, limit_text: str, fix: str) -> None:
    """``ValueError`` unless ``value`` is an int in [low, min(limit, MAX_BATCH_SIZE)]; the message says where
    the upper end comes from (``limit_text``) and how to fix it."""
    high = min(limit, MAX_BATCH_SIZE)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"hyperparameter batch_size must be an integer in [{low}, {high}] ({limit_text}, at most "
                         f"{MAX_BATCH_SIZE}) (got {value!r}): {fix}")


def check_hyperparams(algo: str, params: Mapping[str, Any], n_envs: Any, timesteps: int) -> dict[str, Any]:
    """Refuse (``ValueError`` naming the key and its range) values that crash SB3 or train nonsense: ``gamma``
    in (0, 1], ``gae_lambda`` in [0, 1], ``clip_range`` > 0, ``ent_coef`` >= 0 (SAC: or ``auto`` / ``auto_X``),
    ``tau`` in (0, 1], ``train_freq`` >= 1, ``learning_starts`` >= 0, ``batch_size`` in [2, n_steps x n_envs]
    (PPO) or [1, buffer_size] (SAC/TD3), at most ``MAX_BATCH_SIZE``. Returns notes for the run's config:
    ``timesteps_effective`` (PPO trains whole rollouts of n_steps x n_envs transitions; SAC/TD3 whole vector
    steps of n_envs) and warnings (SAC/TD3 ``learning_starts`` >= ``timesteps``: never updated)."""
    p = {**SB3_DEFAULTS[algo], **params}
    n_envs = _integer("n_envs", n_envs, 1, 4096)
    if "gamma" in p:
        _number("gamma", p["gamma"], 0.0, 1.0, low_open=True)
    if "learning_starts" in p:
        _integer("learning_starts", p["learning_starts"], 0, 10**12)
    if algo == "ppo":
        if "gae_lambda" in p:
            _number("gae_lambda", p["gae_lambda"], 0.0, 1.0)
        if "clip_range" in p and not isinstance(p["clip_range"], str):  # "lin_X": checked by _schedule
            _number("clip_range", p["clip_range"], 0.0, float("inf"), low_open=True)
        if "ent_coef" in p:
            _number("ent_coef", p["ent_coef"], 0.0, float("inf"))
        n_steps = _integer("n_steps", p["n_steps"], 1, 10**7)
        rollout = n_steps * n_envs
        if rollout < 2:
            raise ValueError(f"hyperparameter n_steps x n_envs must be >= 2 (got {n_steps} x {n_envs})")
        _batch_size(p["batch_size"], 2, rollout, f"n_steps x n_envs = {n_steps} x {n_envs} = {rollout}",
                    "--set batch_size=N, or more --num-envs or n_steps")
        chunk = rollout
    else:
        buffer_size = _integer("buffer_size", p["buffer_size"], 1, MAX_BUFFER_SIZE)
        _batch_size(p["batch_size"], 1, buffer_size, f"buffer_size = {buffer_size}", "--set batch_size=N")
        if "tau" in p:
            _number("tau", p["tau"], 0.0, 1.0, low_open=True)
        freq = p.get("train_freq", 1)
        if isinstance(freq, (list, tuple)):
            if len(freq) != 2 or freq[1] not in ("step", "episode"):
                raise ValueError(f"hyperparameter train_freq must be an integer >= 1 or [N, step|episode] "
                                 f"(got {freq!r})")
            freq = freq[0]
        _integer("train_freq", freq, 1, 10**9)
        ent = p.get("ent_coef")
        if algo == "sac" and ent is not None:
            if isinstance(ent, str):
                head, sep, start = ent.partition("_")
                try:   # "auto", or "auto_X" with a finite X > 0 ("auto_" and "auto_inf" crash inside SB3)
                    ok = head == "auto" and (not sep or (math.isfinite(float(start)) and float(start) > 0.0))
                except ValueError:
                    ok = False
                if not ok:
                    raise ValueError(f"hyperparameter ent_coef must be a number >= 0, 'auto' or 'auto_X' with "
                                     f"X > 0 (got {ent!r})")
            else:
                _number("ent_coef", ent, 0.0, float("inf"))
        chunk = n_envs
    notes: dict[str, Any] = {"timesteps_effective": -(-timesteps // chunk) * chunk, "warnings": []}
    if algo == "ppo" and notes["timesteps_effective"] != timesteps:
        notes["warnings"].append(f"PPO trains whole rollouts of n_steps x n_envs = {chunk} transitions: "
                                 f"--timesteps {timesteps} becomes {notes['timesteps_effective']}")
    if algo != "ppo" and p["learning_starts"] >= timesteps:
        notes["warnings"].append(f"learning_starts = {p['learning_starts']} >= --timesteps {timesteps}: the agent "
                                 "will never be updated (it stays the random initial policy)")
    return notes


def _policy_kwargs(raw: Mapping[str, Any] | None) -> dict[str, Any]:
    import torch.nn as nn

    kwargs = dict(raw or {})
    act = kwargs.get("activation_fn")
    if act is not None:
        if act not in _ACTIVATIONS:
            raise ValueError(f"policy_kwargs.activation_fn must be one of {_ACTIVATIONS} (got {act!r})")
        kwargs["activation_fn"] = {"tanh": nn.Tanh, "relu": nn.ReLU}[act]
    net_arch = kwargs.get("net_arch")
    if isinstance(net_arch, dict):
        kwargs["net_arch"] = {k: list(v) for k, v in net_arch.items()}
    return kwargs


def _schedule(name: str, value: Any) -> Any:
    """A number as is, or ``"lin_X"`` (rl-zoo's notation) as a schedule falling linearly from X to 0 over the run
    (SB3 calls it with the remaining progress, 1 -> 0)."""
    if not isinstance(value, str):
        return value
    head, _, number = value.partition("_")
    try:
        start = float(number)
    except ValueError:
        start = float("nan")
    if head != "lin" or not (start > 0.0 and start < 1e3):
        raise ValueError(f"{name} must be a number or 'lin_X' with X > 0, e.g. lin_3e-4 (got {value!r})")
    return lambda progress_remaining: progress_remaining * start


class _Wrapped:
    """SB3 model + frozen VecNormalize statistics as a ``predict`` policy on raw observations."""

    policy_id = "training_agent"

    def __init__(self, model: Any, vecnorm: Any) -> None:
        self.model, self.vecnorm = model, vecnorm

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        obs = np.asarray(observation, dtype=np.float32)
        if self.vecnorm is not None:
            obs = self.vecnorm.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=deterministic)
        return action, None


def evaluate_paper(policy: Any, case1_max_steps: int | None = 3000, seed: int = 0) -> dict[str, dict[str, Any]]:
    """Deterministic rollouts on both paper scenarios: ``{env_id: metrics + termination + steps}``."""
    from vtrack_gym.evaluation.metrics import paper_metrics, smoothness_metrics
    from vtrack_gym.evaluation.rollout import rollout

    out: dict[str, dict[str, Any]] = {}
    for env_id in EVAL_ENV_IDS:
        cap = case1_max_steps if env_id == "LateralTracking-v0" else None
        trace = rollout(policy, env_id, seed=seed, max_steps=cap)
        m = {**paper_metrics(trace), **smoothness_metrics(trace)}
        row: dict[str, Any] = {k: float(m[k]) for k in ("rms_e_y_m", "max_e_y_m", "rms_e_phi_deg",
                                                        "max_hand_wheel_deg", "max_a_y_mps2",
                                                        "steering_reversals_per_s")}
        row.update(termination=trace.termination, completed=bool(trace.completed), success=bool(trace.success),
                   steps=int(trace.n_steps),
                   step_cap=cap, progress_m=float(trace["progress_m"][-1]) if "progress_m" in trace.signals else None)
        out[env_id] = row
    return out


FAILURES = ("off_road", "spin_out", "wheel_lift", "invalid_state")


def selection_score(results: Mapping[str, Mapping[str, Any]]) -> float:
    """Checkpoint-selection score of one periodic evaluation (lower is better): the ``DLC120-v0`` max|e_y| [m]
    if the lane change succeeded (completed, every cone gate passed) and the ``LateralTracking-v0`` run (full lap
    or capped) did not fail, else +inf. The run keeps the best-scoring checkpoint as ``best_agent.json/.npz`` (see
    ``train``)."""
    dlc, lap = results.get("DLC120-v0"), results.get("LateralTracking-v0")
    if not dlc or not lap or not dlc.get("success", dlc.get("completed")) or lap.get("termination") in FAILURES:
        return float("inf")
    if lap.get("step_cap") is None and not lap.get("completed"):
        return float("inf")
    return float(dlc["max_e_y_m"])


def _make_callbacks(run_dir: Path, vecnorm: Any, timesteps: int, eval_freq: int, case1_max_steps: int | None,
                    case1_full_every: int, progress_bar: bool, env_id: str, command: str,
                    seed: int, warm_start: str, contract_env: Any) -> list[Any]:
    from stable_baselines3.common.callbacks import BaseCallback

    class ProgressBar(BaseCallback):
        def _on_training_start(self) -> None:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=timesteps, unit="step", desc="train", mininterval=2.0)

        def _on_step(self) -> bool:
            self.bar.update(max(min(self.num_timesteps, timesteps) - self.bar.n, 0))  # tqdm throttles redraws
            return True

        def _on_training_end(self) -> None:
            self.bar.update(max(min(self.num_timesteps, timesteps) - self.bar.n, 0))
            self.bar.close()

    class PaperEval(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next_eval = eval_freq
            self.count = 0
            self.best_score = float("inf")

        def run(self, final: bool = False) -> None:
            self.count += 1
            full = final or (case1_full_every > 0 and self.count % case1_full_every == 0)
            log.info("evaluating on LateralTracking-v0 (%s) and DLC120-v0 at step %d", "full lap" if full else
                     f"first {case1_max_steps} steps", self.num_timesteps)
            t0 = time.perf_counter()
            res = evaluate_paper(_Wrapped(self.model, vecnorm), None if full else case1_max_steps)
            for eval_id, row in res.items():  # not env_id: that is the training env id exported below
                for key in ("rms_e_y_m", "max_e_y_m", "completed", "steps", "steering_reversals_per_s"):
                    self.logger.record(f"eval/{eval_id}/{key}", float(row[key]))
            score = selection_score(res)
            # the warm start itself (timestep 0) is reported but not eligible: best_agent is an RL checkpoint
            best = score < self.best_score and self.num_timesteps > 0
            if best:
                from vtrack_gym.agents.export import export

                self.best_score = score
                export(self.model, vecnorm, run_dir / "best_agent", env_id=env_id, command=command, seed=seed,
                       warm_start=warm_start, env=contract_env)
                self.model.save(run_dir / "best_model.zip")  # SB3's own format, to check the export against
            self.logger.record("eval/selection_score", score)
            with (run_dir / "evaluations.jsonl").open("a", encoding="utf-8") as fh:
                fh.write(json.dumps({"timesteps": int(self.num_timesteps), "final": final,
                                     "wall_s": round(time.perf_counter() - t0, 2), "selection_score": score,
                                     "new_best": best, "results": res}) + "\n")

        def _on_step(self) -> bool:
            if eval_freq > 0 and self.num_timesteps >= self.next_eval:
                self.next_eval += eval_freq
                self.run()
            return True

    callbacks: list[Any] = [PaperEval()]
    if progress_bar:
        callbacks.append(ProgressBar())
    return callbacks


def train(algo: str, env_id: str | None = None, timesteps: int = 1_000_000, seed: int = 0,
          run_dir: str | Path = "vtrack_runs/run", *, num_envs: int | None = None,
          overrides: Mapping[str, Any] | None = None, eval_freq: int = 100_000, case1_max_steps: int | None = 3000,
          case1_full_every: int = 5, final_eval: bool = True, progress_bar: bool = True, verbose: int = 0,
          torch_threads: int | None = 1, command: str | None = None, bc: Any = None,
          overwrite: bool = False) -> dict[str, Any]:
    """Train ``algo`` on ``env_id`` and write ``run_dir`` (see the module docstring). Returns a summary dict.

    ``overrides`` replace YAML entries (e.g. ``{"n_steps": 64}``; a value of ``None`` drops the entry);
    ``num_envs`` overrides ``n_envs``. ``env_id`` ``None``: ``DEFAULT_ENV_ID`` from scratch, ``IMITATION_ENV_ID``
    with ``bc``.
    ``eval_freq <= 0`` disables periodic evaluation. ``bc`` (a ``vtrack_gym.agents.imitation.BCConfig``, PPO or
    SAC) starts from a behaviour-cloned actor: the YAML entry's ``bc_finetune`` values are applied on top, the
    expert data and the fit go to ``bc.json``, and the warm-started agent is evaluated at timestep 0. A
    ``bc_weight`` hyperparameter (SAC with ``bc`` only) selects ``RegularisedSAC``, whose actor loss keeps a
    behaviour-cloning term on the warm start's expert labels; so do ``temporal_smoothness`` /
    ``spatial_smoothness`` (SAC; CAPS-style terms on the deterministic action, see ``regularised_sac``).
    On ``KeyboardInterrupt`` (Ctrl+C) during the warm start or learning, the model is saved and exported as it
    is, ``config.json`` records ``interrupted: true`` and ``timesteps_done``, the final evaluation is skipped
    and the summary's ``interrupted`` is true (``vtrack train`` exits with 130).
    A ``run_dir`` that already holds a run is refused (``check_run_dir``) unless ``overwrite``, which deletes
    that run's files (``previous_run_files``, nothing else) once every setting has been checked.
    """
    import stable_baselines3
    import torch
    from stable_baselines3 import PPO, SAC, TD3
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from vtrack_gym._version import __version__
    from vtrack_gym.agents.export import export, sign_run, training_env_kwargs
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    if not isinstance(timesteps, int) or timesteps < 1:
        raise ValueError(f"timesteps must be a positive int (got {timesteps!r})")
    if env_id is None:
        env_id = DEFAULT_ENV_ID if bc is None else IMITATION_ENV_ID
    if torch_threads:
        torch.set_num_threads(torch_threads)
    params, hp_version = load_hyperparams(algo, env_id)
    finetune = params.pop("bc_finetune", None) or {}
    if bc is not None:
        if algo not in ("ppo", "sac"):
            raise ValueError(f"the behaviour-cloning warm start supports ppo and sac (got {algo!r})")
        params.update(dict(finetune))
    params.update(dict(overrides or {}))
    for key in [k for k, v in params.items() if v is None]:  # an override of None drops the entry
        del params[key]
    if "bc_weight" in params and (algo != "sac" or bc is None):
        raise ValueError("bc_weight applies to --algo sac with a --bc-expert warm start only")
    if algo != "sac" and REGULARISED_SAC_KEYS & params.keys():
        raise ValueError(f"{sorted(REGULARISED_SAC_KEYS & params.keys())} apply to --algo sac only")
    if num_envs is not None:
        params["n_envs"] = int(num_envs)
    checked = check_hyperparams(algo, params, params.get("n_envs", 8), timesteps)
    for warning in checked["warnings"]:
        log.warning("%s", warning)
    run_dir = Path(run_dir)
    command = command if command is not None else shlex.join([Path(sys.argv[0]).name, *sys.argv[1:]])
    config = {"algo": algo, "env_id": env_id, "timesteps": timesteps, "seed": seed,
              "timesteps_effective": checked["timesteps_effective"], "warnings": checked["warnings"],
              "hyperparams": json.loads(json.dumps(params)),
              "hyperparams_file": f"vtrack_gym/agents/hyperparams/{algo}.yaml", "hyperparams_version": hp_version,
              "overrides": dict(overrides or {}), "command": command, "package_version": __version__,
              "sb3_version": stable_baselines3.__version__, "torch_version": torch.__version__,
              "python": sys.version.split()[0], "eval": {"freq": eval_freq, "case1_max_steps": case1_max_steps,
                                                           "case1_full_every": case1_full_every},
              "bc": None if bc is None else bc.as_dict(),
              "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}

    n_envs = int(params.pop("n_envs", 8))
    policy = params.pop("policy", "MlpPolicy")
    if policy != "MlpPolicy":  # SB3 would accept CnnPolicy etc., which the agent format cannot hold
        raise ValueError(f"policy must be MlpPolicy, the only policy an agent file can hold (got {policy!r})")
    norm_kwargs = dict(params.pop("normalize", {}) or {})
    noise_std = params.pop("action_noise_std", None)
    obs_scaling = params.pop("obs_scaling", "running")
    env_kwargs = training_env_kwargs(params.pop("env_kwargs", None))
    params["policy_kwargs"] = _policy_kwargs(params.get("policy_kwargs"))
    for key in ("learning_rate", "clip_range"):
        if key in params:
            params[key] = _schedule(key, params[key])
    venv = TrackingSB3VecEnv(env_id, num_envs=n_envs, **env_kwargs)
    venv.seed(seed)
    vecnorm = VecNormalize(VecMonitor(venv), **norm_kwargs)  # VecMonitor: rollout/ep_rew_mean, ep_len_mean
    if obs_scaling == "fixed":
        from vtrack_gym.agents.obs_scaling import freeze_observation_scaling

        freeze_observation_scaling(vecnorm, venv.venv.observation_layout.names)
    elif obs_scaling != "running":
        venv.close()
        raise ValueError(f"obs_scaling must be 'fixed' or 'running' (got {obs_scaling!r})")
    if noise_std is not None:
        dim = venv.action_space.shape[0]
        params["action_noise"] = NormalActionNoise(np.zeros(dim), float(noise_std) * np.ones(dim))
    cls = {"ppo": PPO, "sac": SAC, "td3": TD3}[algo]
    if REGULARISED_SAC_KEYS & params.keys():  # extra actor-loss terms (BC needs the warm start's demonstrations)
        from vtrack_gym.agents.regularised_sac import RegularisedSAC

        cls = RegularisedSAC
    try:
        model = cls("MlpPolicy", vecnorm, seed=seed, verbose=verbose, device="cpu", **params)
    except (TypeError, AssertionError) as exc:  # an unknown key or a wrongly typed value (YAML file or --set)
        venv.close()
        raise ValueError(f"{algo} hyperparameters: {type(exc).__name__}: {exc} (see "
                         f"vtrack_gym/agents/hyperparams/{algo}.yaml)") from exc
    except ValueError:  # a value out of its range: nothing of the run folder is written or replaced
        venv.close()
        raise
    try:
        _check_exportable(model, vecnorm, venv.venv, algo)  # before learning, not after hours of it
        _clear_previous_run(run_dir, overwrite)
    except ValueError:
        venv.close()
        raise
    run_dir.mkdir(parents=True, exist_ok=True)
    write_atomic(run_dir / "config.json", json.dumps(config, indent=2, sort_keys=True) + "\n")
    try:
        import tensorboard  # noqa: F401

        formats = ["tensorboard", "csv", "log"]
    except ImportError:
        formats = ["csv", "log"]
    model.set_logger(configure(str(run_dir / "logs"), formats))
    warm_start = "" if bc is None else (f"behaviour cloning of {bc.expert}[{bc.expert_preset}] on {env_id} "
                                        f"({bc.steps} x {n_envs} expert transitions, {bc.dagger_rounds} DAgger rounds)")
    callbacks = _make_callbacks(run_dir, vecnorm, timesteps, eval_freq, case1_max_steps, case1_full_every,
                                progress_bar, env_id, command, seed, warm_start, venv.venv)
    t0 = time.perf_counter()
    interrupted = ""
    try:
        if bc is not None:
            interrupted = "warm start"
            _behaviour_clone(model, venv, vecnorm, bc, seed, run_dir)
            if eval_freq > 0:
                callbacks[0].init_callback(model)
                callbacks[0].run()
        interrupted = "learning"
        log.info("training %s for %d steps", type(model).__name__, timesteps)
        model.learn(total_timesteps=timesteps, callback=callbacks)
        interrupted = ""
    except KeyboardInterrupt:  # Ctrl+C: keep the model as it is (saved and exported below), skip the final eval
        for cb in callbacks:
            if getattr(cb, "bar", None) is not None:
                cb.bar.close()
        log.warning("interrupted during the %s at %d timesteps: saving the model and exporting the agent as they "
                    "are", interrupted, model.num_timesteps)
    train_s = time.perf_counter() - t0
    vecnorm.training = False
    config.update(timesteps_done=int(model.num_timesteps), interrupted=bool(interrupted))
    if interrupted:
        config["interrupted_during"] = interrupted
    write_atomic(run_dir / "config.json", json.dumps(config, indent=2, sort_keys=True) + "\n")
    with atomic_output(run_dir / "model.zip", "--run-dir") as tmp:
        model.save(tmp)
    with atomic_output(run_dir / "vecnormalize.pkl", "--run-dir") as tmp:
        vecnorm.save(str(tmp))
    sign_run(run_dir)  # lets `vtrack export --run-dir` unpickle this run's files without --trust
    agent_json, _ = export(model, vecnorm, run_dir / "agent", env_id=env_id, command=command, seed=seed,
                           warm_start=warm_start, env=venv.venv)
    final = None
    if final_eval and not interrupted:
        callbacks[0].run(final=True)
        lines = (run_dir / "evaluations.jsonl").read_text(encoding="utf-8").strip().splitlines()
        final = json.loads(lines[-1])["results"]
    summary = {"run_dir": str(run_dir), "timesteps": int(model.num_timesteps), "train_s": round(train_s, 1),
               "agent": str(agent_json), "final_eval": final, "interrupted": bool(interrupted),
               "model": model, "vecnormalize": vecnorm}
    venv.close()
    return summary


def _check_exportable(model: Any, vecnorm: Any, contract_env: Any, algo: str) -> None:
    """``ValueError`` with the reason if ``model`` (freshly built) would make an agent that ``export`` or
    ``load_agent`` refuses (gSDE's clipped SAC mean, PPO's squash_output, an empty or too wide layer, ...):
    a dry-run export into a temporary folder, loaded back. Nothing is written to the run folder."""
    import tempfile

    from vtrack_gym.agents.export import export
    from vtrack_gym.baselines.numpy_policy import load_agent

    with tempfile.TemporaryDirectory(prefix="vtrack-export-check-") as tmp:
        try:
            export(model, vecnorm, Path(tmp) / "agent", env=contract_env)
            load_agent(Path(tmp) / "agent")
        except ValueError as exc:
            raise ValueError(f"{algo} hyperparameters (vtrack_gym/agents/hyperparams/{algo}.yaml and --set) make "
                             f"an agent that cannot be exported: {exc}; nothing was trained or written") from None


def _behaviour_clone(model: Any, venv: Any, vecnorm: Any, bc: Any, seed: int, run_dir: Path) -> None:
    """Warm start (``vtrack_gym.agents.imitation``): expert data, fit, SAC replay buffer; writes ``bc.json``."""
    from vtrack_gym.agents import imitation

    t0 = time.perf_counter()
    log.info("warm start: %s drives %d x %d steps of expert data, %d DAgger rounds, then the actor is fitted",
             bc.expert, bc.steps, venv.num_envs, bc.dagger_rounds)
    rounds, fit = imitation.warm_start(model, venv, vecnorm, bc, seed=seed)
    prefilled = 0
    if hasattr(model, "replay_buffer"):
        prefilled = imitation.prefill_replay_buffer(model, rounds)
        fit["critic_loss"] = imitation.pretrain_critic(model, bc.critic_steps, int(model.batch_size))
    if hasattr(model, "set_demonstrations"):  # RegularisedSAC: the expert's labels on every round's states
        model.set_demonstrations(*imitation.labelled_states(rounds))
    record = {"config": bc.as_dict(), "transitions": sum(d.transitions for d in rounds), "fit": fit,
              "replay_buffer_prefilled": prefilled, "wall_s": round(time.perf_counter() - t0, 1)}
    write_atomic(run_dir / "bc.json", json.dumps(record, indent=2, sort_keys=True) + "\n")
