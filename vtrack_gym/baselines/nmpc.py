"""Nonlinear MPC steering baseline: real-time iterations on the Pacejka single-track model (needs CasADi).

Model: ``vtrack_gym.baselines.nmpc_model`` (Frenet single-track, Pacejka axle tyres with the env's design
parameters, first-order steering actuator). Horizon: ``horizon_steps`` stages of ``stage_time_s`` (default 40 x
0.05 s = 2 s, the curvature preview of the observation); the horizon may not outrun that preview.

Per control period (``control_period_s`` of the env, 10 ms):

1. Measured state from the observation: e_y, e_phi, v_y, yaw_rate, road_wheel_angle. Stage speeds: the speed
   the env's speed loop will hold, ``v_k = v_ref + (v_x - v_ref) exp(-t_k / speed_time_constant_s)`` with v_ref
   the observation's target speed (or its speed preview), floored at ``min_speed_mps``. Stage curvatures: the
   observation's curvature and preview, linear in distance travelled, held beyond the last sample.
2. Real-time iteration (Diehl's RTI, ``sqp_iterations = 1``): one Gauss-Newton QP in the command increments
   around the previous solution shifted by one control period (the warm start), ``min 1/2 dU'(J'J + eps I)dU +
   (J'res)'dU`` subject to ``|U + dU| <= max_road_wheel_angle_rad`` and the linearised actuator rate
   ``|(u_k - delta_k) / tau| <= max_road_wheel_rate_radps`` (the plant's own limits). qpOASES (dense, 40
   variables) solves it. More iterations per period (``sqp_iterations`` > 1, preset ``converged``) move the plan
   nearer the converged optimum (a full SQP once they converge).
3. The first command of the plan is applied; the plan is kept (policy memory) for the next period's warm start.

A QP that fails (non-finite or not solved) is counted in ``solver_failures`` and the shifted previous plan is
applied instead. Cost: ``e_y``, ``e_phi``, yaw rate against ``v kappa`` and command moves, the last stage's state
terms scaled by ``terminal_scale``.

State per row (``state_size = 1 + horizon_steps``): the command applied last [rad] and the plan U [rad].
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import math
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines.base import Policy, require_choice
from vtrack_gym.baselines.nmpc_model import (
    HorizonWeights,
    TyreShape,
    c_compiler_available,
    horizon_functions,
    import_casadi,
    linearise_horizon,
)
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

logger = logging.getLogger(__name__)

QP_SOLVERS = ("qpoases", "osqp", "qrqp")
"""CasADi QP plugins the real-time iteration may use (all ship with the casadi wheel)."""


@documented
@dataclass(frozen=True)
class NMPCConfig:
    """Nonlinear MPC parameters.

    horizon_steps: N stages. stage_time_s: stage length [s] (N x stage length may not exceed the observation's
    curvature preview). rk4_substeps: RK4 steps per stage. weight_e_y [1/m^2], weight_e_phi [1/rad^2],
    weight_yaw_rate [s^2/rad^2], weight_move [1/rad^2]: stage costs; terminal_scale: factor on the last stage's
    state weights. regularisation: eps added to the Gauss-Newton Hessian. sqp_iterations: 1 = real-time iteration.
    qp_solver: the CasADi QP plugin. compile_model: compile the model's functions to C when a C compiler is
    found (same numbers, faster). min_speed_mps: model speed floor [m/s]. speed_time_constant_s: how fast the
    predicted speed approaches the target [s]. actuator_lag_s: the steering actuator's time constant [s].
    front_shape_c, front_peak_d, rear_shape_c, rear_peak_d: the Pacejka shape (C, D) per axle.
    """

    horizon_steps: int = ranged(40, ge=5, le=100, integer=True)
    stage_time_s: float = ranged(0.05, ge=0.01, le=0.2, unit="s")
    rk4_substeps: int = ranged(2, ge=1, le=10, integer=True)
    weight_e_y: float = ranged(10.0, ge=0.0, le=1e6, unit="1/m^2")
    weight_e_phi: float = ranged(10.0, ge=0.0, le=1e6, unit="1/rad^2")
    weight_yaw_rate: float = ranged(0.1, ge=0.0, le=1e6, unit="s^2/rad^2")
    weight_move: float = ranged(200.0, ge=1e-6, le=1e8, unit="1/rad^2")
    terminal_scale: float = ranged(3.0, ge=0.0, le=100.0)
    regularisation: float = ranged(1e-6, ge=0.0, le=1e3)
    sqp_iterations: int = ranged(1, ge=1, le=20, integer=True)
    qp_solver: str = "qpoases"
    compile_model: bool = True
    min_speed_mps: float = ranged(4.0, ge=1.0, le=30.0, unit="m/s")
    speed_time_constant_s: float = ranged(2.0, gt=0.0, le=100.0, unit="s")
    actuator_lag_s: float = ranged(0.03, ge=0.005, le=1.0, unit="s")
    front_shape_c: float = ranged(1.367, ge=1.0, lt=2.0)
    front_peak_d: float = ranged(0.962, gt=0.0, le=2.0)
    rear_shape_c: float = ranged(1.365, ge=1.0, lt=2.0)
    rear_peak_d: float = ranged(0.974, gt=0.0, le=2.0)

    def __post_init__(self) -> None:
        validate(self)
        require_choice(self, "qp_solver", QP_SOLVERS)

    @property
    def horizon_s(self) -> float:
        """N x stage length [s]."""
        return self.horizon_steps * self.stage_time_s


NMPC_PRESETS: dict[str, NMPCConfig] = {"default": NMPCConfig(),
                                       "converged": NMPCConfig(sqp_iterations=5)}


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


def check_horizon(config: NMPCConfig, layout: ObservationLayout) -> None:
    """``ValueError`` unless the horizon fits in the observation's curvature preview (n_preview x preview_dt_s)."""
    preview_s = layout.n_preview * layout.preview_dt_s
    if config.horizon_s > preview_s + 1e-9:
        raise ValueError(f"NMPCConfig.horizon_steps x stage_time_s must be in (0, {preview_s:g}] s, the "
                         f"observation's curvature preview (got {config.horizon_steps} x {config.stage_time_s} = "
                         f"{config.horizon_s:g} s)")


class NMPC(Policy):
    """Nonlinear MPC by real-time iterations (see the module docstring)."""

    name: ClassVar[str] = "nmpc"
    PRESETS: ClassVar[dict[str, NMPCConfig]] = NMPC_PRESETS
    config_type: ClassVar[type] = NMPCConfig

    def __init__(self, design: DesignModel, config: NMPCConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        cfg: NMPCConfig = self.config
        check_horizon(cfg, layout)
        ca = import_casadi()
        self.state_size = 1 + cfg.horizon_steps
        shape = TyreShape(cfg.front_shape_c, cfg.front_peak_d, cfg.rear_shape_c, cfg.rear_peak_d)
        weights = HorizonWeights(math.sqrt(cfg.weight_e_y), math.sqrt(cfg.weight_e_phi),
                                 math.sqrt(cfg.weight_yaw_rate), math.sqrt(cfg.weight_move), cfg.terminal_scale)
        self._weights = weights
        self._horizon = horizon_functions(design, shape, cfg.actuator_lag_s, cfg.stage_time_s, cfg.rk4_substeps,
                                          cfg.horizon_steps, cfg.compile_model and c_compiler_available())
        self._qp = self._make_qp(ca, cfg)
        self._max_rate = float(design.max_road_wheel_rate_radps)
        self._stage_mid_s = (np.arange(cfg.horizon_steps) + 0.5) * cfg.stage_time_s
        self._idx = {name: layout.index(name) for name in (
            "e_y", "e_phi", "v_y", "yaw_rate", "road_wheel_angle", "v_x", "curvature", "target_speed")}
        self.solver_failures = 0
        """QPs that failed since the policy was built (the shifted plan was applied instead)."""
        self._warm_up()

    def _warm_up(self) -> None:
        """Evaluate the model once (CasADi compiles lazily: the first call would otherwise pay for it)."""
        n = self.config.horizon_steps
        self._horizon.simulate(np.zeros(5), np.zeros((1, n)), np.full((1, n), self.config.min_speed_mps),
                               np.zeros((1, n)))

    def _make_qp(self, ca: Any, cfg: NMPCConfig) -> Any:
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

    # ----------------------------------------------------------------------------------------- memory
    def _initial_state_batch(self, obs: np.ndarray) -> np.ndarray:
        delta = np.clip(obs[:, self._idx["road_wheel_angle"]], -self.max_steer_rad, self.max_steer_rad)
        return np.repeat(delta[:, None], self.state_size, axis=1)

    # ------------------------------------------------------------------------------------- prediction
    def stage_parameters(self, row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Stage speeds [m/s] and curvatures [1/m] over the horizon for one observation row."""
        cfg: NMPCConfig = self.config
        lay, idx = self.layout, self._idx
        v_x = float(row[idx["v_x"]])
        v_ref = np.full(cfg.horizon_steps, float(row[idx["target_speed"]]))
        travelled = np.cumsum(np.full(cfg.horizon_steps, max(v_x, cfg.min_speed_mps) * cfg.stage_time_s))
        if lay.n_speed_preview:
            nodes = np.concatenate(([0.0], lay.speed_preview_distances(v_x)))
            v_ref = np.interp(travelled, nodes, np.concatenate(([v_ref[0]], row[lay.speed_preview])))
        speeds = v_ref + (v_x - v_ref) * np.exp(-self._stage_mid_s / cfg.speed_time_constant_s)
        speeds = np.maximum(speeds, cfg.min_speed_mps)
        mid = np.cumsum(speeds * cfg.stage_time_s) - 0.5 * speeds * cfg.stage_time_s
        nodes = np.concatenate(([0.0], lay.preview_distances(v_x)))
        kappa = np.interp(mid, nodes, np.concatenate(([row[idx["curvature"]]], row[lay.preview])))
        return speeds, kappa

    def measured_state(self, row: np.ndarray) -> np.ndarray:
        """(e_y, e_phi, v_y, r, delta) of one observation row."""
        idx = self._idx
        return np.array([row[idx["e_y"]], row[idx["e_phi"]], row[idx["v_y"]], row[idx["yaw_rate"]],
                         row[idx["road_wheel_angle"]]])

    def _shifted(self, plan: np.ndarray) -> np.ndarray:
        """The previous plan moved one control period forward in time (its last command held)."""
        t = np.arange(plan.size) * self.config.stage_time_s
        return np.interp(t + self.control_period_s, t, plan)

    # ---------------------------------------------------------------------------------------- solving
    def _gauss_newton_step(self, plan: np.ndarray, x0: np.ndarray, speeds: np.ndarray, kappa: np.ndarray,
                           u_prev: float) -> np.ndarray | None:
        """One Gauss-Newton QP step from ``plan`` (None when the QP fails)."""
        lin = linearise_horizon(self._horizon, self._weights, self.config.actuator_lag_s, plan, x0, speeds, kappa,
                                u_prev)
        hess = lin.jac.T @ lin.jac + self.config.regularisation * np.eye(plan.size)
        grad = lin.jac.T @ lin.res
        sol = self._qp(h=hess, g=grad, a=lin.rate_jac, lba=-self._max_rate - lin.rate, uba=self._max_rate - lin.rate,
                       lbx=-self.max_steer_rad - plan, ubx=self.max_steer_rad - plan)
        step = np.asarray(sol["x"]).reshape(-1)
        if not self._qp.stats().get("success", False) or not np.all(np.isfinite(step)):
            return None
        return np.clip(plan + step, -self.max_steer_rad, self.max_steer_rad)

    def plan(self, row: np.ndarray, u_prev: float, warm: np.ndarray) -> np.ndarray:
        """The command plan [rad] (N,) for one observation row from the warm start ``warm``."""
        speeds, kappa = self.stage_parameters(row)
        x0 = self.measured_state(row)
        plan = warm
        for _ in range(self.config.sqp_iterations):
            new = self._gauss_newton_step(plan, x0, speeds, kappa, u_prev)
            if new is None:
                self.solver_failures += 1
                logger.debug("nmpc: QP failed (%s); applying the shifted plan", self._qp.stats().get("return_status"))
                break
            plan = new
        return plan

    def _act_batch(self, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        assert state is not None
        out = np.empty(obs.shape[0])
        for n in range(obs.shape[0]):
            plan = self.plan(obs[n], float(state[n, 0]), self._shifted(state[n, 1:]))
            state[n, 0] = out[n] = plan[0]
            state[n, 1:] = plan
        return out, state
