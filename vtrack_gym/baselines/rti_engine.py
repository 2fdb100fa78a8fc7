"""The real-time iteration engine the compiled NMPCs share: the decision's bookkeeping, one model apart.

Per decision (Diehl's real-time iteration with the initial value and the stage parameters embedded):

* **feedback** (from the observation to the command): read the measured state x0 and the stage parameters P from
  the observation, correct the prepared gradient to first order (``g = g0 + Gx (x0 - x0_pred) + Gp (P - P_pred)``),
  shift the steering actuator's rate bounds by the measured steering angle, and solve the condensed QP in the
  plan's increments (``dense_qp.solve_qp``). The first command of each input of the new plan is the action.
* **preparation** (for the next decision, before its state arrives): shift the plan by one control period, predict
  the next x0 (the model over one period with the commands just sent) and the next P (shifted), linearise and
  condense there.

The linearisation point is a pure function of the decision's record (the state row: the commands sent, a decision
flag, the plan, x0 and P), so a prepared record is only a cache: a feedback whose state row is not the one its
preparation was made from (a fresh policy object, a state passed back edited, the first decision of an episode)
prepares first, inside the feedback phase (counted in ``cold_starts`` and charged as feedback).

A model (``nmpc_rti.RealTimeIteration``: steering; ``nmpc_coupled_rti.CoupledIteration``: steering and the
longitudinal demand) names its inputs and measured state (``N_INPUTS``, ``STATE_NAMES``) and supplies the
stage parameters, the one-period prediction, the preparation record, the QP data and the plan's bounds.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym.baselines.dense_qp import QP_SOLVED, solve_qp
from vtrack_gym.baselines.rti_kernels import record_offsets, shifted

STAT_NAMES: tuple[str, ...] = ("preparation_s", "feedback_s", "qp_s", "qp_iterations", "sqp_iterations",
                               "cold_starts")
"""Per-decision solver statistics (``last_stats``): the preparation for the next decision and the feedback [s]
(wall clock), the QP solves inside the feedback [s], the active-set iterations, the Gauss-Newton steps, and the
preparations made inside the feedback (no prepared record matched)."""


@dataclass
class Prepared:
    """A preparation: the state row it was made from, its linearisation point (plan, x0, P) and its record."""

    key: np.ndarray
    point: np.ndarray
    record: np.ndarray


class RealTimeEngine:
    """The compiled RTI of one NMPC config (module docstring); one instance per policy.

    State row (``state_size`` = N_INPUTS + 1 + N_INPUTS N + n_x + 2N): the first command of each input sent, 1 once
    a decision was made (0: none yet), the plan (N commands per input, input by input), the measured x0 (n_x) and
    the stage parameters P (2N) it used. Subclasses set ``N_INPUTS`` and ``STATE_NAMES`` (the observation fields of
    x0 in the model's order) and call ``_warm_up`` once their own constants are set.
    """

    N_INPUTS: ClassVar[int] = 1
    """Inputs per stage (the plan holds N of each)."""
    STATE_NAMES: ClassVar[tuple[str, ...]] = ()
    """Observation fields of the measured state x0, in the model's order."""
    MAX_QP_ITERATIONS = 1000
    """Active-set iterations after which a QP counts as failed."""

    def __init__(self, design: Any, config: Any, layout: Any, control_period_s: float) -> None:
        from vtrack_gym.baselines.nmpc_kernels import model_constants
        from vtrack_gym.baselines.nmpc_model import TyreShape

        self.config, self.period = config, control_period_s
        n = self.n = config.horizon_steps
        self.head = self.N_INPUTS + 1
        self.n_plan = self.N_INPUTS * n
        self.n_x = len(self.STATE_NAMES)
        self.state_size = self.head + self.n_plan + self.n_x + 2 * n
        shape = TyreShape(config.front_shape_c, config.front_peak_d, config.rear_shape_c, config.rear_peak_d)
        self._mc = model_constants(design, shape, config.actuator_lag_s)
        self._max_steer = float(design.max_road_wheel_angle_rad)
        self._max_rate = float(design.max_road_wheel_rate_radps)
        self._x_idx = np.array([layout.index(k) for k in self.STATE_NAMES])
        sp = layout.speed_preview
        self._idx = np.array([layout.index("v_x"), layout.index("target_speed"), layout.index("curvature"),
                              layout.preview.start, layout.n_preview, sp.start, layout.n_speed_preview],
                             dtype=np.int64)
        self._lay = np.array([layout.preview_dt_s, layout.speed_preview_dt_s, layout.preview_min_speed_mps])
        self._stage = np.array([config.stage_time_s, config.min_speed_mps, config.speed_time_constant_s])
        self._obs_size = layout.size
        self._offsets = record_offsets(n, self.N_INPUTS, self.n_x)
        self._cache: dict[int, Prepared] = {}
        self._pending: list[tuple[int, np.ndarray]] = []
        self.solver_failures = 0
        self.last_stats: dict[str, float] = dict.fromkeys(STAT_NAMES, 0.0)

    def _warm_up(self) -> None:
        """Run every compiled function once (loaded from the kernel cache or compiled on first use): two
        decisions at rest on a straight road, then forget them (their statistics too: a new engine holds no
        wall-clock time, so two engines of one config hold the same state)."""
        obs, row = np.zeros(self._obs_size), np.zeros(self.state_size)
        row = self.decide(obs, row, -1, False)
        self.decide(obs, row.copy(), -1, False)
        self._cache.clear()
        self.solver_failures = 0
        self.last_stats = dict.fromkeys(STAT_NAMES, 0.0)

    # ------------------------------------------------------------------------------------------- the model
    def _stage_parameters(self, obs_row: np.ndarray) -> np.ndarray:
        """The stage parameters P (2N) of one observation row."""
        raise NotImplementedError

    def _advance(self, x0: np.ndarray, row: np.ndarray, params: np.ndarray) -> np.ndarray:
        """x0 one control period on, with the commands sent in ``row`` and the first stage's parameters held."""
        raise NotImplementedError

    def _condense(self, point: np.ndarray, row: np.ndarray) -> np.ndarray:
        """The preparation record at ``point`` (plan, x0, P), the move costs from the commands sent in ``row``."""
        raise NotImplementedError

    def _qp_data(self, prep: Prepared, x0: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        """Gradient, steering-rate bounds (lo, hi) [rad/s] and increment bounds (lb, ub) of the feedback QP at the
        measured (x0, P)."""
        raise NotImplementedError

    def _clip(self, plan: np.ndarray) -> np.ndarray:
        """The plan within its inputs' bounds."""
        raise NotImplementedError

    # ------------------------------------------------------------------------------------------ preparation
    def _split(self, row: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(plan, x0, P) of a state row."""
        plan_end = self.head + self.n_plan
        return row[self.head:plan_end], row[plan_end:plan_end + self.n_x], row[plan_end + self.n_x:]

    def _point(self, row: np.ndarray) -> np.ndarray:
        """The linearisation point (plan, x0, P) of the decision after the one recorded in ``row``."""
        n, cfg = self.n, self.config
        plan, x0, params = self._split(row)
        if row[self.head - 1] == 0.0:   # no decision yet: linearise where the car is (x0, P the current ones)
            return np.concatenate((plan, x0, params))
        x_next = self._advance(x0, row, params)
        blocks = [plan[i * n:(i + 1) * n] for i in range(self.N_INPUTS)] + [params[:n], params[n:]]
        moved = [shifted(np.ascontiguousarray(v), cfg.stage_time_s, self.period) for v in blocks]
        return np.concatenate((*moved[:self.N_INPUTS], x_next, *moved[self.N_INPUTS:]))

    def _prepare(self, row: np.ndarray) -> Prepared:
        """Prepare the decision that follows ``row`` (linearise and condense at its point)."""
        point = self._point(row)
        return Prepared(row.copy(), point, self._condense(point, row))

    def prepare_pending(self) -> float:
        """Prepare the next decision of every row decided by the last ``decide`` calls with ``defer=True``;
        returns the time spent [s]."""
        start = time.perf_counter()
        for i, row in self._pending:
            self._cache[i] = self._prepare(row)
        self._pending = []
        return time.perf_counter() - start

    # --------------------------------------------------------------------------------------------- feedback
    def _solve(self, prep: Prepared, x0: np.ndarray, params: np.ndarray) -> tuple[np.ndarray | None, float, int]:
        """The feedback QP of ``prep`` at the measured (x0, P): the new plan (None if the QP failed), the QP's
        time [s] and its iterations."""
        n, nv = self.n, self.n_plan
        g, lo, hi, lb, ub = self._qp_data(prep, x0, params)
        o_j, o_g, _, _, _, o_ru, o_rd, _ = self._offsets
        step = np.empty(nv)
        start = time.perf_counter()
        status, iterations, _ = solve_qp(prep.record[o_j:o_g].reshape(nv, nv), g,
                                         prep.record[o_ru:o_rd].reshape(n, nv), lo, hi, lb, ub, step,
                                         self.MAX_QP_ITERATIONS)
        qp_s = time.perf_counter() - start
        if status != QP_SOLVED or not math.isfinite(np.add.reduce(step)) and not np.isfinite(step).all():
            return None, qp_s, iterations
        return self._clip(prep.point[:nv] + step), qp_s, iterations

    def _iterate(self, row: np.ndarray, plan: np.ndarray, x0: np.ndarray, params: np.ndarray
                 ) -> tuple[np.ndarray, float, int, int]:
        """More Gauss-Newton steps at the measured point (``sqp_iterations`` > 1): plan, QP time [s], QP
        iterations and Gauss-Newton steps added."""
        qp_s, qp_iterations, steps = 0.0, 0, 0
        while steps + 1 < self.config.sqp_iterations:
            point = np.concatenate((plan, x0, params))
            new, more_s, more_iterations = self._solve(Prepared(row, point, self._condense(point, row)), x0, params)
            qp_s, qp_iterations, steps = qp_s + more_s, qp_iterations + more_iterations, steps + 1
            if new is None:
                self.solver_failures += 1
                break
            plan = new
        return plan, qp_s, qp_iterations, steps

    def decide(self, obs_row: np.ndarray, row: np.ndarray, car: int, defer: bool) -> np.ndarray:
        """The decision for one observation row and its car's state row: returns the new state row (the first
        command of each input first) and sets ``last_stats``. ``defer``: leave the preparation of the next decision
        to ``prepare_pending`` (else it runs now, after the command is known)."""
        start = time.perf_counter()
        x0 = obs_row[self._x_idx]
        params = self._stage_parameters(obs_row)
        prep = self._cache.get(car)
        cold = prep is None or not np.array_equal(prep.key, row)
        if cold:
            prep = self._prepare(row if row[self.head - 1] else
                                 np.concatenate((row[:self.head + self.n_plan], x0, params)))
        plan, qp_s, qp_iterations = self._solve(prep, x0, params)
        sqp = 1
        if plan is None:   # the QP failed: the shifted plan is applied
            self.solver_failures += 1
            plan = prep.point[:self.n_plan].copy()
        else:
            plan, more_s, more_iterations, steps = self._iterate(row, plan, x0, params)
            qp_s, qp_iterations, sqp = qp_s + more_s, qp_iterations + more_iterations, sqp + steps
        new_row = np.concatenate((plan[::self.n], (1.0,), plan, x0, params))
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
