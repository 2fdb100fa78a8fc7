"""The coupled NMPC's real-time iteration: the steering NMPC's engine (``nmpc_rti``) with two inputs per stage.

Per decision:

* **feedback**: read the measured state x0 = (e_y, e_phi, v_y, r, delta, v_x, time_error) and the stage
  parameters P = (curvatures, reference speeds) from the observation (``stage_parameters``), correct the prepared
  gradient to first order, ``g = g0 + Gx (x0 - x0_pred) + Gp (P - P_pred)``, shift the steering actuator's rate
  bounds by the measured steering angle, and solve the condensed QP in the 2N command increments
  (``dense_qp.solve_qp``: boxes on the steering commands and the demands, two-sided rate constraints on the
  steering). The first commands of the new plan are the action.
* **preparation**: shift the plan by one control period, predict the next x0 (the model over one period with the
  commands just sent) and the next P (shifted), linearise and condense there (``nmpc_coupled_kernels.prepare``).

As in ``nmpc_rti`` the linearisation point is a pure function of the decision's record (the state row), so a
prepared record is only a cache: a feedback whose row does not match prepares first, inside the feedback phase
(``cold_starts``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.dense_qp import QP_SOLVED, solve_qp
from vtrack_gym.baselines.nmpc_coupled_kernels import prep_offsets, prepare
from vtrack_gym.baselines.nmpc_coupled_model import N_X, advance, longitudinal_constants
from vtrack_gym.baselines.nmpc_kernels import model_constants
from vtrack_gym.baselines.nmpc_model import TyreShape
from vtrack_gym.baselines.nmpc_rti import STAT_NAMES, shifted

STATE_NAMES = ("e_y", "e_phi", "v_y", "yaw_rate", "road_wheel_angle", "v_x", "time_error")
"""Observation fields of the measured state x0, in the model's order."""
HEAD = 3
"""State-row entries before the plan: the steering command [rad] and the demand sent, the decision flag."""


@kernel
def stage_parameters(row: np.ndarray, idx: np.ndarray, lay: np.ndarray, stage: np.ndarray, out: np.ndarray) -> None:
    """Stage curvatures [1/m] and reference speeds [m/s] of one observation row into ``out`` (2N): the stations
    are those of a speed approaching the target from v_x with time constant ``stage[2]`` [s] (floored at
    ``stage[1]`` [m/s]), mid-stage; curvature and speed are the previews' linear interpolation there (held beyond
    the last sample). ``idx``: v_x, target speed, curvature, preview start and length, speed preview start and
    length; ``lay``: preview dt [s], speed preview dt [s], preview min speed [m/s]; ``stage``: stage length [s],
    speed floor [m/s], time constant [s]."""
    n = out.size // 2
    v_x, v0, t_stage = row[idx[0]], row[idx[1]], stage[0]
    v_look = max(v_x, lay[2])
    n_sp, n_p = idx[6], idx[4]
    sp_nodes, sp_values = np.empty(n_sp + 1), np.empty(n_sp + 1)
    sp_nodes[0], sp_values[0] = 0.0, v0
    for j in range(n_sp):
        sp_nodes[j + 1], sp_values[j + 1] = v_look * ((j + 1) * lay[1]), row[idx[5] + j]
    nodes, values = np.empty(n_p + 1), np.empty(n_p + 1)
    nodes[0], values[0] = 0.0, row[idx[2]]
    for j in range(n_p):
        nodes[j + 1], values[j + 1] = v_look * ((j + 1) * lay[0]), row[idx[3] + j]
    travelled = 0.0
    for k in range(n):
        v_ref = np.interp(travelled, sp_nodes, sp_values) if n_sp else v0
        v = max(v_ref + (v_x - v_ref) * math.exp(-((k + 0.5) * t_stage) / stage[2]), stage[1])
        mid = travelled + 0.5 * v * t_stage
        out[k] = np.interp(mid, nodes, values)
        out[n + k] = np.interp(mid, sp_nodes, sp_values) if n_sp else v0
        travelled += v * t_stage


@dataclass
class Prepared:
    """A preparation: the state row it was made from, its linearisation point (plan, x0, P) and its record."""

    key: np.ndarray
    point: np.ndarray
    record: np.ndarray


class CoupledIteration:
    """The compiled RTI of a ``CoupledNMPCConfig`` (module docstring); one instance per policy.

    State row (``state_size`` = 3 + 4N + 7): steering command [rad] and demand sent, 1 once a decision was made,
    the plan (N steering commands, N demands), the measured x0 (7) and the stage parameters P (2N) it used.
    """

    MAX_QP_ITERATIONS = 1000
    """Active-set iterations after which a QP counts as failed."""

    def __init__(self, design: Any, vehicle: Any, config: Any, layout: Any, control_period_s: float) -> None:
        self.config, self.period = config, control_period_s
        n = self.n = config.horizon_steps
        self.state_size = HEAD + 4 * n + N_X
        shape = TyreShape(config.front_shape_c, config.front_peak_d, config.rear_shape_c, config.rear_peak_d)
        self._mc = model_constants(design, shape, config.actuator_lag_s)
        self._lc = longitudinal_constants(vehicle, config.min_speed_mps, config.min_ref_speed_mps)
        self._weights = np.array([*(math.sqrt(w) for w in (
            config.weight_e_y, config.weight_e_phi, config.weight_yaw_rate, config.weight_speed, config.weight_time,
            config.weight_move, config.weight_demand_move, config.weight_demand)), config.terminal_scale])
        self._max_steer = float(design.max_road_wheel_angle_rad)
        self._max_rate = float(design.max_road_wheel_rate_radps)
        self._x_idx = np.array([layout.index(k) for k in STATE_NAMES])
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
        """Run every compiled function once (loaded from the kernel cache or compiled): two decisions at rest on a
        straight road, then forget them."""
        obs, row = np.zeros(self._obs_size), np.zeros(self.state_size)
        row = self.decide(obs, row, -1, False)
        self.decide(obs, row.copy(), -1, False)
        self._cache.clear()
        self.solver_failures = 0

    # ------------------------------------------------------------------------------------------ preparation
    def _split(self, row: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(plan (2N), x0 (7), P (2N)) of a state row."""
        n = self.n
        return row[HEAD:HEAD + 2 * n], row[HEAD + 2 * n:HEAD + 2 * n + N_X], row[HEAD + 2 * n + N_X:]

    def _point(self, row: np.ndarray) -> np.ndarray:
        """The linearisation point (plan, x0, P) of the decision after the one recorded in ``row``."""
        n, cfg = self.n, self.config
        plan, x0, params = self._split(row)
        if row[2] == 0.0:   # no decision yet: linearise where the car is
            return np.concatenate((plan, x0, params))
        x_next = advance(x0, row[:2].copy(), np.array([params[0], params[n]]), self._mc, self._lc, self.period,
                         cfg.rk4_substeps)
        halves = [shifted(np.ascontiguousarray(v), cfg.stage_time_s, self.period)
                  for v in (plan[:n], plan[n:], params[:n], params[n:])]
        return np.concatenate((halves[0], halves[1], x_next, halves[2], halves[3]))

    def _prepare(self, row: np.ndarray) -> Prepared:
        """Prepare the decision that follows ``row`` (linearise and condense at its point)."""
        n, cfg = self.n, self.config
        point = self._point(row)
        record = np.empty(self._offsets[-1])
        prepare(point[:2 * n], point[2 * n:2 * n + N_X], point[2 * n + N_X:], row[:2].copy(), self._weights,
                self._mc, self._lc, cfg.stage_time_s, cfg.rk4_substeps, cfg.regularisation, record)
        return Prepared(row.copy(), point, record)

    def prepare_pending(self) -> float:
        """Prepare the next decision of every row decided by the last ``decide`` with ``defer=True``; returns the
        time spent [s]."""
        start = time.perf_counter()
        for i, row in self._pending:
            self._cache[i] = self._prepare(row)
        self._pending = []
        return time.perf_counter() - start

    # --------------------------------------------------------------------------------------------- feedback
    def _qp_data(self, prep: Prepared, x0: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        """Gradient, steering-rate bounds and increment bounds of the feedback QP at the measured (x0, P)."""
        n, nv = self.n, 2 * self.n
        _, o_g, o_gx, o_gp, o_r, o_ru, o_rd, end = self._offsets
        rec, point = prep.record, prep.point
        dx, dp = x0 - point[nv:nv + N_X], params - point[nv + N_X:]
        g = rec[o_g:o_gx] + rec[o_gx:o_gp].reshape(nv, N_X) @ dx + rec[o_gp:o_r].reshape(nv, nv) @ dp
        shift = rec[o_r:o_ru] + rec[o_rd:end] * dx[4]
        limit = np.concatenate((np.full(n, self._max_steer), np.ones(n)))
        return g, -self._max_rate - shift, self._max_rate - shift, -limit - point[:nv], limit - point[:nv]

    def _solve(self, prep: Prepared, x0: np.ndarray, params: np.ndarray) -> tuple[np.ndarray | None, float, int]:
        """The feedback QP of ``prep``: the new plan (None if the QP failed), the QP's time [s], its iterations."""
        n, nv = self.n, 2 * self.n
        g, lo, hi, lb, ub = self._qp_data(prep, x0, params)
        o_j, o_g, _, _, _, o_ru, o_rd, _ = self._offsets
        step = np.empty(nv)
        start = time.perf_counter()
        status, iterations, _ = solve_qp(prep.record[o_j:o_g].reshape(nv, nv), g,
                                         prep.record[o_ru:o_rd].reshape(n, nv), lo, hi, lb, ub, step,
                                         self.MAX_QP_ITERATIONS)
        qp_s = time.perf_counter() - start
        if status != QP_SOLVED or not np.all(np.isfinite(step)):
            return None, qp_s, iterations
        plan = prep.point[:nv] + step
        plan[:n] = np.clip(plan[:n], -self._max_steer, self._max_steer)
        plan[n:] = np.clip(plan[n:], -1.0, 1.0)
        return plan, qp_s, iterations

    def _iterate(self, row: np.ndarray, plan: np.ndarray, x0: np.ndarray, params: np.ndarray
                 ) -> tuple[np.ndarray, float, int, int]:
        """More Gauss-Newton steps at the measured point (``sqp_iterations`` > 1): plan, QP time [s], QP
        iterations and Gauss-Newton steps added."""
        cfg, nv = self.config, 2 * self.n
        qp_s, qp_iterations, steps = 0.0, 0, 0
        while steps + 1 < cfg.sqp_iterations:
            exact = Prepared(row, np.concatenate((plan, x0, params)), np.empty(self._offsets[-1]))
            prepare(plan, x0, params, row[:2].copy(), self._weights, self._mc, self._lc, cfg.stage_time_s,
                    cfg.rk4_substeps, cfg.regularisation, exact.record)
            new, more_s, more_iterations = self._solve(exact, x0, params)
            qp_s, qp_iterations, steps = qp_s + more_s, qp_iterations + more_iterations, steps + 1
            if new is None:
                self.solver_failures += 1
                break
            plan = new
        assert plan.size == nv
        return plan, qp_s, qp_iterations, steps

    def decide(self, obs_row: np.ndarray, row: np.ndarray, car: int, defer: bool) -> np.ndarray:
        """The decision for one observation row and its car's state row: the new state row (steering command [rad]
        and demand first) and ``last_stats``. ``defer``: leave the next preparation to ``prepare_pending``."""
        start = time.perf_counter()
        n = self.n
        x0 = obs_row[self._x_idx]
        params = np.empty(2 * n)
        stage_parameters(obs_row, self._idx, self._lay, self._stage, params)
        prep = self._cache.get(car)
        cold = prep is None or not np.array_equal(prep.key, row)
        if cold:
            prep = self._prepare(row if row[2] else np.concatenate((row[:HEAD + 2 * n], x0, params)))
        plan, qp_s, qp_iterations = self._solve(prep, x0, params)
        sqp = 1
        if plan is None:   # the QP failed: the shifted plan is applied
            self.solver_failures += 1
            plan = prep.point[:2 * n].copy()
        else:
            plan, more_s, more_iterations, steps = self._iterate(row, plan, x0, params)
            qp_s, qp_iterations, sqp = qp_s + more_s, qp_iterations + more_iterations, sqp + steps
        new_row = np.concatenate(((plan[0], plan[n], 1.0), plan, x0, params))
        fed = time.perf_counter()
        if defer:
            self._pending.append((car, new_row))
            prepared_s = 0.0
        else:
            self._cache[car] = self._prepare(new_row)
            prepared_s = time.perf_counter() - fed
        self.last_stats = {"preparation_s": prepared_s, "feedback_s": fed - start, "qp_s": qp_s,
                           "qp_iterations": float(qp_iterations), "sqp_iterations": float(sqp),
                           "cold_starts": float(cold)}
        return new_row
