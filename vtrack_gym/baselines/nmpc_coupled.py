"""Coupled nonlinear MPC: one model and one optimisation for the steering and the longitudinal demand.

Model (``nmpc_coupled_model``): the steering NMPC's lateral model (Frenet single-track, Pacejka axle tyres derated
by the friction ellipse of the longitudinal force, the steering actuator's lag) with the speed v and the time
error e_t as states; inputs the road-wheel command and the
longitudinal demand d in [-1, 1] through the env's throttle/brake map and the plant's drive-force curve, brakes,
drag and rolling resistance; stage parameters the path's curvature and the reference speed at each stage's
predicted station (the observation's previews). Cost (``nmpc_coupled_kernels``): e_y, e_phi, yaw rate against
v kappa, speed error v - v_ref, time error (small weight: the car also keeps to the reference's timing), command
moves of both inputs and optionally the demand's size; the last stage's state terms scaled by ``terminal_scale``.
Bounds: the steering command and actuator rate (the car's limits) and |d| <= 1.

Solved by the steering NMPC's real-time iteration, extended to two inputs (``nmpc_coupled_rti``): a compiled
preparation (linearising and condensing) after each command and a short feedback (one condensed QP of 2N
increments by the dense active-set solver); ``defer_preparation``, ``prepare()`` and ``last_solver_stats`` as in
``vtrack_gym.baselines.nmpc``.

Control modes: ``steer_accel`` only (the action is the steering command and the demand). It reads the
observation's ``time_error``, which only the longitudinal modes have; ``steer`` (no demand to send) and
``steer_rate_accel`` (the command would be rate limited, which the model does not include) are refused with a
``ValueError``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines import nmpc_params as shared
from vtrack_gym.baselines.base import Policy, env_contract
from vtrack_gym.baselines.nmpc import check_horizon
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

CONTROL_MODES = ("steer_accel",)
"""The control modes the coupled NMPC drives."""


@dataclass(frozen=True)
class _SpeedWeightFields:
    """Stage costs of the speed error v - v_ref [s^2/m^2] and the time error [1/s^2]."""

    weight_speed: float = ranged(1.0, ge=0.0, le=1e6, unit="s^2/m^2")
    weight_time: float = ranged(0.1, ge=0.0, le=1e6, unit="1/s^2")


@dataclass(frozen=True)
class _DemandWeightFields:
    """Costs of the demand's moves and of its size (dimensionless demand)."""

    weight_demand_move: float = ranged(1.0, ge=1e-6, le=1e8)
    weight_demand: float = ranged(0.0, ge=0.0, le=1e6)


@dataclass(frozen=True)
class _ReferenceSpeedFields:
    """Floor of the reference speed in the time error's rate [m/s]."""

    min_ref_speed_mps: float = ranged(1.0, ge=0.1, le=30.0, unit="m/s")


# the field groups of nmpc_params (shared with the steering NMPC's config) and its own, named last field first
@documented
@dataclass(frozen=True)
class CoupledNMPCConfig(shared.PlantModelFields, _ReferenceSpeedFields, shared.SpeedFloorFields,
                        shared.IterationFields, _DemandWeightFields, shared.MoveWeightFields, _SpeedWeightFields,
                        shared.LateralWeightFields, shared.HorizonFields):
    """Coupled NMPC parameters (the steering NMPC's where the names match).

    horizon_steps, stage_time_s, rk4_substeps: N stages of stage_time_s [s], RK4 steps per stage.
    weight_e_y [1/m^2], weight_e_phi [1/rad^2], weight_yaw_rate [s^2/rad^2], weight_speed [s^2/m^2],
    weight_time [1/s^2]: state costs; weight_move [1/rad^2], weight_demand_move, weight_demand: the steering
    command's and the demand's moves and the demand's size (dimensionless demand). terminal_scale: factor on the
    last stage's state weights. regularisation: eps added to the Gauss-Newton Hessian. sqp_iterations: 1 =
    real-time iteration. min_speed_mps: speed floor of the lateral model [m/s]. min_ref_speed_mps: floor of the
    reference speed in the time error's rate [m/s]. speed_time_constant_s: how fast the stations of the stage
    parameters' look-up approach the target speed [s]. actuator_lag_s: steering actuator time constant [s].
    front/rear shape and peak: the Pacejka shape (C, D) per axle.
    """

    def __post_init__(self) -> None:
        validate(self)


def check_control(control: Any, name: str) -> None:
    """``ValueError`` unless ``control`` is a mode the coupled NMPC drives (naming the modes it supports)."""
    if control not in CONTROL_MODES:
        raise ValueError(f"{name} sends the steering command and the longitudinal demand: it drives envs made with "
                         f"control in {', '.join(map(repr, CONTROL_MODES))} (got control={control!r}); in "
                         f"'steer' use the steering NMPC 'nmpc'")


class CoupledNMPC(Policy):
    """Coupled NMPC by real-time iterations (module docstring). Action: (steering command, demand) per row."""

    name: ClassVar[str] = "nmpc_coupled"
    PRESETS: ClassVar[dict[str, CoupledNMPCConfig]] = {"default": CoupledNMPCConfig()}
    config_type: ClassVar[type] = CoupledNMPCConfig
    action_dim = 2

    def __init__(self, design: DesignModel, config: CoupledNMPCConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01, vehicle: Any = None) -> None:
        from vtrack_gym.baselines.nmpc_coupled_rti import CoupledIteration
        from vtrack_gym.vehicle.params import paper_vehicle

        super().__init__(design, config, layout, control_period_s)
        if "time_error" not in layout.names:
            raise ValueError(f"{self.name} reads the observation's speed_error and time_error: the layout needs "
                             "tracking_errors=True (an env made with control='steer_accel')")
        check_horizon(self.config, layout)
        self.vehicle = vehicle if vehicle is not None else paper_vehicle()
        self.defer_preparation = False
        """True: ``predict`` stops after the feedback and ``prepare()`` runs the preparation."""
        self._engine = CoupledIteration(design, self.vehicle, self.config, layout, self.control_period_s)
        self.state_size = self._engine.state_size
        self.last_solver_stats: dict[str, float] = {}
        """The last ``predict`` call's solver statistics (``nmpc_rti.STAT_NAMES``, summed over a batch)."""
        self._demand = np.zeros(0)

    @classmethod
    def from_env(cls, env: Any, preset: str = "default", **overrides: Any) -> CoupledNMPC:
        """The policy for ``env`` (its design model, layout, period and car); ``ValueError`` for a control mode
        other than ``steer_accel``."""
        base = getattr(env, "unwrapped", env)
        check_control(getattr(base, "control", None), cls.name)
        design, layout, period = env_contract(env)
        return cls(design, cls.make_config(preset, **overrides), layout, period, vehicle=base.config.vehicle)

    @property
    def solver_failures(self) -> int:  # type: ignore[override]
        """QPs that failed since the policy was built (the shifted plan was applied instead)."""
        return self._engine.solver_failures

    def _initial_state_batch(self, obs: np.ndarray) -> np.ndarray:
        """No decision yet: the measured steering angle as every planned command, zero demands."""
        n = self.config.horizon_steps
        delta = np.clip(obs[:, self.layout.index("road_wheel_angle")], -self.max_steer_rad, self.max_steer_rad)
        state = np.zeros((obs.shape[0], self.state_size))
        state[:, 0] = delta
        state[:, 3:3 + n] = delta[:, None]
        return state

    def prepare(self) -> float:
        """Run the preparation the last ``predict`` left undone (``defer_preparation``); its time [s], also added
        to ``last_solver_stats``."""
        spent = self._engine.prepare_pending()
        if self.last_solver_stats:
            self.last_solver_stats["preparation_s"] += spent
        return spent

    def _act_batch(self, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        assert state is not None
        steer, demand = np.empty(obs.shape[0]), np.empty(obs.shape[0])
        totals: dict[str, float] = {}
        for n in range(obs.shape[0]):
            state[n] = self._engine.decide(obs[n], state[n], n, self.defer_preparation)
            steer[n], demand[n] = state[n, 0], state[n, 1]
            for key, value in self._engine.last_stats.items():
                totals[key] = totals.get(key, 0.0) + value
        self.last_solver_stats = totals
        self._demand = demand
        return steer, state

    def predict(self, observation: Any, state: np.ndarray | None = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """(steering command, demand) per observation: shape (2,) for one observation, (N, 2) for a batch; the
        state contract of ``Policy.predict``."""
        steer, st = super().predict(observation, state, episode_start, deterministic)
        demand = np.clip(self._demand, -1.0, 1.0).astype(np.float32)
        if steer.ndim == 1:
            return np.array((steer[0], demand[0]), dtype=np.float32), st
        return np.hstack((steer, demand.reshape(-1, 1))), st
