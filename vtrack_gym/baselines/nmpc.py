"""Nonlinear MPC steering baseline on the Pacejka single-track model: a compiled real-time iteration (default) or
CasADi's iterations (presets ``casadi``, ``converged``; they need CasADi).

Model: ``vtrack_gym.baselines.nmpc_model`` (Frenet single-track, Pacejka axle tyres with the env's design
parameters, first-order steering actuator). Horizon: ``horizon_steps`` stages of ``stage_time_s`` (default 40 x
0.05 s = 2 s, the curvature preview of the observation); the horizon may not outrun that preview.

Per control period (``control_period_s`` of the env, 10 ms):

1. Measured state from the observation: e_y, e_phi, v_y, yaw_rate, road_wheel_angle. Stage speeds: the speed
   the env's speed loop will hold, ``v_k = v_ref + (v_x - v_ref) exp(-t_k / speed_time_constant_s)`` with v_ref
   the observation's target speed (or its speed preview), floored at ``min_speed_mps``. Stage curvatures: the
   observation's curvature and preview, linear in distance travelled, held beyond the last sample.
2. One Gauss-Newton QP in the command increments (``sqp_iterations = 1``: Diehl's real-time iteration) around the
   previous plan shifted by one control period, ``min 1/2 dU'(J'J + eps I)dU + (J'res)'dU`` subject to
   ``|U + dU| <= max_road_wheel_angle_rad`` and the actuator rate ``|(u_k - delta_k) / tau| <=
   max_road_wheel_rate_radps`` (the plant's own limits). More iterations (``sqp_iterations`` > 1, preset
   ``converged``) move the plan nearer the converged optimum.
3. The first command of the plan is applied; the plan is kept (policy memory) for the next period's warm start.

``method = "rti"`` (default, ``nmpc_rti``): compiled model Jacobians and a compiled dense active-set QP solver,
split into a *feedback* phase (observation -> command: the prepared QP corrected to first order for the measured
state and stage parameters, then solved) and a *preparation* phase (linearising and condensing around the
predicted next state, run after the command is known). ``method = "casadi"`` (``nmpc_casadi``): CasADi's model
functions (compiled to C when a compiler is found) and its QP plugin ``qp_solver``, linearised after the state
arrives (no split: everything is feedback).

Statistics of the last decision: ``last_solver_stats`` (``nmpc_rti.STAT_NAMES``: preparation and feedback time,
QP time and iterations, Gauss-Newton steps, preparations made in the feedback). The evaluation harness records
them per decision and reports them in the rows; with compute charged in the loop (``latency="measured"``) it sets
``defer_preparation`` and calls ``prepare()`` after each decision, so only the feedback phase delays the command
(the preparation must fit in the control period; its time is reported beside).

A QP that fails (non-finite or not solved) is counted in ``solver_failures`` and the shifted previous plan is
applied instead. Cost: ``e_y``, ``e_phi``, yaw rate against ``v kappa`` and command moves, the last stage's state
terms scaled by ``terminal_scale``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import documented, validate
from vtrack_gym.baselines import nmpc_params as shared
from vtrack_gym.baselines.base import Policy, require_choice
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

logger = logging.getLogger(__name__)

QP_SOLVERS = ("qpoases", "osqp", "qrqp")
"""CasADi QP plugins the ``casadi`` method may use (all ship with the casadi wheel)."""
METHODS = ("rti", "casadi")
"""``NMPCConfig.method``: the compiled real-time iteration, or CasADi's functions and QP plugin."""


@dataclass(frozen=True)
class _SolverFields:
    """The steering NMPC's own solver choices (``NMPCConfig``)."""

    method: str = "rti"
    qp_solver: str = "qpoases"
    compile_model: bool = True


# the field groups of nmpc_params (shared with the coupled NMPC's config), named last field first
@documented
@dataclass(frozen=True)
class NMPCConfig(shared.PlantModelFields, shared.SpeedFloorFields, _SolverFields, shared.IterationFields,
                 shared.MoveWeightFields, shared.LateralWeightFields, shared.HorizonFields):
    """Nonlinear MPC parameters.

    horizon_steps: N stages. stage_time_s: stage length [s] (N x stage length may not exceed the observation's
    curvature preview). rk4_substeps: RK4 steps per stage. weight_e_y [1/m^2], weight_e_phi [1/rad^2],
    weight_yaw_rate [s^2/rad^2], weight_move [1/rad^2]: stage costs; terminal_scale: factor on the last stage's
    state weights. regularisation: eps added to the Gauss-Newton Hessian. sqp_iterations: 1 = real-time iteration.
    method: ``rti`` (compiled, preparation/feedback split) or ``casadi``. qp_solver (``casadi`` only): the CasADi
    QP plugin. compile_model (``casadi`` only): compile the model's functions to C when a C compiler is found
    (same numbers, faster). min_speed_mps: model speed floor [m/s]. speed_time_constant_s: how fast the
    predicted speed approaches the target [s]. actuator_lag_s: the steering actuator's time constant [s].
    front_shape_c, front_peak_d, rear_shape_c, rear_peak_d: the Pacejka shape (C, D) per axle.
    """

    def __post_init__(self) -> None:
        validate(self)
        require_choice(self, "qp_solver", QP_SOLVERS)
        require_choice(self, "method", METHODS)


NMPC_PRESETS: dict[str, NMPCConfig] = {"default": NMPCConfig(),
                                       "casadi": NMPCConfig(method="casadi"),
                                       "converged": NMPCConfig(method="casadi", sqp_iterations=5)}
"""``default``: the compiled real-time iteration; ``casadi``: the same problem, one Gauss-Newton step by CasADi
and qpOASES after the state arrives (the default until the compiled one); ``converged``: five such steps."""


def check_horizon(config: shared.HorizonFields, layout: ObservationLayout) -> None:
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
        self._stage_mid_s = (np.arange(cfg.horizon_steps) + 0.5) * cfg.stage_time_s
        self._idx = {name: layout.index(name) for name in (
            "e_y", "e_phi", "v_y", "yaw_rate", "road_wheel_angle", "v_x", "curvature", "target_speed")}
        self.defer_preparation = False
        """True: ``predict`` stops after the feedback phase and ``prepare()`` runs the preparation (what a harness
        that charges compute in the loop sets); False: ``predict`` prepares the next decision before returning."""
        if cfg.method == "rti":
            from vtrack_gym.baselines.nmpc_rti import RealTimeIteration

            self._engine: Any = RealTimeIteration(design, cfg, layout, self.control_period_s)
        else:
            from vtrack_gym.baselines.nmpc_casadi import CasadiIteration

            self._engine = CasadiIteration(design, cfg, self.control_period_s, self.stage_parameters,
                                           self.measured_state)
        self.state_size = self._engine.state_size
        self.last_solver_stats: dict[str, float] = {}
        """The last ``predict`` call's solver statistics (``nmpc_rti.STAT_NAMES``; summed over a batch's rows)."""

    @property
    def solver_failures(self) -> int:  # type: ignore[override]
        """QPs that failed since the policy was built (the shifted plan was applied instead)."""
        return self._engine.solver_failures

    # ----------------------------------------------------------------------------------------- memory
    def _initial_state_batch(self, obs: np.ndarray) -> np.ndarray:
        delta = np.clip(obs[:, self._idx["road_wheel_angle"]], -self.max_steer_rad, self.max_steer_rad)
        state = np.repeat(delta[:, None], self.state_size, axis=1)
        if self.config.method == "rti":   # the command, no decision yet, the plan; x0 and p unused until then
            state[:, 1] = 0.0
            state[:, 2 + self.config.horizon_steps:] = 0.0
        return state

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

    # ---------------------------------------------------------------------------------------- solving
    def prepare(self) -> float:
        """Run the preparation phase the last ``predict`` left undone (``defer_preparation``); returns its time
        [s] (0 for the ``casadi`` method, which has none) and adds it to ``last_solver_stats``."""
        if self.config.method != "rti":
            return 0.0
        spent = self._engine.prepare_pending()
        if self.last_solver_stats:
            self.last_solver_stats["preparation_s"] += spent
        return spent

    def _act_batch(self, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        assert state is not None
        out = np.empty(obs.shape[0])
        rti = self.config.method == "rti"
        totals: dict[str, float] = {}
        for n in range(obs.shape[0]):
            row = (self._engine.decide(obs[n], state[n], n, self.defer_preparation) if rti
                   else self._engine.decide(obs[n], state[n]))
            state[n] = row
            out[n] = row[0]
            for key, value in self._engine.last_stats.items():
                totals[key] = totals.get(key, 0.0) + value
        self.last_solver_stats = totals
        return out, state
