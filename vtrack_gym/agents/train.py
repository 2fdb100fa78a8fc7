"""Train PPO / SAC / TD3 on the native vector env and write a run folder.

``train("ppo", seed=0, run_dir="runs/ppo_s0")`` trains on ``TrackingSB3VecEnv`` (one compiled call steps every
car) wrapped in ``VecNormalize`` (observation statistics are saved with the agent), with the hyperparameters of
``vtrack_gym/agents/hyperparams/<algo>.yaml`` for ``env_id`` (rl_zoo3's format, read with ``yaml.safe_load``;
nothing is evaluated: see ``agents.recipes``), for the entry's ``n_timesteps`` unless ``timesteps`` is given.
``train`` runs in phases, one function each: configuration check (``_configure``), env building
(``_build_envs``), model building (``_build_model``), the run folder (``_open_run_dir``), learning (``_learn``)
and export (``_save_and_export``).

The run folder holds:

* ``config.json``: algo, env id, hyperparameters (+ the SHA-256 of their file), overrides, seed, timesteps, command,
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
* ``bc_agent.json`` + ``bc_agent.npz`` (with a ``--bc-expert`` warm start): the weights-only export of the cloned
  actor before any RL update (``provenance.timesteps`` 0, the warm start recorded), to compare with the fine-tune
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

import errno
import json
import logging
import os
import shlex
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vtrack_gym._io import atomic_output, check_output_dir, check_output_file, output_error, write_atomic
from vtrack_gym.agents.recipes import (
    ALGOS,
    DEFAULT_ENV_ID,
    HYPERPARAMS_DIR,
    IMITATION_ENV_ID,
    REGULARISED_SAC_KEYS,
    _integer,
    _schedule,
    action_noise,
    check_hyperparams,
    load_hyperparams,
    observation_scaling,
    policy_kwargs,
)

__all__ = ["ALGOS", "DEFAULT_ENV_ID", "EVAL_ENV_IDS", "HYPERPARAMS_DIR", "IMITATION_ENV_ID", "LOG_FILE_PATTERNS",
           "RUN_FILES", "check_hyperparams", "check_run_dir", "evaluate_paper", "load_hyperparams",
           "previous_run_files", "selection_score", "train"]

log = logging.getLogger(__name__)

EVAL_ENV_IDS = ("DLC120-v0", "LateralTracking-v0")
RUN_FILES = ("config.json", "model.zip", "vecnormalize.pkl", "best_model.zip", "agent.json", "agent.npz",
             "best_agent.json", "best_agent.npz", "bc.json", "dagger.json", "bc_agent.json", "bc_agent.npz", "evaluations.jsonl",
             "vtrack-train.sig", "episodes.jsonl", "finetune.json")
"""Files ``train`` writes at the top of its run folder."""
LOG_FILE_PATTERNS = ("progress.csv", "log.txt", "events.out.tfevents.*")
"""Files SB3's logger writes into ``<run>/logs`` (CSV, text log, TensorBoard events)."""
WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM)
"""Errors of a write that stopped training are reported as the run folder's (a full or read-only disk)."""
LOG_FILES = ("progress.csv", "log.txt")
"""The logger files with fixed names: each must pass the output gate's check (absent or a regular file) before
training, as they grow while training runs and are written in place, not renamed (TensorBoard's event file gets a
new unique name in the checked ``logs/`` folder)."""


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
    for name in LOG_FILES:   # a FIFO here would block SB3's open for ever, a device link swallow the logs
        check_output_file(logs / name, "--run-dir")
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


def evaluate_paper(policy: Any, case1_max_steps: int | None = 3000, seed: int = 0,
                   control: str = "steer") -> dict[str, dict[str, Any]]:
    """Deterministic rollouts on both paper scenarios (in the control mode ``control``, ``envs.control``):
    ``{env_id: metrics + termination + steps}``."""
    import gymnasium as gym

    from vtrack_gym.evaluation.rollouts.rollout import rollout
    from vtrack_gym.evaluation.scoring.metrics import paper_metrics, smoothness_metrics

    out: dict[str, dict[str, Any]] = {}
    for env_id in EVAL_ENV_IDS:
        cap = case1_max_steps if env_id == "LateralTracking-v0" else None
        env = gym.make(env_id, control=control) if control != "steer" else env_id
        trace = rollout(policy, env, seed=seed, max_steps=cap)
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


def _progress_bar(timesteps: int) -> Any:
    """An SB3 callback showing a tqdm bar of ``timesteps`` steps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class ProgressBar(BaseCallback):
        def _on_training_start(self) -> None:
            from vtrack_gym._progress import progress_bar

            self.bar = progress_bar(total=timesteps, unit="step", desc="train", mininterval=2.0)

        def _on_step(self) -> bool:
            self.bar.update(max(min(self.num_timesteps, timesteps) - self.bar.n, 0))  # tqdm throttles redraws
            return True

        def _on_training_end(self) -> None:
            self.bar.update(max(min(self.num_timesteps, timesteps) - self.bar.n, 0))
            self.bar.close()

    return ProgressBar()


def _make_callbacks(run_dir: Path, vecnorm: Any, timesteps: int, eval_freq: int, case1_max_steps: int | None,
                    case1_full_every: int, progress_bar: bool, env_id: str, command: str,
                    seed: int, warm_start: str, contract_env: Any) -> list[Any]:
    """``[the periodic paper evaluation (keeps the best checkpoint), the progress bar if wanted]``."""
    from stable_baselines3.common.callbacks import BaseCallback

    class PaperEval(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next_eval = eval_freq
            self.count = 0
            self.best_score = float("inf")
            self.lines: list[str] = []   # evaluations.jsonl so far (a new run's file starts empty)

        def run(self, final: bool = False) -> None:
            self.count += 1
            full = final or (case1_full_every > 0 and self.count % case1_full_every == 0)
            log.info("evaluating on LateralTracking-v0 (%s) and DLC120-v0 at step %d", "full lap" if full else
                     f"first {case1_max_steps} steps", self.num_timesteps)
            t0 = time.perf_counter()
            res = evaluate_paper(_Wrapped(self.model, vecnorm), None if full else case1_max_steps,
                                 control=getattr(contract_env, "control", "steer"))
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
                with atomic_output(run_dir / "best_model.zip", "--run-dir") as tmp:
                    self.model.save(tmp)  # SB3's own format, to check the export against
            self.logger.record("eval/selection_score", score)
            self.lines.append(json.dumps({"timesteps": int(self.num_timesteps), "final": final,
                                          "wall_s": round(time.perf_counter() - t0, 2), "selection_score": score,
                                          "new_best": best, "results": res}) + "\n")
            write_atomic(run_dir / "evaluations.jsonl", "".join(self.lines), "--run-dir")  # whole file, renamed

        def _on_step(self) -> bool:
            if eval_freq > 0 and self.num_timesteps >= self.next_eval:
                self.next_eval += eval_freq
                self.run()
            return True

    return [PaperEval(), _progress_bar(timesteps)] if progress_bar else [PaperEval()]


@dataclass(frozen=True)
class _RunSetup:
    """A checked training run: what the config phase decided, read by the later phases."""

    algo: str
    env_id: str
    timesteps: int
    timesteps_effective: int
    seed: int
    run_dir: Path
    command: str
    bc: Any
    n_envs: int
    normalize: dict[str, Any]
    obs_scaling: str           # "fixed" or "running"
    env_kwargs: dict[str, Any]
    model_params: dict[str, Any]  # the SB3 constructor's keyword arguments, as in the file
    config: dict[str, Any]     # config.json


def _merged_params(algo: str, env_id: str, overrides: Mapping[str, Any] | None, bc: Any,
                   num_envs: int | None, control: str | None = None) -> tuple[dict[str, Any], str]:
    """The entry's hyperparameters with the warm start's ``bc_finetune``, ``overrides`` (None drops a key),
    ``num_envs`` and the control mode (into ``env_kwargs``) applied, checked for settings of another algorithm; and
    the file's SHA-256."""
    params, digest = load_hyperparams(algo, env_id)
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
    if control is not None:
        from vtrack_gym.envs.control import check_control

        params["env_kwargs"] = {**dict(params.get("env_kwargs") or {}), "control": check_control(control)}
    return params, digest


def _configure(algo: str, env_id: str | None, timesteps: int | None, seed: int, run_dir: str | Path,
               num_envs: int | None, overrides: Mapping[str, Any] | None, bc: Any, command: str | None,
               eval_settings: dict[str, Any], control: str | None = None) -> _RunSetup:
    """Config phase: read and check the hyperparameters, decide the run's settings and its ``config.json``."""
    import stable_baselines3
    import torch

    from vtrack_gym._version import __version__
    from vtrack_gym.agents.export import training_env_kwargs

    if timesteps is not None and (not isinstance(timesteps, int) or timesteps < 1):
        raise ValueError(f"timesteps must be a positive int (got {timesteps!r})")
    if env_id is None:
        env_id = DEFAULT_ENV_ID if bc is None else IMITATION_ENV_ID
    params, digest = _merged_params(algo, env_id, overrides, bc, num_envs, control)
    file_timesteps = params.pop("n_timesteps", None)
    if timesteps is None:
        if file_timesteps is None:
            raise ValueError(f"{env_id} in hyperparams/{algo}.yaml has no n_timesteps: pass timesteps")
        timesteps = _integer("n_timesteps", file_timesteps, 1, 10**12)
    checked = check_hyperparams(algo, params, params.get("n_envs", 8), timesteps)
    for warning in checked["warnings"]:
        log.warning("%s", warning)
    command = command if command is not None else shlex.join([Path(sys.argv[0]).name, *sys.argv[1:]])
    config = {"algo": algo, "env_id": env_id, "timesteps": timesteps, "seed": seed,
              "timesteps_effective": checked["timesteps_effective"], "warnings": checked["warnings"],
              "hyperparams": json.loads(json.dumps(params)),
              "hyperparams_file": f"vtrack_gym/agents/hyperparams/{algo}.yaml", "hyperparams_sha256": digest,
              "overrides": dict(overrides or {}), "command": command, "package_version": __version__,
              "sb3_version": stable_baselines3.__version__, "torch_version": torch.__version__,
              "python": sys.version.split()[0], "eval": eval_settings,
              "bc": None if bc is None else bc.as_dict(),
              "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    model_params = dict(params)
    n_envs = int(model_params.pop("n_envs", 8))
    policy = model_params.pop("policy", "MlpPolicy")
    if policy != "MlpPolicy":  # SB3 would accept CnnPolicy etc., which the agent format cannot hold
        raise ValueError(f"policy must be MlpPolicy, the only policy an agent file can hold (got {policy!r})")
    normalize = dict(model_params.pop("normalize", {}) or {})
    obs_scaling = observation_scaling(model_params)
    env_kwargs = training_env_kwargs(model_params.pop("env_kwargs", None))
    return _RunSetup(algo, env_id, timesteps, checked["timesteps_effective"], seed, Path(run_dir), command, bc,
                     n_envs, normalize, obs_scaling, env_kwargs, model_params, config)


def _build_envs(setup: _RunSetup) -> tuple[Any, Any]:
    """Env phase: the native vector env of ``n_envs`` cars, seeded, in ``VecMonitor`` and ``VecNormalize`` (its
    observation statistics frozen at the fixed scales when the entry's ``callback`` asks for them)."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv(setup.env_id, num_envs=setup.n_envs, **setup.env_kwargs)
    venv.seed(setup.seed)
    vecnorm = VecNormalize(VecMonitor(venv), **setup.normalize)  # VecMonitor: rollout/ep_rew_mean, ep_len_mean
    if setup.obs_scaling == "fixed":
        from vtrack_gym.agents.obs_scaling import freeze_observation_scaling

        try:
            freeze_observation_scaling(vecnorm, venv.venv.observation_layout.names)
        except ValueError:
            venv.close()
            raise
    return venv, vecnorm


def _build_model(setup: _RunSetup, venv: Any, vecnorm: Any, verbose: int) -> Any:
    """Model phase: the SB3 model (``RegularisedSAC`` for its loss weights) on ``vecnorm``; ``ValueError`` naming
    the file for a key SB3 does not take or a value it refuses, and for settings the agent format cannot hold."""
    from stable_baselines3 import PPO, SAC, TD3

    params = dict(setup.model_params)
    noise = action_noise(params, venv.action_space.shape[0])
    if noise is not None:
        params["action_noise"] = noise
    params["policy_kwargs"] = policy_kwargs(params.get("policy_kwargs"))
    for key in ("learning_rate", "clip_range"):
        if key in params:
            params[key] = _schedule(key, params[key])
    cls = {"ppo": PPO, "sac": SAC, "td3": TD3}[setup.algo]
    if REGULARISED_SAC_KEYS & params.keys():  # extra actor-loss terms (BC needs the warm start's demonstrations)
        from vtrack_gym.agents.regularised_sac import RegularisedSAC

        cls = RegularisedSAC
    try:
        model = cls("MlpPolicy", vecnorm, seed=setup.seed, verbose=verbose, device="cpu", **params)
    except (TypeError, AssertionError) as exc:  # an unknown key or a wrongly typed value (YAML file or --set)
        raise ValueError(f"{setup.algo} hyperparameters: {type(exc).__name__}: {exc} (see "
                         f"vtrack_gym/agents/hyperparams/{setup.algo}.yaml)") from exc
    _check_exportable(model, vecnorm, venv.venv, setup.algo)  # before learning, not after hours of it
    return model


def _open_run_dir(setup: _RunSetup, model: Any, overwrite: bool) -> None:
    """Run-folder phase: remove a previous run (with ``overwrite``), write ``config.json``, point SB3's logger at
    ``logs/`` (TensorBoard if installed, CSV and text)."""
    from vtrack_gym.agents.sb3_logger import log_outside_tmp

    _clear_previous_run(setup.run_dir, overwrite)
    setup.run_dir.mkdir(parents=True, exist_ok=True)
    write_atomic(setup.run_dir / "config.json", json.dumps(setup.config, indent=2, sort_keys=True) + "\n")
    log_outside_tmp(model, setup.run_dir)


def _warm_start_text(setup: _RunSetup) -> str:
    """How the actor was initialised before RL, for the agent's provenance ('' from scratch)."""
    bc = setup.bc
    if bc is None:
        return ""
    return (f"behaviour cloning of {bc.expert}[{bc.expert_preset}] on {setup.env_id} ({bc.steps} x {setup.n_envs} "
            f"expert transitions, {bc.dagger_rounds} DAgger rounds)")


def _learn(setup: _RunSetup, model: Any, venv: Any, vecnorm: Any, callbacks: list[Any],
           eval_freq: int) -> tuple[float, str]:
    """Learning phase: the warm start (evaluated at timestep 0), then ``model.learn``. Returns the wall time [s]
    and what Ctrl+C interrupted ('' if nothing: ``warm start`` or ``learning``)."""
    t0 = time.perf_counter()
    interrupted = ""
    try:
        if setup.bc is not None:
            interrupted = "warm start"
            _behaviour_clone(model, venv, vecnorm, setup)
            if eval_freq > 0:
                callbacks[0].init_callback(model)
                callbacks[0].run()
        interrupted = "learning"
        rounding = "" if setup.timesteps_effective == setup.timesteps else \
            f" ({setup.timesteps} rounded up to whole {'rollouts' if setup.algo == 'ppo' else 'vector steps'})"
        log.info("training %s for %d steps%s", type(model).__name__, setup.timesteps_effective, rounding)
        model.learn(total_timesteps=setup.timesteps, callback=callbacks)
        interrupted = ""
    except OSError as exc:  # SB3's logger files are written in place: a full or read-only disk while training
        if exc.errno not in WRITE_ERRNOS:
            raise
        raise output_error(exc, setup.run_dir / "logs", "--run-dir") from None
    except KeyboardInterrupt:  # Ctrl+C: keep the model as it is (saved and exported after), skip the final eval
        for cb in callbacks:
            if getattr(cb, "bar", None) is not None:
                cb.bar.close()
        log.warning("interrupted during the %s at %d timesteps: saving the model and exporting the agent as they "
                    "are", interrupted, model.num_timesteps)
    return time.perf_counter() - t0, interrupted


def _save_and_export(setup: _RunSetup, model: Any, venv: Any, vecnorm: Any, interrupted: str) -> Path:
    """Export phase: ``config.json`` completed, SB3's files saved and signed, the weights-only agent written.
    Returns the agent's JSON path."""
    import io
    import pickle

    from vtrack_gym.agents.export import export
    from vtrack_gym.agents.run_signature import TRUST_MARKER, sign_bytes

    run_dir = setup.run_dir
    vecnorm.training = False
    setup.config.update(timesteps_done=int(model.num_timesteps), interrupted=bool(interrupted))
    if interrupted:
        setup.config["interrupted_during"] = interrupted
    buffer = io.BytesIO()
    model.save(buffer)
    files = {"config.json": (json.dumps(setup.config, indent=2, sort_keys=True) + "\n").encode(),
             "model.zip": buffer.getvalue(), "vecnormalize.pkl": pickle.dumps(vecnorm)}  # VecNormalize.save's bytes
    # signed before any file is written: the signature covers the bytes serialised here, never a file on disk
    # that someone could swap between saving and signing (lets `vtrack export --run-dir` load them without --trust)
    files[TRUST_MARKER] = sign_bytes(run_dir, files).encode()
    for name, data in files.items():
        write_atomic(run_dir / name, data, "--run-dir")
    agent_json, _ = export(model, vecnorm, run_dir / "agent", env_id=setup.env_id, command=setup.command,
                           seed=setup.seed, warm_start=_warm_start_text(setup), env=venv.venv)
    return agent_json


def train(algo: str, env_id: str | None = None, timesteps: int | None = None, seed: int = 0,
          run_dir: str | Path = "vtrack_runs/run", *, num_envs: int | None = None,
          overrides: Mapping[str, Any] | None = None, eval_freq: int = 100_000, case1_max_steps: int | None = 3000,
          case1_full_every: int = 5, final_eval: bool = True, progress_bar: bool = True, verbose: int = 0,
          torch_threads: int | None = 1, command: str | None = None, bc: Any = None,
          overwrite: bool = False, control: str | None = None) -> dict[str, Any]:
    """Train ``algo`` on ``env_id`` and write ``run_dir`` (see the module docstring). Returns a summary dict.

    ``control``: the control mode of the training env and the periodic evaluation (``envs.control``; recorded in
    the hyperparameters' ``env_kwargs``; default: the hyperparameter file's, else ``steer``). The longitudinal modes
    train a two-output actor (steering or its rate, and the demand); there the warm start clones the expert paired
    with the PD-FLC (``baselines.decoupled``), both outputs.

    ``timesteps`` None: the entry's ``n_timesteps``. ``overrides`` replace YAML entries (e.g. ``{"n_steps": 64}``;
    a value of ``None`` drops the entry); ``num_envs`` overrides ``n_envs``. ``env_id`` ``None``:
    ``DEFAULT_ENV_ID`` from scratch, ``IMITATION_ENV_ID`` with ``bc``.
    ``eval_freq <= 0`` disables periodic evaluation. ``bc`` (a ``vtrack_gym.agents.imitation.BCConfig``, PPO or
    SAC) starts from a behaviour-cloned actor: the entry's ``bc_finetune`` values are applied on top, the
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
    import torch

    if torch_threads:
        torch.set_num_threads(torch_threads)
    setup = _configure(algo, env_id, timesteps, seed, run_dir, num_envs, overrides, bc, command,
                       {"freq": eval_freq, "case1_max_steps": case1_max_steps, "case1_full_every": case1_full_every},
                       control)
    venv, vecnorm = _build_envs(setup)
    try:  # every setting is checked before anything of the run folder is written or replaced
        model = _build_model(setup, venv, vecnorm, verbose)
        _open_run_dir(setup, model, overwrite)
    except ValueError:
        venv.close()
        raise
    callbacks = _make_callbacks(setup.run_dir, vecnorm, setup.timesteps, eval_freq, case1_max_steps,
                                case1_full_every, progress_bar, setup.env_id, setup.command, seed,
                                _warm_start_text(setup), venv.venv)
    train_s, interrupted = _learn(setup, model, venv, vecnorm, callbacks, eval_freq)
    agent_json = _save_and_export(setup, model, venv, vecnorm, interrupted)
    final = None
    if final_eval and not interrupted:
        callbacks[0].run(final=True)
        lines = (setup.run_dir / "evaluations.jsonl").read_text(encoding="utf-8").strip().splitlines()
        final = json.loads(lines[-1])["results"]
    venv.close()
    return {"run_dir": str(setup.run_dir), "timesteps": int(model.num_timesteps), "train_s": round(train_s, 1),
            "agent": str(agent_json), "final_eval": final, "interrupted": bool(interrupted),
            "model": model, "vecnormalize": vecnorm}



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


def _behaviour_clone(model: Any, venv: Any, vecnorm: Any, setup: _RunSetup) -> None:
    """Warm start (``vtrack_gym.agents.imitation``): expert data, fit, SAC replay buffer; writes ``bc.json`` and
    the cloned actor, before any RL update, as ``bc_agent.json/.npz`` (``timesteps`` 0, the warm start recorded)."""
    from vtrack_gym.agents import imitation
    from vtrack_gym.agents.export import export

    bc, seed, run_dir = setup.bc, setup.seed, setup.run_dir

    t0 = time.perf_counter()
    log.info("warm start: %s drives %d x %d steps of expert data, %d DAgger rounds, then the actor is fitted",
             bc.expert, bc.steps, venv.num_envs, bc.dagger_rounds)
    rounds, fit = imitation.warm_start(model, venv, vecnorm, bc, seed=seed)
    export(model, vecnorm, run_dir / "bc_agent", env_id=setup.env_id, command=setup.command, seed=seed,
           warm_start=_warm_start_text(setup), env=venv.venv)
    prefilled = 0
    if hasattr(model, "replay_buffer"):
        prefilled = imitation.prefill_replay_buffer(model, rounds)
        fit["critic_loss"] = imitation.pretrain_critic(model, bc.critic_steps, int(model.batch_size))
    if hasattr(model, "set_demonstrations"):  # RegularisedSAC: the expert's labels on every round's states
        model.set_demonstrations(*imitation.labelled_states(rounds))
    record = {"config": bc.as_dict(), "transitions": sum(d.transitions for d in rounds), "fit": fit,
              "replay_buffer_prefilled": prefilled, "wall_s": round(time.perf_counter() - t0, 1)}
    write_atomic(run_dir / "bc.json", json.dumps(record, indent=2, sort_keys=True) + "\n")
