"""One GA generation = one batched rollout: car i of a ``TrackingVectorEnv`` runs individual i.

* ``PopulationSMC``: the SMC law (``vtrack_gym.baselines.smc``) with per-row p, eta, Delta arrays (the
  coefficients (25), (29), (39) are computed vectorised over the rows; the ``limit_layer_rate`` rule is applied
  per row, silently).
* ``PopulationMPC``: the MPC (``vtrack_gym.baselines.mpc``) with one gain table per row. The prediction
  matrices F, Phi, tau do not depend on the weights, so they are built once per speed and cached; per
  individual only the (N_c x N_c) Hessian solve and the folded preview row are computed, for all rows at once
  (``population_gain_tables``). The full 60-speed grid is kept (no coarser tuning grid is needed).
* ``PopulationEvaluator``: rolls out a population on Case 1 (``LateralTracking-v0``) and returns the fitness.
  PD-FLC gains per car via ``BatchSim.set_speed_controller``. The default (compiled) path runs every car's
  whole episode in one numba call (``vtrack_gym.tuning._kernels``: the controller law, the env's own per-car
  step and the ITAE / max|a_y| (physics substeps) / min F_z accumulators, cars spread over the threads in
  contiguous blocks); a car that terminates stops costing time. ``compiled=False`` runs the numpy
  ``PopulationSMC``/``PopulationMPC`` ``_act_batch`` through ``BatchSim.step`` one control period at a time:
  the reference the tests compare against (SMC bit-identical; MPC to rounding, numpy sums in another order).
* ``also_complete``: optional extra scenarios (e.g. ``DLC120-v0``) rolled out the same way; an individual that
  does not complete one gets the incomplete-run penalty, and one whose max|e_y| there exceeds
  ``FitnessConfig.also_max_e_y_m`` (0.25 m: the paper's Case-2 bound, inside the 0.31 m each side that the
  DLC's offset lane leaves a 1.8 m wide car) a penalty per metre above it (not part of the paper's fitness; off
  by default). Completing alone is not enough: the DLC's road is wider than its gates.

Fitness (``FitnessConfig``, paper-math 8): ``J = ITAE + a_y_penalty * max(0, max|a_y| - 8.83)
+ wheel_lift_penalty [min F_z <= 0] + (incomplete_penalty + incomplete_penalty_per_m * remaining distance)
[not completed] + comfort_weight * a_v`` (ISO 2631-1 comfort a_v, off by default). ITAE = int t |e_y| dt by
the trapezoid rule over the env's steps, identical to ``vtrack_gym.evaluation.metrics.itae`` on a trace.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym.baselines.base import Policy
from vtrack_gym.baselines.linear_models import curvature_preview_operator
from vtrack_gym.baselines.mpc import MPC, OUTPUTS, RELATIVE, MPCConfig, mpc_model
from vtrack_gym.baselines.smc import SMC, SMCConfig, _coefficients, _design_constants, _law, singular_speed
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.evaluation.metrics import A_Y_LIMIT_MPS2
from vtrack_gym.tuning.spaces import SearchSpace
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import DesignModel

T_COMPLETED = 1


# ---------------------------------------------------------------------------------------------- controllers
class PopulationSMC(SMC):
    """SMC with per-row p [rad/s], eta [rad/s^2], Delta [rad/s] (arrays of shape (P,)); batch path only."""

    def __init__(self, design: DesignModel, config: SMCConfig, pole: np.ndarray, eta: np.ndarray,
                 delta: np.ndarray, layout: ObservationLayout = OBS, control_period_s: float = 0.01) -> None:
        Policy.__init__(self, design, config, layout, control_period_s)
        self._k = _design_constants(design)
        self.v_star = singular_speed(design)
        pole, eta, delta = (np.asarray(a, dtype=np.float64).reshape(-1) for a in (pole, eta, delta))
        if not (pole.shape == eta.shape == delta.shape) or np.any(pole <= 0) or np.any(eta <= 0) \
                or np.any(delta <= 0):
            raise ValueError("PopulationSMC: pole, eta, delta must be positive arrays of one shape")
        self.rows = pole.size
        self._pole = pole
        layer = np.maximum(delta, eta * self.control_period_s) if config.limit_layer_rate else delta
        self.boundary_layer = layer
        self._eta_k = eta * self._k[7]
        self._inv_layer = 1.0 / layer
        self._idx = tuple(layout.index(n) for n in ("v_x", "e_y", "e_phi", "e_y_dot", "e_phi_dot", "v_y",
                                                    "yaw_rate", "yaw_rate_ref", "yaw_acc_ref"))

    def _evaluate(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        iv, iey, iep, ieyd, iepd, ivy, ir, irr, iar = self._idx
        cfg: SMCConfig = self.config
        v = np.maximum(obs[:, iv], cfg.min_speed_mps)
        if not math.isnan(self.v_star) and cfg.guard_band_mps > 0.0:
            near = np.abs(v - self.v_star) < cfg.guard_band_mps
            if near.any():
                side = np.where(v < self.v_star, -cfg.guard_band_mps, cfg.guard_band_mps)
                v = np.where(near, self.v_star + side, v)
        cf = _coefficients(self._k, v, self._pole)
        return _law(self._k, cf, v, cfg.sideslip_shift, obs[:, iey], obs[:, iep], obs[:, ieyd], obs[:, iepd],
                    obs[:, ivy], obs[:, ir], obs[:, irr], obs[:, iar])

    def _act_single(self, row: list[float], state: Any) -> tuple[float, None]:
        raise ValueError("PopulationSMC evaluates a whole population: pass (P, obs_dim) observations")


class RowSchedule:
    """Per-row speed schedules: ``tables`` (P, S, width) on one speed grid; ``dot_batch`` uses row n's table."""

    def __init__(self, speeds: np.ndarray, tables: np.ndarray) -> None:
        self.speeds = np.asarray(speeds, dtype=np.float64)
        self.tables = np.ascontiguousarray(tables, dtype=np.float64)
        self.slopes = np.ascontiguousarray(np.diff(self.tables, axis=1))
        self.v_min, self.v_max = float(self.speeds[0]), float(self.speeds[-1])
        self._last = self.speeds.size - 2
        self._rows = np.arange(self.tables.shape[0])

    @property
    def width(self) -> int:
        return self.tables.shape[2]

    def dot_batch(self, v: np.ndarray, z: np.ndarray) -> np.ndarray:
        vc = np.clip(v, self.v_min, self.v_max)
        i = np.clip(np.searchsorted(self.speeds, vc, side="right") - 1, 0, self._last)
        t = (vc - self.speeds[i]) / (self.speeds[i + 1] - self.speeds[i])
        rows = self.tables[self._rows, i] + t[:, None] * self.slopes[self._rows, i]
        return np.einsum("ij,ij->i", rows, z)


@functools.lru_cache(maxsize=4)
def _weight_free_models(design: DesignModel, config: MPCConfig, layout: ObservationLayout) -> tuple:
    """Prediction matrices stacked over the speed grid, independent of the weights: (speeds (S,), phi
    (S, R, N_c), f (S, R, n_x), tau (S, R, n_d), preview slope difference (S, N_p - 1, n_preview + 2) or None)."""
    speeds = np.geomspace(config.min_speed_mps, config.max_speed_mps, config.n_speeds)
    npred, ts = config.prediction_horizon, config.sample_time_s
    phis, fs, taus, slopes = [], [], [], []
    for v in speeds:
        mdl = mpc_model(design, float(v), config)
        phis.append(mdl.phi)
        fs.append(mdl.f)
        taus.append(mdl.tau)
        if config.use_preview and npred > 1:
            kap, _ = curvature_preview_operator(layout, float(v), v * ts * np.arange(npred + 1))
            slope = (v / ts) * np.diff(kap, axis=0)
            slopes.append(slope[1:] - slope[0])
    slope_diff = np.stack(slopes) if slopes else None
    return speeds, np.stack(phis), np.stack(fs), np.stack(taus), slope_diff


def population_gain_tables(design: DesignModel, config: MPCConfig, weights: np.ndarray,
                           layout: ObservationLayout = OBS) -> tuple[np.ndarray, np.ndarray]:
    """(speeds (S,), run-time gain rows (P, S, width)) for weight vectors ``weights`` (P, 12).

    Row p equals ``gain_table(design, replace(config, weights=weights[p]), layout).runtime`` (to rounding). All
    speeds and individuals are computed at once; only the first row of the receding-horizon gain
    K = (Phi' W Phi + r I)^-1 Phi' W is needed, and as the Hessian H is symmetric that row is
    (H^-1 e_1)' Phi' W: one small solve per speed and individual instead of one with R right-hand sides.
    """
    w = np.atleast_2d(np.asarray(weights, dtype=np.float64))
    if w.shape[1] != 12 or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError("weights must be finite, >= 0, of shape (P, 12)")
    speeds, phi, f, tau, slope_diff = _weight_free_models(design, dataclasses.replace(config, weights=(0.0,) * 12),
                                                          layout)
    npred, nc = config.prediction_horizon, config.control_horizon
    w1 = np.tile(w, (1, npred)) if config.interpretation == "augmented_outputs" else w     # (P, R)
    outputs = OUTPUTS[config.interpretation]
    measured = [8 + j for j, xi in enumerate(outputs) if xi not in RELATIVE]
    # H = Phi' diag(w) Phi + r I for every speed and individual: one product with the weight-free Phi_c Phi_d.
    outer = (phi[..., :, None] * phi[..., None, :]).reshape(phi.shape[0], phi.shape[1], nc * nc)  # (S, R, N_c^2)
    # einsum, not BLAS matmul: BLAS rounding depends on how many rows (individuals) it gets, and a row's gains
    # must not depend on the batch it is evaluated in (local and Ray backends give the same bits).
    hess = np.einsum("pr,srk->spk", w1, outer).reshape(phi.shape[0], w.shape[0], nc, nc) \
        + config.input_weight * np.eye(nc)
    e1 = np.zeros((*hess.shape[:-1], 1))
    e1[..., 0, 0] = 1.0
    first = np.linalg.solve(hess, e1)[..., 0]                                             # (S, P, N_c)
    k_mpc = np.einsum("spc,src->spr", first, phi) * w1                                    # (S, P, R)
    kx = np.einsum("spr,srx->spx", k_mpc, f)                                              # (S, P, n_x)
    kd = np.einsum("spr,srd->spd", k_mpc, tau)                                            # (S, P, n_d)
    if slope_diff is not None:
        kd_next = np.concatenate((kd[..., 1:], np.zeros((*kd.shape[:-1], 1))), axis=-1)
        preview = np.einsum("spj,sjq->spq", (kd - kd_next)[..., 1:], slope_diff)          # (S, P, n_preview + 2)
    else:
        preview = np.zeros((*kd.shape[:-1], layout.n_preview + 2))
    table = np.concatenate((kx[..., :8], kx[..., measured], kd[..., :1], preview), axis=-1)  # (S, P, width)
    return speeds, np.ascontiguousarray(table.transpose(1, 0, 2))


class PopulationMPC(MPC):
    """MPC with one weight vector (and gain table) per row; batch path only."""

    def __init__(self, design: DesignModel, config: MPCConfig, weights: np.ndarray, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        speeds, tables = population_gain_tables(design, config, weights, layout)
        self.rows = tables.shape[0]
        self.schedule = RowSchedule(speeds, tables)

    def _act_single(self, row: list[float], state: Any) -> tuple[float, Any]:
        raise ValueError("PopulationMPC evaluates a whole population: pass (P, obs_dim) observations")


# ---------------------------------------------------------------------------------------------- fitness
@dataclass(frozen=True)
class FitnessConfig:
    """Penalty weights of the GA fitness (see the module docstring); units: the ITAE's m s^2."""

    a_y_limit_mps2: float = A_Y_LIMIT_MPS2
    a_y_penalty_per_mps2: float = 1e4
    wheel_lift_penalty: float = 1e5
    incomplete_penalty: float = 1e5
    incomplete_penalty_per_m: float = 1e3
    comfort_weight: float = 0.0
    also_max_e_y_m: float = 0.25              # allowed max|e_y| [m] on the also_complete scenarios
    also_e_y_penalty_per_m: float = 1e4       # per m of max|e_y| above it

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value < 0:
                raise ValueError(f"FitnessConfig.{f.name} must be a finite number >= 0 (got {value!r})")


@dataclass
class PopulationResult:
    """Per-individual results of one batched rollout (arrays of shape (P,))."""

    fitness: np.ndarray
    itae: np.ndarray
    completed: np.ndarray
    termination: np.ndarray       # kernel termination code (0: truncated at the time limit)
    remaining_m: np.ndarray
    max_abs_a_y_mps2: np.ndarray
    min_fz_n: np.ndarray
    duration_s: np.ndarray
    comfort_a_v_mps2: np.ndarray
    max_abs_e_y_m: np.ndarray
    steps: int                    # batch steps (= longest episode)
    wall_s: float
    also_completed: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)  # per constraint scenario
    also_max_abs_e_y_m: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)  # per constraint scenario

    def row(self, i: int) -> dict[str, float]:
        """Metrics of individual ``i`` (NaN entries, e.g. an unused comfort term, left out)."""
        out = {"fitness": float(self.fitness[i]), "itae": float(self.itae[i]),
                "completed": float(self.completed[i]), "remaining_m": float(self.remaining_m[i]),
                "max_abs_a_y_mps2": float(self.max_abs_a_y_mps2[i]), "min_fz_n": float(self.min_fz_n[i]),
                "duration_s": float(self.duration_s[i]), "comfort_a_v_mps2": float(self.comfort_a_v_mps2[i]),
                "max_abs_e_y_m": float(self.max_abs_e_y_m[i])}
        for scenario, done in self.also_completed.items():
            out[f"completed_{scenario}"] = float(done[i])
            out[f"max_abs_e_y_m_{scenario}"] = float(self.also_max_abs_e_y_m[scenario][i])
        return {k: v for k, v in out.items() if math.isfinite(v)}


def configs_from_vector(space: SearchSpace, x: np.ndarray, base_config: Any, base_speed: Any) -> tuple[Any, Any]:
    """(controller config, PDFLCConfig) of one GA vector ``x`` (fields not in the space from the bases)."""
    ctrl: dict[str, Any] = {}
    speed: dict[str, float] = {}
    weights = list(getattr(base_config, "weights", ()))
    for p, value in zip(space.params, np.asarray(x, dtype=np.float64).tolist(), strict=True):
        if p.target == "speed":
            speed[p.field] = value
        elif p.index is not None:
            weights[p.index] = value
        else:
            ctrl[p.field] = value
    if any(p.index is not None for p in space.params):
        ctrl["weights"] = tuple(weights)
    return dataclasses.replace(base_config, **ctrl), dataclasses.replace(base_speed, **speed)


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
        self.compiled = compiled  # False: the numpy PopulationSMC/PopulationMPC path (reference, ~20x slower)
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
            res.fitness = res.fitness + np.where(
                extra.completed, 0.0, fc.incomplete_penalty + fc.incomplete_penalty_per_m * extra.remaining_m) \
                + fc.also_e_y_penalty_per_m * np.maximum(extra.max_abs_e_y_m - fc.also_max_e_y_m, 0.0)
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
            if sim.any_noise or sim.any_delay:
                raise ValueError("the compiled population rollout runs nominal scenarios only (no noise or delay)")
            self._run_compiled(sim, policy, max_steps, dt, acc_buf, out)
            code, done_dist = sim.term.copy(), _distance_done(sim)
        else:
            code, done_dist = self._run_stepwise(sim, policy, max_steps, dt, acc_buf, out)
        itae, max_ay, min_fz, steps = out[:, 0].copy(), out[:, 2].copy(), out[:, 3].copy(), out[:, 4].astype(int)
        completed = code == T_COMPLETED
        remaining = np.where(completed, 0.0, np.maximum(sim.tmeta[sim.veh_track, 3] - done_dist, 0.0))
        duration = steps * dt
        a_v = np.full(n, np.nan)
        if record_acc:
            from vtrack_gym.evaluation import iso2631

            fs = 1.0 / env.config.physics_dt_s
            for i in range(n):
                a = acc_buf[i, : steps[i] * sim.n_sub]
                if a.shape[0] >= int(fs):
                    a_v[i] = iso2631.vibration_total(a[:, 0], a[:, 1], a[:, 2], fs)
        fitness = (itae + fc.a_y_penalty_per_mps2 * np.maximum(max_ay - fc.a_y_limit_mps2, 0.0)
                   + fc.wheel_lift_penalty * (min_fz <= 0.0)
                   + np.where(completed, 0.0, fc.incomplete_penalty + fc.incomplete_penalty_per_m * remaining))
        if record_acc:
            fitness = fitness + fc.comfort_weight * np.nan_to_num(a_v, nan=0.0)
        fitness = np.where(np.isfinite(fitness), fitness, 1e12)
        batch_steps = int(steps.max()) if n else 0
        self.episodes += n
        self.car_steps += int(steps.sum())
        return PopulationResult(fitness, itae, completed, code, remaining, max_ay, min_fz, duration, a_v,
                                out[:, 5].copy(), batch_steps, time.perf_counter() - start)

    @staticmethod
    def _run_compiled(sim: Any, policy: Policy, max_steps: int, dt: float, acc_buf: np.ndarray,
                      out: np.ndarray) -> None:
        """Whole episodes in one compiled call (``vtrack_gym.tuning._kernels``)."""
        import numba

        from vtrack_gym.tuning import _kernels as K

        n = sim.n
        lanes = max(1, min(n, numba.get_num_threads()))
        sim_args = (sim.arrays, float(sim._max_steer))
        inv_steer = 1.0 / policy.max_steer_rad
        if isinstance(policy, PopulationSMC):
            cfg = policy.config
            K.rollout_smc(*sim_args, lanes, max_steps, dt, np.asarray(policy._idx, dtype=np.int64),
                          np.asarray(policy._k, dtype=np.float64), policy._pole, policy._eta_k, policy._inv_layer,
                          float(cfg.min_speed_mps), float(policy.v_star), float(cfg.guard_band_mps),
                          bool(cfg.sideslip_shift), inv_steer, acc_buf, out)
        elif isinstance(policy, PopulationMPC):
            sch = policy.schedule
            state = np.ascontiguousarray(policy._initial_state_batch(sim.obs.astype(np.float64)))
            K.rollout_mpc(*sim_args, lanes, max_steps, dt, np.asarray(policy._idx, dtype=np.int64), policy._pv[0],
                          policy._pv[1], float(policy._pv_vmin), float(policy._pv_dt), bool(policy._preview),
                          policy._n_out, float(policy._ts), float(policy.n_hold), float(policy._max_du),
                          float(policy.max_steer_rad), sch.speeds, sch.tables, sch.slopes, inv_steer, state,
                          np.zeros((n, sch.width)), acc_buf, out)
        else:
            raise ValueError(f"no compiled population rollout for {type(policy).__name__}")
        sim.steps[:] = out[:, 4].astype(np.int64)

    @staticmethod
    def _run_stepwise(sim: Any, policy: Policy, max_steps: int, dt: float, acc_buf: np.ndarray,
                      out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Reference path: the numpy controllers and ``BatchSim.step``, one control period at a time (~20x
        slower; the tests compare the compiled rollout against it). Returns each car's termination code and
        distance driven [m] when its episode ended (the batch keeps stepping finished cars with zero steering)."""
        n = sim.n
        code = np.zeros(n, dtype=np.int64)
        done_dist = np.zeros(n)
        inv_steer = 1.0 / policy.max_steer_rad
        obs = sim.obs.astype(np.float64)
        state = policy._initial_state_batch(obs) if policy.state_size else None
        active = np.ones(n, dtype=bool)
        n_sub = sim.n_sub
        for k in range(1, max_steps + 1):
            delta, state = policy._act_batch(obs, state)
            action = np.clip(delta * inv_steer, -1.0, 1.0)
            action[~active] = 0.0
            sim.step(action)
            te = k * dt * np.abs(sim.err[:, 1])
            a = active
            if k >= 2:
                out[a, 0] += 0.5 * dt * (out[a, 1] + te[a])
            out[a, 1] = te[a]
            out[a, 2] = np.maximum(out[a, 2], np.abs(sim.outputs[a, :, L.O_AY]).max(axis=1))
            out[a, 3] = np.minimum(out[a, 3], sim.min_fz[a])
            out[a, 4] = k
            out[a, 5] = np.maximum(out[a, 5], np.abs(sim.err[a, 1]))
            if acc_buf.shape[1]:
                acc_buf[a, (k - 1) * n_sub:k * n_sub] = sim.outputs[a, :, L.O_AX:L.O_AZ + 1]
            ended = active & ((sim.term != 0) | (k >= max_steps))
            code[ended] = sim.term[ended]
            done_dist[ended] = _distance_done(sim)[ended]
            active = active & ~ended
            if not active.any():
                break
            obs = sim.obs.astype(np.float64)
            obs[~active] = 0.0
            obs[~active, sim.layout.V_X] = 10.0  # a harmless speed for frozen rows (their output is discarded)
        return code, done_dist


def _distance_done(sim: Any) -> np.ndarray:
    """Distance each car has covered on its track [m] (lap progress on a closed track, station otherwise)."""
    closed = sim.tmeta[sim.veh_track, 4] != 0.0
    return np.where(closed, sim.progress, sim.err[:, 0])
