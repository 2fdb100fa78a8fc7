"""The real-time iteration of the NMPC, compiled: a preparation phase off the critical path, a short feedback phase.

Per decision (Diehl's real-time iteration with the initial value and the stage parameters embedded):

* **feedback** (from the observation to the command): read the measured state x0 and the stage speeds and
  curvatures p from the observation (``stage_parameters``, the same law as the CasADi NMPC), correct the prepared
  gradient to first order, ``g = g0 + Gx (x0 - x0_pred) + Gp (p - p_pred)``, shift the actuator-rate bounds by the
  measured steering angle (exactly: the actuator is linear), and solve the condensed QP (``dense_qp.solve_qp``,
  box constraints on the commands, two-sided linear rate constraints). The first command of the new plan is the
  action.
* **preparation** (for the next decision, before its state arrives): shift the plan by one control period,
  predict the next initial state (the model over one control period from x0 with the command just sent) and the
  next stage parameters (shifted), linearise and condense around them (``nmpc_kernels.prepare``) and factor the
  Hessian.

The linearisation point is a pure function of the decision's record (the policy state row: command sent, a
prepared flag, plan, x0 and p), so a prepared record is only a cache: a feedback whose state row is not the one
its preparation was made from (a fresh policy object, a state passed back edited, the first decision of an
episode) prepares first, inside the feedback phase (counted in ``cold_starts`` and charged as feedback).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.dense_qp import QP_SOLVED, solve_qp
from vtrack_gym.baselines.nmpc_kernels import N_STATES, advance, model_constants, prep_offsets, prep_size, prepare
from vtrack_gym.baselines.nmpc_model import TyreShape

STAT_NAMES: tuple[str, ...] = ("preparation_s", "feedback_s", "qp_s", "qp_iterations", "sqp_iterations",
                               "cold_starts")
"""Per-decision solver statistics (``RealTimeIteration.last_stats``): the preparation for the next decision and
the feedback [s] (wall clock), the QP solves inside the feedback [s], the active-set iterations, the Gauss-Newton
steps, and the preparations made inside the feedback (no prepared record matched)."""


@kernel
def stage_parameters(row: np.ndarray, idx: np.ndarray, lay: np.ndarray, stage: np.ndarray, speeds: np.ndarray,
                     kappa: np.ndarray) -> None:
    """Stage speeds [m/s] and curvatures [1/m] of one observation row into ``speeds``, ``kappa`` (the law of
    ``NMPC.stage_parameters``). ``idx``: v_x, target speed, curvature, preview start and length, speed preview
    start and length; ``lay``: preview dt [s], speed preview dt [s], preview min speed [m/s]; ``stage``: stage
    length [s], model speed floor [m/s], speed time constant [s]."""
    n = speeds.size
    v_x, v0, t_stage, v_min = row[idx[0]], row[idx[1]], stage[0], stage[1]
    v_look = max(v_x, lay[2])
    n_sp = idx[6]
    nodes, values = np.empty(n_sp + 1), np.empty(n_sp + 1)
    nodes[0], values[0] = 0.0, v0
    for j in range(n_sp):
        nodes[j + 1], values[j + 1] = v_look * ((j + 1) * lay[1]), row[idx[5] + j]
    step, travelled, mid = max(v_x, v_min) * t_stage, 0.0, 0.0
    for k in range(n):
        travelled += step
        v_ref = np.interp(travelled, nodes, values) if n_sp else v0
        v = v_ref + (v_x - v_ref) * math.exp(-((k + 0.5) * t_stage) / stage[2])
        speeds[k] = max(v, v_min)
    n_p = idx[4]
    nodes, values = np.empty(n_p + 1), np.empty(n_p + 1)
    nodes[0], values[0] = 0.0, row[idx[2]]
    for j in range(n_p):
        nodes[j + 1], values[j + 1] = v_look * ((j + 1) * lay[0]), row[idx[3] + j]
    for k in range(n):
        mid += speeds[k] * t_stage
        kappa[k] = np.interp(mid - 0.5 * speeds[k] * t_stage, nodes, values)


@kernel
def shifted(values: np.ndarray, stage_s: float, period_s: float) -> np.ndarray:
    """Stage values moved one control period forward in time (linear in time, the last value held)."""
    n = values.size
    t = np.arange(n) * stage_s
    return np.interp(t + period_s, t, values)


@kernel
def qp_data(prep: np.ndarray, x0: np.ndarray, p: np.ndarray, point: np.ndarray, max_steer: float,
            max_rate: float, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> None:
    """The feedback QP's data from the prepared record: gradient ``g``, rate bounds ``lo``/``hi`` [rad/s] and
    command-step bounds ``lb``/``ub`` [rad]. ``point``: the linearisation point (plan (n), x0 (5), p (2n))."""
    n = g.size
    _, o_g, o_gx, o_gp, o_r, _, o_rd, _ = prep_offsets(n)
    dx = x0 - point[n:n + N_STATES]
    dp = p - point[n + N_STATES:]
    for i in range(n):
        acc = prep[o_g + i]
        for j in range(N_STATES):
            acc += prep[o_gx + i * N_STATES + j] * dx[j]
        for j in range(2 * n):
            acc += prep[o_gp + i * 2 * n + j] * dp[j]
        g[i] = acc
        shift = prep[o_r + i] + prep[o_rd + i] * dx[4]
        lo[i], hi[i] = -max_rate - shift, max_rate - shift
        lb[i], ub[i] = -max_steer - point[i], max_steer - point[i]


@dataclass
class Prepared:
    """A preparation: the state row it was made from, its linearisation point (plan, x0, p) and its record."""

    key: np.ndarray
    point: np.ndarray
    record: np.ndarray


class RealTimeIteration:
    """The compiled RTI of an ``NMPCConfig`` (see the module docstring); one instance per policy.

    State row (``state_size`` = 2 + 3N + 5): the command sent [rad], 1 when a decision was made (0: none yet),
    the plan U (N) [rad], the measured state x0 (5) and stage speeds (N) [m/s] and curvatures (N) [1/m] it used.
    """

    def __init__(self, design: Any, config: Any, layout: Any, control_period_s: float) -> None:
        self.config, self.period = config, control_period_s
        n = self.n = config.horizon_steps
        self.state_size = 2 + 3 * n + N_STATES
        shape = TyreShape(config.front_shape_c, config.front_peak_d, config.rear_shape_c, config.rear_peak_d)
        self._mc = model_constants(design, shape, config.actuator_lag_s)
        self._weights = np.array([math.sqrt(config.weight_e_y), math.sqrt(config.weight_e_phi),
                                  math.sqrt(config.weight_yaw_rate), math.sqrt(config.weight_move),
                                  config.terminal_scale])
        self._max_steer = float(design.max_road_wheel_angle_rad)
        self._max_rate = float(design.max_road_wheel_rate_radps)
        self._x_idx = np.array([layout.index(k) for k in ("e_y", "e_phi", "v_y", "yaw_rate", "road_wheel_angle")])
        sp = layout.speed_preview
        self._idx = np.array([layout.index("v_x"), layout.index("target_speed"), layout.index("curvature"),
                              layout.preview.start, layout.n_preview, sp.start, layout.n_speed_preview],
                             dtype=np.int64)
        self._lay = np.array([layout.preview_dt_s, layout.speed_preview_dt_s, layout.preview_min_speed_mps])
        self._stage = np.array([config.stage_time_s, config.min_speed_mps, config.speed_time_constant_s])
        self._obs_size = layout.size
        self._offsets = prep_offsets(n)
        self._cache: dict[int, Prepared] = {}
        self._pending: list[tuple[int, np.ndarray]] = []
        self.solver_failures = 0
        self.last_stats: dict[str, float] = dict.fromkeys(STAT_NAMES, 0.0)
        self._warm_up()

    def _warm_up(self) -> None:
        """Run every compiled function once (they load from the kernel cache or compile on first use): two
        decisions on a straight road at rest, then forget them."""
        obs, row = np.zeros(self._obs_size), np.zeros(self.state_size)
        row = self.decide(obs, row, -1, False)
        self.decide(obs, np.concatenate((row[:1], [1.0], row[2:])), -1, False)
        self._cache.clear()
        self.solver_failures = 0

    # ------------------------------------------------------------------------------------------ preparation
    def _point(self, row: np.ndarray) -> tuple[np.ndarray, float]:
        """The linearisation point (plan, x0, p) of the decision after the one recorded in ``row``, and the
        previous command of its move cost."""
        n, cfg = self.n, self.config
        plan, x0 = row[2:2 + n], row[2 + n:2 + n + N_STATES]
        speeds, kappa = row[2 + n + N_STATES:2 + 2 * n + N_STATES], row[2 + 2 * n + N_STATES:]
        if row[1] == 0.0:   # no decision yet: linearise where the car is (x0, p are the current ones)
            return np.concatenate((plan, x0, speeds, kappa)), float(row[0])
        x_next = advance(x0, float(row[0]), float(speeds[0]), float(kappa[0]), self._mc, self.period,
                         cfg.rk4_substeps)
        point = np.concatenate((shifted(plan, cfg.stage_time_s, self.period), x_next,
                                shifted(speeds, cfg.stage_time_s, self.period),
                                shifted(kappa, cfg.stage_time_s, self.period)))
        return point, float(row[0])

    def _prepare(self, row: np.ndarray) -> Prepared:
        """Prepare the decision that follows ``row`` (linearise and condense at its point)."""
        n, cfg = self.n, self.config
        point, u_prev = self._point(row)
        record = np.empty(prep_size(n))
        prepare(point[:n], point[n:n + N_STATES], point[n + N_STATES:2 * n + N_STATES],
                point[2 * n + N_STATES:], u_prev, self._weights, self._mc, cfg.stage_time_s, cfg.rk4_substeps,
                cfg.regularisation, record)
        return Prepared(row.copy(), point, record)

    def prepare_pending(self) -> float:
        """Prepare the next decision of every row decided by the last ``decide`` call with ``defer=True``;
        returns the time spent [s]."""
        start = time.perf_counter()
        for i, row in self._pending:
            self._cache[i] = self._prepare(row)
        self._pending = []
        return time.perf_counter() - start

    # --------------------------------------------------------------------------------------------- feedback
    def _solve(self, prep: Prepared, x0: np.ndarray, p: np.ndarray) -> tuple[np.ndarray | None, float, int]:
        """The feedback QP of ``prep`` at the measured (x0, p): the new plan (None if the QP failed), the QP's
        time [s] and its iterations."""
        n = self.n
        g, lo, hi, lb, ub, step = (np.empty(n) for _ in range(6))
        qp_data(prep.record, x0, p, prep.point, self._max_steer, self._max_rate, g, lo, hi, lb, ub)
        o_j, o_g, _, _, _, o_ru, o_rd, _ = self._offsets
        start = time.perf_counter()
        status, iterations, _ = solve_qp(prep.record[o_j:o_g].reshape(n, n), g, prep.record[o_ru:o_rd].reshape(n, n),
                                         lo, hi, lb, ub, step, self.MAX_QP_ITERATIONS)
        qp_s = time.perf_counter() - start
        if status != QP_SOLVED or not np.all(np.isfinite(step)):
            return None, qp_s, iterations
        return np.clip(prep.point[:n] + step, -self._max_steer, self._max_steer), qp_s, iterations

    MAX_QP_ITERATIONS = 1000
    """Active-set iterations after which a QP counts as failed."""

    def decide(self, obs_row: np.ndarray, row: np.ndarray, car: int, defer: bool) -> np.ndarray:
        """The decision for one observation row and its car's state row: returns the new state row (its first
        entry the command [rad]) and sets ``last_stats``. ``defer``: leave the preparation of the next decision
        to ``prepare_pending`` (else it runs now, after the command is known)."""
        start = time.perf_counter()
        n, cfg = self.n, self.config
        x0 = obs_row[self._x_idx]
        speeds, kappa = np.empty(n), np.empty(n)
        stage_parameters(obs_row, self._idx, self._lay, self._stage, speeds, kappa)
        p = np.concatenate((speeds, kappa))
        prep = self._cache.get(car)
        cold = prep is None or not np.array_equal(prep.key, row)
        if cold:
            prep = self._prepare(row if row[1] else np.concatenate((row[:2 + n], x0, p)))
        u_prev = float(row[0])
        plan, qp_s, qp_iterations = self._solve(prep, x0, p)
        sqp = 1
        while plan is not None and sqp < cfg.sqp_iterations:   # more Gauss-Newton steps at the measured point
            exact = Prepared(row, np.concatenate((plan, x0, p)), np.empty(prep_size(n)))
            prepare(plan, x0, speeds, kappa, u_prev, self._weights, self._mc, cfg.stage_time_s, cfg.rk4_substeps,
                    cfg.regularisation, exact.record)
            new, more_s, more_iterations = self._solve(exact, x0, p)
            plan, qp_s, qp_iterations, sqp = (plan if new is None else new), qp_s + more_s, \
                qp_iterations + more_iterations, sqp + 1
            if new is None:
                self.solver_failures += 1
                break
        if plan is None:   # the QP failed: the shifted plan is applied
            self.solver_failures += 1
            plan = prep.point[:n]
        new_row = np.concatenate(((plan[0], 1.0), plan, x0, p))
        fed = time.perf_counter()
        if defer:   # nothing prepared here: prepare_pending measures and reports the preparation
            self._pending.append((car, new_row))
            prepared_s = 0.0
        else:
            self._cache[car] = self._prepare(new_row)
            prepared_s = time.perf_counter() - fed
        self.last_stats = {"preparation_s": prepared_s, "feedback_s": fed - start, "qp_s": qp_s,
                           "qp_iterations": float(qp_iterations), "sqp_iterations": float(sqp),
                           "cold_starts": float(cold)}
        return new_row
