"""The NMPC's CasADi iteration (presets ``casadi`` and ``converged``): the model's functions by CasADi, the QP by
one of its plugins (qpOASES by default), everything computed after the state arrives.

Per decision: the stage parameters and the measured state from the observation, then ``sqp_iterations``
Gauss-Newton QPs (``nmpc_model.linearise_horizon``) from the previous plan shifted by one control period. State
row (``state_size = 1 + horizon_steps``): the command applied last [rad] and the plan U [rad].
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import math
import os
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from vtrack_gym.baselines.nmpc_model import (
    HorizonWeights,
    TyreShape,
    horizon_functions,
    import_casadi,
    linearise_horizon,
)

logger = logging.getLogger(__name__)


def _flush_c_stdio() -> None:
    """Flush the C library's stdio buffers (what a C++ library printed is written out now, not at exit)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # no C runtime reachable this way (non-POSIX): nothing to flush
        pass


@contextlib.contextmanager
def silenced_stdout() -> Iterator[None]:
    """Discard what C libraries write to the process's standard output (file descriptor 1) inside the block."""
    sys.stdout.flush()
    _flush_c_stdio()
    saved = os.dup(1)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
            try:
                yield
            finally:
                _flush_c_stdio()
    finally:
        os.dup2(saved, 1)
        os.close(saved)


class CasadiIteration:
    """Gauss-Newton iterations with CasADi's model functions and QP plugin (see the module docstring)."""

    def __init__(self, design: Any, config: Any, control_period_s: float,
                 stage_parameters: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
                 measured_state: Callable[[np.ndarray], np.ndarray]) -> None:
        ca = import_casadi()
        cfg = self.config = config
        self.control_period_s = control_period_s
        self.state_size = 1 + cfg.horizon_steps
        self.stage_parameters, self.measured_state = stage_parameters, measured_state
        shape = TyreShape(cfg.front_shape_c, cfg.front_peak_d, cfg.rear_shape_c, cfg.rear_peak_d)
        self._weights = HorizonWeights(math.sqrt(cfg.weight_e_y), math.sqrt(cfg.weight_e_phi),
                                       math.sqrt(cfg.weight_yaw_rate), math.sqrt(cfg.weight_move),
                                       cfg.terminal_scale)
        self._horizon = horizon_functions(design, shape, cfg.actuator_lag_s, cfg.stage_time_s, cfg.rk4_substeps,
                                          cfg.horizon_steps, cfg.compile_model)
        self._qp = self._make_qp(ca, cfg)
        self._max_rate = float(design.max_road_wheel_rate_radps)
        self.max_steer_rad = float(design.max_road_wheel_angle_rad)
        self.solver_failures = 0
        self._qp_s, self._qp_iterations, self._sqp = 0.0, 0, 0
        self.last_stats: dict[str, float] = {}
        n = cfg.horizon_steps
        self._horizon.simulate(np.zeros(5), np.zeros((1, n)), np.full((1, n), cfg.min_speed_mps), np.zeros((1, n)))

    def _make_qp(self, ca: Any, cfg: Any) -> Any:
        """The CasADi QP solver of the Gauss-Newton step (dense H, one rate row per stage)."""
        n = cfg.horizon_steps
        structure = {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(n, n)}
        options: dict[str, Any] = {"error_on_fail": False}
        if cfg.qp_solver == "qpoases":
            options.update({"printLevel": "none", "sparse": False, "schur": False})
        elif cfg.qp_solver == "osqp":
            options.update({"osqp": {"verbose": False, "eps_abs": 1e-8, "eps_rel": 1e-8, "max_iter": 20000,
                                     "polishing": False}})
        else:
            options.update({"print_iter": False, "print_header": False, "print_info": False})
        with silenced_stdout():  # qpOASES prints its licence banner when its first solver is created
            return ca.conic("nmpc_qp", cfg.qp_solver, structure, options)

    def _shifted(self, plan: np.ndarray) -> np.ndarray:
        """The previous plan moved one control period forward in time (its last command held)."""
        t = np.arange(plan.size) * self.config.stage_time_s
        return np.interp(t + self.control_period_s, t, plan)

    def _gauss_newton_step(self, plan: np.ndarray, x0: np.ndarray, speeds: np.ndarray, kappa: np.ndarray,
                           u_prev: float) -> np.ndarray | None:
        """One Gauss-Newton QP step from ``plan`` (None when the QP fails)."""
        lin = linearise_horizon(self._horizon, self._weights, self.config.actuator_lag_s, plan, x0, speeds, kappa,
                                u_prev)
        hess = lin.jac.T @ lin.jac + self.config.regularisation * np.eye(plan.size)
        grad = lin.jac.T @ lin.res
        qp_start = time.perf_counter()
        sol = self._qp(h=hess, g=grad, a=lin.rate_jac, lba=-self._max_rate - lin.rate, uba=self._max_rate - lin.rate,
                       lbx=-self.max_steer_rad - plan, ubx=self.max_steer_rad - plan)
        self._qp_s += time.perf_counter() - qp_start
        self._qp_iterations += int(self._qp.stats().get("iter_count", 0) or 0)
        self._sqp += 1
        step = np.asarray(sol["x"]).reshape(-1)
        if not self._qp.stats().get("success", False) or not np.all(np.isfinite(step)):
            return None
        return np.clip(plan + step, -self.max_steer_rad, self.max_steer_rad)

    def plan(self, row: np.ndarray, u_prev: float, warm: np.ndarray) -> np.ndarray:
        """The command plan [rad] (N,) for one observation row from the warm start ``warm``."""
        speeds, kappa = self.stage_parameters(row)
        x0 = self.measured_state(row)
        plan = warm
        self._qp_s, self._qp_iterations, self._sqp = 0.0, 0, 0
        for _ in range(self.config.sqp_iterations):
            new = self._gauss_newton_step(plan, x0, speeds, kappa, u_prev)
            if new is None:
                self.solver_failures += 1
                logger.debug("nmpc: QP failed (%s); applying the shifted plan", self._qp.stats().get("return_status"))
                break
            plan = new
        return plan

    def decide(self, obs_row: np.ndarray, row: np.ndarray) -> np.ndarray:
        """The new state row (command, plan) for one observation row and its car's state row; sets
        ``last_stats`` (no preparation phase: everything is feedback)."""
        start = time.perf_counter()
        plan = self.plan(obs_row, float(row[0]), self._shifted(row[1:]))
        new_row = np.concatenate(((plan[0],), plan))
        self.last_stats = {"preparation_s": 0.0, "feedback_s": time.perf_counter() - start, "qp_s": self._qp_s,
                           "qp_iterations": float(self._qp_iterations), "sqp_iterations": float(self._sqp),
                           "cold_starts": 0.0}
        return new_row
