"""``Trace``: the time series of one episode, everything a metric needs (SI units; angles in rad)."""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import chain
from operator import itemgetter
from typing import Any

import numpy as np

from vtrack_gym.envs.schema import SCALAR_SIGNALS

STEP_SIGNALS: tuple[str, ...] = SCALAR_SIGNALS
"""Scalar per-step signals copied from the env's info dict (``envs.schema.SCALAR_SIGNALS``)."""


@dataclass
class Trace:
    """One episode sampled at the control rate, plus the accelerations at the physics rate.

    Attributes are arrays of shape (T,) named as in ``STEP_SIGNALS`` (``signals[name]``), ``fz_n`` (T, 4)
    wheel loads FL, FR, RL, RR [N], ``acc_physics_mps2`` (T * n_sub, 3) a_x, a_y, a_z at ``physics_rate_hz``.
    ``success``: the scenario's verdict on the episode (``info["success"]`` of its last step).
    """

    env_id: str
    policy_id: str
    seed: int | None
    signals: dict[str, np.ndarray]
    fz_n: np.ndarray
    acc_physics_mps2: np.ndarray
    physics_rate_hz: float
    control_period_s: float
    termination: str
    wall_time_per_step_s: float
    meta: dict[str, Any] = field(default_factory=dict)
    success: bool | None = None
    """The env's own success verdict (the last info's ``"success"``), None when the env gives none."""
    policy_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """Wall time of each of the policy's decisions [s] (its ``predict`` call, not the env's step; with a preparation
    deferred to ``prepare()`` under ``latency="measured"``, both calls)."""
    solver_failures: int | None = None
    """Failed solves of the policy's optimiser during the episode (0 for a closed-form law; None: not reported)."""
    reference: Any = None
    """The episode's timed reference (``reference_time.EpisodeReference``: its time law and start station), taken
    at the reset; None for an env that has none (the time lag and lap figures are then missing)."""
    solver_stats: dict[str, np.ndarray] = field(default_factory=dict)
    """Per-decision solver statistics the policy reported (``policy.last_solver_stats``, e.g. the NMPC's
    ``preparation_s``, ``feedback_s``, ``qp_s`` [s], ``qp_iterations``); empty when it reports none."""

    def __getitem__(self, name: str) -> np.ndarray:
        return self.signals[name]

    @property
    def n_steps(self) -> int:
        """Number of control steps recorded (the reset state excluded)."""
        return len(self.signals["time_s"])

    @property
    def completed(self) -> bool:
        """True when the episode ended by completing the course."""
        return self.termination == "completed"

    @classmethod
    def from_infos(cls, infos: list[dict[str, Any]], *, env_id: str, policy_id: str, seed: int | None,
                   physics_rate_hz: float, control_period_s: float, termination: str, wall_time_s: float,
                   meta: dict[str, Any] | None = None, policy_time_s: np.ndarray | None = None,
                   solver_failures: int | None = None, reference: Any = None,
                   solver_stats: dict[str, np.ndarray] | None = None) -> Trace:
        """Assemble a trace from the per-step ``info`` dicts of a single env (``policy_time_s``: the policy's
        compute per decision [s]; ``solver_failures``: its failed solves; ``reference``: the timed reference;
        ``solver_stats``: its per-decision statistics)."""
        if not infos:
            raise ValueError("a trace needs at least one step")
        row_of = itemgetter(*STEP_SIGNALS)   # one pass over the infos: a (steps, signals) table, then its columns
        width = len(STEP_SIGNALS)
        table = np.fromiter(chain.from_iterable(map(row_of, infos)), dtype=np.float64,
                            count=len(infos) * width).reshape(len(infos), width)
        signals = {name: table[:, j].copy() for j, name in enumerate(STEP_SIGNALS)}
        fz = np.array([info["fz_n"] for info in infos], dtype=np.float64)
        acc = np.concatenate([info["acc_substeps_mps2"] for info in infos], axis=0)
        verdict = infos[-1].get("success")
        return cls(env_id, policy_id, seed, signals, fz, acc, physics_rate_hz, control_period_s, termination,
                   wall_time_s / len(infos), dict(meta or {}), None if verdict is None else bool(verdict),
                   np.zeros(0) if policy_time_s is None else np.asarray(policy_time_s, dtype=np.float64),
                   solver_failures, reference, dict(solver_stats or {}))
