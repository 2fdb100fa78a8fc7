"""Run a policy through an env and record a ``Trace`` (single env) or many traces at once (vector env)."""

from __future__ import annotations

import math
import time
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from vtrack_gym.evaluation.scoring.reference_time import episode_reference
from vtrack_gym.evaluation.scoring.trace import STEP_SIGNALS, Trace


class PolicyLike(Protocol):
    """Anything with stable-baselines3's ``predict`` signature."""

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: np.ndarray | None = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]: ...


def policy_id_of(policy: PolicyLike) -> str:
    """A readable id for provenance: ``policy.policy_id`` if present, else its class and the constructor arguments
    it holds (``policy_names.instance_label``: ``Gains(k_y=0.2)``)."""
    if hasattr(policy, "policy_id"):
        return str(policy.policy_id)
    from vtrack_gym.evaluation.identity.policy_names import instance_label

    return instance_label(policy)


def step_action(action: Any, shape: tuple[int, ...]) -> np.ndarray:
    """A policy's action as the float32 array ``env.step`` takes: finite values are clipped to the action box
    [-1, 1] before the cast (a finite 1e39 would otherwise become inf in float32 and be refused as non-finite),
    NaN and inf are passed on for the env to refuse."""
    if isinstance(action, np.ndarray) and action.size == 1 and shape == (1,):   # one car: plain floats, same cast
        value = float(action.reshape(-1)[0])
        if math.isfinite(value):
            return np.array([min(1.0, max(-1.0, value))], dtype=np.float32)
    a = np.asarray(action, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        a = np.where(np.isfinite(a), np.clip(a, -1.0, 1.0), a)
    return a.astype(np.float32).reshape(shape)


def solver_failure_count(policy: PolicyLike) -> int | None:
    """The policy's running count of failed solves (``policy.solver_failures``; 0 for the package's closed-form
    baselines and agents), None when the policy does not report one."""
    count = getattr(policy, "solver_failures", None)
    return int(count) if isinstance(count, (int, np.integer)) and not isinstance(count, bool) else None


def solver_stats_of(policy: PolicyLike) -> dict[str, float] | None:
    """The policy's statistics of its last decision (``policy.last_solver_stats``: a dict of numbers, e.g. the NMPC's
    preparation, feedback and QP times [s] and iteration counts), None when it reports none."""
    stats = getattr(policy, "last_solver_stats", None)
    return stats if isinstance(stats, dict) and stats else None


def two_phase(policy: PolicyLike) -> bool:
    """Whether the policy splits a decision into a feedback phase (``predict``) and a preparation phase for the next
    decision that it can defer to a ``prepare()`` call (``defer_preparation`` attribute, the NMPC's real-time
    iteration)."""
    return hasattr(policy, "defer_preparation") and callable(getattr(policy, "prepare", None))


class _StatsLog:
    """Per-decision solver statistics gathered into arrays (names seen on the first decision), each divided by
    ``cars`` (a batch decision's totals as the mean per car; 1: as reported)."""

    def __init__(self, cars: int = 1) -> None:
        self.values: dict[str, list[float]] = {}
        self.cars = cars

    def add(self, policy: PolicyLike) -> None:
        stats = solver_stats_of(policy)
        if stats is None:
            return
        for key, value in stats.items():
            self.values.setdefault(key, []).append(float(value) / self.cars)

    def arrays(self, steps: int | None = None) -> dict[str, np.ndarray]:
        """Each statistic over the first ``steps`` decisions (None: all)."""
        return {key: np.asarray(v[:steps]) for key, v in self.values.items()}


class Decisions:
    """The policy's side of every step, one code path for ``rollout`` and ``rollout_batch``: ``predict`` on the
    ``n`` cars' observations, timed; with ``charge`` (the single env's ``charge_compute`` under
    ``latency="measured"``) the call's time charged and a two-phase policy's preparation (``two_phase``) deferred
    until after it, so only the feedback delays the command; the decision's time per car [s] and the policy's
    solver statistics (per car) logged. Use as a context manager: ``defer_preparation`` is restored on exit."""

    def __init__(self, policy: PolicyLike, n: int, deterministic: bool = True,
                 charge: Any = None) -> None:
        self.policy = policy
        self.n = n
        self.deterministic = deterministic
        self.charge = charge
        self.split = charge is not None and two_phase(policy)
        self.state: Any = None
        self.episode_start = np.ones(n, dtype=bool)
        self._running = np.zeros(n, dtype=bool)
        self.policy_s: list[float] = []
        """Each decision's time per car [s] (with the deferred preparation)."""
        self.stats = _StatsLog(n)
        self._reports = hasattr(policy, "last_solver_stats")
        self._failures_before = solver_failure_count(policy)
        self._deferred_before = False

    def __enter__(self) -> Decisions:
        if self.split:   # only the feedback phase (predict) is charged; the preparation runs after the command
            self._deferred_before = self.policy.defer_preparation
            self.policy.defer_preparation = True
        return self

    def __exit__(self, *exc: object) -> None:
        if self.split:
            self.policy.defer_preparation = self._deferred_before

    def decide(self, obs: np.ndarray) -> tuple[Any, float]:
        """The policy's action for ``obs`` and the ``time.perf_counter`` reading at the decision's start [s]."""
        start = time.perf_counter()
        action, self.state = self.policy.predict(obs, state=self.state, episode_start=self.episode_start,
                                                 deterministic=self.deterministic)
        if self.charge is not None:   # the policy call alone is charged, not the harness around it
            self.charge(time.perf_counter() - start)
        if self.split:
            self.policy.prepare()
        self.policy_s.append((time.perf_counter() - start) / self.n)
        if self._reports:
            self.stats.add(self.policy)
        self.episode_start = self._running
        return action, start

    def failures(self) -> int | None:
        """Solves that failed since the start (None when the policy does not count them)."""
        return _failures_since(self.policy, self._failures_before)


def _failures_since(policy: PolicyLike, before: int | None) -> int | None:
    after = solver_failure_count(policy)
    return None if before is None or after is None else after - before


def _make(env_id_or_env: str | gym.Env, **make_kwargs: Any) -> tuple[gym.Env, str]:
    if isinstance(env_id_or_env, str):
        return gym.make(env_id_or_env, **make_kwargs), env_id_or_env
    spec = getattr(env_id_or_env, "spec", None)
    return env_id_or_env, spec.id if spec is not None else type(env_id_or_env.unwrapped).__name__


def rollout(policy: PolicyLike, env_id_or_env: str | gym.Env, seed: int | None = 0,
            options: dict[str, Any] | None = None, max_steps: int | None = None,
            deterministic: bool = True) -> Trace:
    """Run one episode of ``policy`` and return its trace (until termination, truncation or ``max_steps``).

    With the env's ``latency="measured"`` each decision is charged the wall time of the ``predict`` call. A policy
    with a two-phase decision (``two_phase``) runs with ``defer_preparation`` set for the episode and its
    ``prepare()`` called after each ``predict``: only the feedback is charged, the preparation is not (its time is
    in ``policy_time_s`` and the solver statistics)."""
    env, env_id = _make(env_id_or_env)
    obs, _ = env.reset(seed=seed, options=options)
    unwrapped = env.unwrapped
    reference = episode_reference(unwrapped)
    cfg = unwrapped.config
    latency = getattr(unwrapped, "latency", None)
    measured = latency is not None and latency.mode == "measured"
    infos: list[dict[str, Any]] = []
    termination = "max_steps"
    step_s: list[float] = []   # wall time of each step (policy + env) [s]
    shape = env.action_space.shape
    with Decisions(policy, 1, deterministic, unwrapped.charge_compute if measured else None) as decisions:
        while max_steps is None or len(infos) < max_steps:
            action, start = decisions.decide(obs)
            obs, _, terminated, truncated, info = env.step(step_action(action, shape))
            step_s.append(time.perf_counter() - start)
            infos.append(info)
            if terminated or truncated:
                termination = info["termination"] if terminated else "time_limit"
                break
    # the median step x steps: kernels compiled on first use (at any step) and a shared machine's hiccups stay out
    wall = float(np.median(step_s)) * len(step_s) if step_s else 0.0
    return Trace.from_infos(infos, env_id=env_id, policy_id=policy_id_of(policy), seed=seed,
                            physics_rate_hz=1.0 / cfg.physics_dt_s, control_period_s=cfg.control_period_s,
                            termination=termination, wall_time_s=wall,
                            meta={"options": dict(options or {}), "model": cfg.model},
                            policy_time_s=np.asarray(decisions.policy_s),
                            solver_failures=decisions.failures(), solver_stats=decisions.stats.arrays(),
                            reference=reference)


def rollout_batch(policy: PolicyLike, env_id: str, seeds: list[int], options: dict[str, Any] | None = None,
                  max_steps: int | None = None, deterministic: bool = True) -> list[Trace]:
    """One episode per seed, all cars stepped together on the native vector env (car i seeded ``seeds[i]``).

    Cars that finish early are frozen (their later steps are not recorded); returns traces in seed order. The
    decisions go through ``Decisions`` as in ``rollout``: each trace's ``policy_time_s`` is the batch's decision
    time divided by the number of cars and its ``solver_stats`` the batch decision's statistics divided by it too
    (the mean per car: one car gives ``rollout``'s figures); its ``solver_failures`` the batch's failed solves when
    there are none or one car (a failure cannot be attributed to a car), else None. Compute latency is not charged:
    the vector env refuses it (one decision's compute for every car at once is not defined), so a two-phase policy
    prepares within its decision, as ``rollout`` runs it without latency.
    """
    n = len(seeds)
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    obs, _ = envs.reset(seed=list(seeds), options=options)
    cfg = envs.unwrapped.config
    references = [episode_reference(envs, i) for i in range(n)]
    active = np.ones(n, dtype=bool)
    records: list[dict[str, list]] = [{k: [] for k in (*STEP_SIGNALS, "fz_n", "acc")} for _ in range(n)]
    terminations = ["max_steps"] * n
    verdicts: list[bool | None] = [None] * n
    start = time.perf_counter()
    steps = 0
    shape = envs.action_space.shape
    with Decisions(policy, n, deterministic) as decisions:
        while active.any() and (max_steps is None or steps < max_steps):
            action, _ = decisions.decide(obs)
            obs, _, terminated, truncated, info = envs.step(step_action(action, shape))
            steps += 1
            for i in np.flatnonzero(active):
                _record_car(records[i], info, i)
                if "success" in info:   # the last recorded step's verdict, as ``Trace.from_infos`` reads it
                    verdicts[i] = bool(info["success"][i])
                if terminated[i] or truncated[i]:
                    terminations[i] = str(info["termination"][i]) if terminated[i] else "time_limit"
                    active[i] = False
    wall = time.perf_counter() - start
    failures = decisions.failures()
    failures = failures if failures == 0 or n == 1 else None
    meta = {"options": dict(options or {}), "model": cfg.model}
    traces = []
    for i, seed in enumerate(seeds):
        rec = records[i]
        recorded = len(rec["time_s"])
        signals = {name: np.asarray(rec[name]) for name in STEP_SIGNALS}
        traces.append(Trace(env_id, policy_id_of(policy), seed, signals, np.asarray(rec["fz_n"]),
                            np.concatenate(rec["acc"], axis=0), 1.0 / cfg.physics_dt_s, cfg.control_period_s,
                            terminations[i], wall / max(steps, 1) / n, dict(meta), verdicts[i],
                            np.asarray(decisions.policy_s[:recorded]), failures, references[i],
                            decisions.stats.arrays(recorded)))
    return traces


def _record_car(rec: dict[str, list], info: dict[str, Any], i: int) -> None:
    """Append car ``i``'s signals of the vector env's step ``info`` to its record."""
    for name in STEP_SIGNALS:
        rec[name].append(float(info[name][i]))
    rec["fz_n"].append(info["fz_n"][i])
    rec["acc"].append(info["acc_substeps_mps2"][i])
