"""One GA generation = one batched rollout: car i of a ``TrackingVectorEnv`` runs individual i.

``PopulationEvaluator`` rolls out a population on Case 1 (``LateralTracking-v0``) and returns the fitness
(``vtrack_gym.tuning.fitness``). The controllers are the baselines' laws with one parameter row per individual
(``vtrack_gym.tuning.controllers``); PD-FLC gains per car via ``BatchSim.set_speed_controller``. The default
(compiled) path runs every car's whole episode in one numba call, ``compiled=False`` the step-by-step reference
(``vtrack_gym.tuning.rollouts``).

``also_complete``: optional extra scenarios (e.g. ``DLC120-v0``) rolled out the same way; an individual that
does not complete one gets the incomplete-run penalty, and one whose max|e_y| there exceeds
``FitnessConfig.also_max_e_y_m`` (0.25 m: the paper's Case-2 bound, inside the 0.31 m each side that the
DLC's offset lane leaves a 1.8 m wide car) a penalty per metre above it (not part of the paper's fitness; off
by default). Completing alone is not enough: the DLC's road is wider than its gates.

The names this module used to define are re-exported from their modules (``FitnessConfig``,
``PopulationResult``, ``PopulationSMC``, ``PopulationMPC``, ``population_gain_tables``, ``configs_from_vector``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from vtrack_gym.baselines.base import Policy
from vtrack_gym.envs.kernels import T_COMPLETED
from vtrack_gym.tuning.controllers import PopulationMPC, PopulationSMC
from vtrack_gym.tuning.fitness import FitnessConfig, PopulationResult, also_complete_penalty, fitness
from vtrack_gym.tuning.gains import population_gain_tables
from vtrack_gym.tuning.rollouts import distance_done, run_compiled, run_stepwise
from vtrack_gym.tuning.spaces import SearchSpace, configs_from_vector

__all__ = ["FitnessConfig", "PopulationEvaluator", "PopulationMPC", "PopulationResult", "PopulationSMC",
           "configs_from_vector", "population_gain_tables"]




class PopulationEvaluator:
    """Evaluates GA populations of ``space`` on ``scenario``; reuses one vector env per population size."""

    def __init__(self, space: SearchSpace, scenario: str = "LateralTracking-v0",
                 fitness: FitnessConfig | None = None, seed: int = 0, max_steps: int | None = None,
                 compiled: bool = True, also_complete: tuple[str, ...] = ()) -> None:
        from vtrack_gym.baselines.registry import policy_class

        self.space = space
        self.scenario = scenario
        self.fitness = fitness or FitnessConfig()
        self.seed = int(seed)
        self.max_steps = max_steps
        self.also_complete = tuple(also_complete)  # extra scenarios an individual must complete (else penalised)
        self.compiled = compiled  # False: the step-by-step reference path (tuning.rollouts.run_stepwise)
        self.policy_cls = policy_class(space.controller)
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
        design, layout, period = env.design_model, env.observation_layout, env.control_period_s
        if self.space.controller == "smc":
            pol = PopulationSMC(design, self.base_config, np.array([c.pole_radps for c, _ in cfgs]),
                                np.array([c.reaching_gain for c, _ in cfgs]),
                                np.array([c.boundary_layer for c, _ in cfgs]), layout, period)
        elif self.space.controller == "mpc":
            pol = PopulationMPC(design, self.base_config, np.array([c.weights for c, _ in cfgs]), layout, period)
        else:
            raise ValueError(f"no population controller for {self.space.controller!r}")
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
        # out columns: ITAE [m s^2], last t|e_y| [m s], max|a_y| [m/s^2], min F_z [N], steps driven, max|e_y| [m]
        out = np.zeros((n, 6))
        out[:, 3] = np.inf
        acc_buf = np.full((n, max_steps * sim.n_sub if record_acc else 0, 3), np.nan)
        if self.compiled:
            run_compiled(sim, policy, max_steps, dt, acc_buf, out)
            code, done_dist = sim.term.copy(), distance_done(sim)
        else:
            code, done_dist = run_stepwise(sim, policy, max_steps, dt, acc_buf, out)
        itae, max_ay, min_fz, steps = out[:, 0].copy(), out[:, 2].copy(), out[:, 3].copy(), out[:, 4].astype(int)
        completed = code == T_COMPLETED
        remaining = np.where(completed, 0.0, np.maximum(sim.tracks.length_m[sim.veh_track] - done_dist, 0.0))
        duration = steps * dt
        a_v = np.full(n, np.nan)
        if record_acc:
            from vtrack_gym.evaluation import iso2631

            fs = 1.0 / env.config.physics_dt_s
            for i in range(n):
                a = acc_buf[i, : steps[i] * sim.n_sub]
                if a.shape[0] >= int(fs):
                    a_v[i] = iso2631.vibration_total(a[:, 0], a[:, 1], a[:, 2], fs)
        j = fitness(fc, itae, max_ay, min_fz, completed, remaining, a_v if record_acc else None)
        batch_steps = int(steps.max()) if n else 0
        self.episodes += n
        self.car_steps += int(steps.sum())
        return PopulationResult(j, itae, completed, code, remaining, max_ay, min_fz, duration, a_v,
                                out[:, 5].copy(), batch_steps, time.perf_counter() - start)
