"""Run a policy through an env and record a ``Trace`` (single env) or many traces at once (vector env)."""

from __future__ import annotations

import math
import time
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from vtrack_gym.evaluation.reference_time import episode_reference
from vtrack_gym.evaluation.trace import STEP_SIGNALS, Trace


class PolicyLike(Protocol):
    """Anything with stable-baselines3's ``predict`` signature."""

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: np.ndarray | None = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]: ...


def policy_id_of(policy: PolicyLike) -> str:
    """A readable id for provenance: ``policy.policy_id`` if present, else its class and the constructor arguments
    it holds (``policy_names.instance_label``: ``Gains(k_y=0.2)``)."""
    if hasattr(policy, "policy_id"):
        return str(policy.policy_id)
    from vtrack_gym.evaluation.policy_names import instance_label

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
    """Per-decision solver statistics gathered into arrays (names seen on the first decision)."""

    def __init__(self) -> None:
        self.values: dict[str, list[float]] = {}

    def add(self, policy: PolicyLike) -> None:
        stats = solver_stats_of(policy)
        if stats is None:
            return
        for key, value in stats.items():
            self.values.setdefault(key, []).append(float(value))

    def arrays(self) -> dict[str, np.ndarray]:
        return {key: np.asarray(v) for key, v in self.values.items()}


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
    state = None
    episode_start = np.ones(1, dtype=bool)
    infos: list[dict[str, Any]] = []
    termination = "max_steps"
    step_s: list[float] = []   # wall time of each step (policy + env) [s]
    policy_s: list[float] = []  # wall time of each decision (the policy's predict alone) [s]
    failures_before = solver_failure_count(policy)
    split = measured and two_phase(policy)
    deferred_before = policy.defer_preparation if split else False
    stats = _StatsLog()
    steps = 0
    try:
        if split:   # only the feedback phase (predict) is charged; the preparation runs after the command is sent
            policy.defer_preparation = True
        while max_steps is None or steps < max_steps:
            start = time.perf_counter()
            action, state = policy.predict(obs, state=state, episode_start=episode_start,
                                           deterministic=deterministic)
            decided = time.perf_counter()
            if measured:   # the policy call alone is charged, not the harness around it
                unwrapped.charge_compute(decided - start)
            if split:
                policy.prepare()
            policy_s.append(time.perf_counter() - start)
            stats.add(policy)
            episode_start = np.zeros(1, dtype=bool)
            obs, _, terminated, truncated, info = env.step(step_action(action, env.action_space.shape))
            step_s.append(time.perf_counter() - start)
            infos.append(info)
            steps += 1
            if terminated or truncated:
                termination = info["termination"] if terminated else "time_limit"
                break
    finally:
        if split:
            policy.defer_preparation = deferred_before
    # the median step x steps: kernels compiled on first use (at any step) and a shared machine's hiccups stay out
    wall = float(np.median(step_s)) * len(step_s) if step_s else 0.0
    return Trace.from_infos(infos, env_id=env_id, policy_id=policy_id_of(policy), seed=seed,
                            physics_rate_hz=1.0 / cfg.physics_dt_s, control_period_s=cfg.control_period_s,
                            termination=termination, wall_time_s=wall,
                            meta={"options": dict(options or {}), "model": cfg.model},
                            policy_time_s=np.asarray(policy_s),
                            solver_failures=_failures_since(policy, failures_before), solver_stats=stats.arrays(),
                            reference=reference)


def rollout_batch(policy: PolicyLike, env_id: str, seeds: list[int], options: dict[str, Any] | None = None,
                  max_steps: int | None = None, deterministic: bool = True) -> list[Trace]:
    """One episode per seed, all cars stepped together on the native vector env (car i seeded ``seeds[i]``).

    Cars that finish early are frozen (their later steps are not recorded); returns traces in seed order. Each
    trace's ``policy_time_s`` is the batch's decision time divided by the number of cars; its ``solver_failures``
    the batch's failed solves when there are none or one car (a failure cannot be attributed to a car), else
    None.
    """
    n = len(seeds)
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    sim = envs.unwrapped.sim if hasattr(envs, "unwrapped") else envs.sim
    obs, _ = envs.reset(seed=list(seeds), options=options)
    cfg = envs.unwrapped.config
    references = [episode_reference(envs, i) for i in range(n)]
    active = np.ones(n, dtype=bool)
    records: list[dict[str, list]] = [{k: [] for k in (*STEP_SIGNALS, "fz_n", "acc")} for _ in range(n)]
    terminations = ["max_steps"] * n
    verdicts: list[bool | None] = [None] * n
    state = None
    episode_start = np.ones(n, dtype=bool)
    policy_s: list[float] = []
    failures_before = solver_failure_count(policy)
    start = time.perf_counter()
    steps = 0
    while active.any() and (max_steps is None or steps < max_steps):
        tick = time.perf_counter()
        action, state = policy.predict(obs, state=state, episode_start=episode_start, deterministic=deterministic)
        policy_s.append((time.perf_counter() - tick) / n)
        episode_start = np.zeros(n, dtype=bool)
        obs, _, terminated, truncated, info = envs.step(step_action(action, envs.action_space.shape))
        steps += 1
        sig = info
        for i in np.flatnonzero(active):
            rec = records[i]
            for name in STEP_SIGNALS:
                rec[name].append(float(sig[name][i]))
            rec["fz_n"].append(sig["fz_n"][i])
            rec["acc"].append(sig["acc_substeps_mps2"][i])
            if terminated[i] or truncated[i]:
                terminations[i] = str(sig["termination"][i]) if terminated[i] else "time_limit"
                if "success" in sig and sig["success"][i] is not None:
                    verdicts[i] = bool(sig["success"][i])
                active[i] = False
    wall = time.perf_counter() - start
    del sim
    failures = _failures_since(policy, failures_before)
    failures = failures if failures == 0 or n == 1 else None
    traces = []
    for i, seed in enumerate(seeds):
        rec = records[i]
        signals = {name: np.asarray(rec[name]) for name in STEP_SIGNALS}
        traces.append(Trace(env_id, policy_id_of(policy), seed, signals, np.asarray(rec["fz_n"]),
                            np.concatenate(rec["acc"], axis=0), 1.0 / cfg.physics_dt_s, cfg.control_period_s,
                            terminations[i], wall / max(steps, 1) / n, {"options": dict(options or {}),
                                                                         "model": cfg.model}, verdicts[i],
                            np.asarray(policy_s[:len(rec["time_s"])]), failures, references[i]))
    return traces
