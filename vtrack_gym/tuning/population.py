"""One GA generation = one batched rollout: car i of a ``TrackingVectorEnv`` runs individual i.

``PopulationEvaluator`` rolls out a population on Case 1 (``LateralTracking-v0``) and returns the fitness
(``vtrack_gym.tuning.fitness``). The controller is the space's, through its tuning protocol
(``vtrack_gym.baselines.tunable``): its declared ``population`` builds the batched law, one parameter row per
individual; PD-FLC gains per car via ``BatchSim.set_speed_controller``. The default (compiled) path runs every
car's whole episode in one numba call when the law has ``compiled_rows``; ``compiled=False`` (or a law without
it) the step-by-step reference (``vtrack_gym.tuning.rollouts``).

``also_complete``: optional extra scenarios (e.g. ``DLC120-v0``) rolled out the same way; an individual that
does not complete one gets the incomplete-run penalty, and one whose max|e_y| there exceeds
``FitnessConfig.also_max_e_y_m`` (0.25 m: the paper's Case-2 bound, inside the 0.31 m each side that the
DLC's offset lane leaves a 1.8 m wide car) a penalty per metre above it (not part of the paper's fitness; off
by default). Completing alone is not enough: the DLC's road is wider than its gates.

The names this module used to define are re-exported from their modules (``FitnessConfig``,
``PopulationResult``, ``configs_from_vector``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from vtrack_gym.baselines.base import Policy
from vtrack_gym.envs.kernels import T_COMPLETED
from vtrack_gym.tuning.accumulators import (
    ACC_ITAE,
    ACC_MAX_AY,
    ACC_MAX_EY,
    ACC_MIN_FZ,
    ACC_STEPS,
    BUF_AX,
    BUF_AY,
    BUF_AZ,
    new_acceleration_buffer,
    new_accumulators,
)
from vtrack_gym.tuning.fitness import FitnessConfig, PopulationResult, also_complete_penalty, fitness
from vtrack_gym.tuning.rollouts import distance_done, run_compiled, run_stepwise
from vtrack_gym.tuning.spaces import SearchSpace, configs_from_vector, tuning_of

__all__ = ["FitnessConfig", "PopulationEvaluator", "PopulationResult", "configs_from_vector"]


class PopulationEvaluator:
    """Evaluates GA populations of ``space`` on ``scenario``; reuses one vector env per population size."""

    def __init__(self, space: SearchSpace, scenario: str = "LateralTracking-v0",
                 fitness: FitnessConfig | None = None, seed: int = 0, max_steps: int | None = None,
                 compiled: bool = True, also_complete: tuple[str, ...] = ()) -> None:
        self.space = space
        self.scenario = scenario
        self.fitness = fitness or FitnessConfig()
        self.seed = int(seed)
        self.max_steps = max_steps
        self.also_complete = tuple(also_complete)  # extra scenarios an individual must complete (else penalised)
        self.compiled = compiled  # False: the step-by-step reference path (tuning.rollouts.run_stepwise)
        self.policy_cls = space.policy_class()
        self.tuning = tuning_of(space)
        self.base_config = self.policy_cls.make_config(space.base_preset)
        self._envs: dict[tuple[str, int], Any] = {}
        self.episodes = 0
        self.car_steps = 0

    def env(self, n: int, scenario: str | None = None) -> Any:
        key = (scenario or self.scenario, n)
        if key not in self._envs:
            from vtrack_gym.envs.vector_env import TrackingVectorEnv

            self._envs[key] = TrackingVectorEnv(key[0], num_envs=n)
        return self._envs[key]

    def make_policy(self, env: Any, X: np.ndarray) -> tuple[Policy, list[Any]]:
        base_speed = env.config.speed_controller
        cfgs = [configs_from_vector(self.space, x, self.base_config, base_speed) for x in X]
        pol = self.tuning.population(env.design_model, self.base_config, [c for c, _ in cfgs],
                                     env.observation_layout, env.control_period_s)
        return pol, [s for _, s in cfgs]

    def __call__(self, X: np.ndarray) -> PopulationResult:
        """Fitness of every row of ``X`` (one batched rollout per scenario: the tuning scenario, then each
        ``also_complete`` scenario, whose non-completion adds the incomplete-run penalty and whose max|e_y| above
        ``FitnessConfig.also_max_e_y_m`` adds ``also_e_y_penalty_per_m`` per metre)."""
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
        res = self._rollout(X, self.scenario)
        fc = self.fitness
        for scenario in self.also_complete:
            extra = self._rollout(X, scenario)
            res.also_completed[scenario] = extra.completed
            res.also_max_abs_e_y_m[scenario] = extra.max_abs_e_y_m
            res.fitness = res.fitness + also_complete_penalty(fc, extra)
            res.wall_s += extra.wall_s
        return res

    def _rollout(self, X: np.ndarray, scenario: str) -> PopulationResult:
        n = X.shape[0]
        start = time.perf_counter()
        env = self.env(n, scenario)
        sim = env.sim
        policy, speed_cfgs = self.make_policy(env, X)
        for i, sc in enumerate(speed_cfgs):
            sim.set_speed_controller(i, sc)
        env.reset(seed=[self.seed] * n)
        fc = self.fitness
        dt = env.control_period_s
        max_steps = sim.max_steps if self.max_steps is None else min(self.max_steps, sim.max_steps)
        record_acc = fc.comfort_weight > 0.0
        out = new_accumulators(n)
        acc_buf = new_acceleration_buffer(n, max_steps * sim.n_sub if record_acc else 0)
        if self.compiled and callable(getattr(policy, "compiled_rows", None)):
            run_compiled(sim, policy, max_steps, dt, acc_buf, out)
            code, done_dist = sim.term.copy(), distance_done(sim)
        else:
            code, done_dist = run_stepwise(sim, policy, max_steps, dt, acc_buf, out)
        itae, max_ay, min_fz = out[:, ACC_ITAE].copy(), out[:, ACC_MAX_AY].copy(), out[:, ACC_MIN_FZ].copy()
        steps = out[:, ACC_STEPS].astype(int)
        completed = code == T_COMPLETED
        remaining = np.where(completed, 0.0, np.maximum(sim.tracks.length_m[sim.veh_track] - done_dist, 0.0))
        duration = steps * dt
        a_v = np.full(n, np.nan)
        if record_acc:
            from vtrack_gym.evaluation.scoring import iso2631

            fs = 1.0 / env.config.physics_dt_s
            for i in range(n):
                a = acc_buf[i, : steps[i] * sim.n_sub]
                if a.shape[0] >= int(fs):
                    a_v[i] = iso2631.vibration_total(a[:, BUF_AX], a[:, BUF_AY], a[:, BUF_AZ], fs)
        j = fitness(fc, itae, max_ay, min_fz, completed, remaining, a_v if record_acc else None)
        batch_steps = int(steps.max()) if n else 0
        self.episodes += n
        self.car_steps += int(steps.sum())
        return PopulationResult(j, itae, completed, code, remaining, max_ay, min_fz, duration, a_v,
                                out[:, ACC_MAX_EY].copy(), batch_steps, time.perf_counter() - start)
