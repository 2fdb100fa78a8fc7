"""A Kalman filter on the measured lateral states, the ``observer`` option of the paper's MPC and SMC.

The paper's controllers use the measurements as they come: the MPC differences them between samples, the SMC
multiplies rates by large gains, so sensor noise reaches the steering amplified. A real deployment puts a state
estimator in front of them; this is the textbook one for this plant.

Model (the paper's linear design model, eq. (5), at the measured speed v = max(v_x, ``min_speed_mps``), plus the
path errors and the steering actuator), state ``x = (e_y [m], e_phi [rad], v_y [m/s], r [rad/s], delta [rad])``::

    e_y'   = v_y + v e_phi                  e_phi' = r - psi_ref_dot
    (v_y, r)' = A(v) (v_y, r) + B(v) delta  delta' = (u - delta) / tau

inputs the observation's reference yaw rate psi_ref_dot (noise free) and the command u the controller applied
last; discretised over one control period (second-order series of the matrix exponential, exact to 1e-3 at the
fastest pole). Measurements: the seven noisy fields e_y, e_phi, e_y_dot (= v_y + v e_phi), e_phi_dot (= r -
psi_ref_dot), v_y, yaw_rate, road_wheel_angle, with the covariance R = diag(sigma^2) of the env's DECLARED sensor
noise (``EnvConfig.noise_std``: the standard deviations at ``sensor_noise = 1``). The process noise Q
(``ObserverConfig``, per control period) stands for what the linear model leaves out: tyre saturation, load
transfer, roll, an unknown actuator delay.

Actuator dead time: the robust suite delays the steering command by 0-50 ms, unknown to the controller. A bank
of actuator models (lag and rate limit), one per candidate dead time 0..``max_delay_s`` in control periods, is fed
with the command history; the candidate whose output stays closest to the measured road-wheel angle (discounted
squared residuals) is the identified dead time. The filter then uses the command that acts now, and the estimate
is predicted over the dead time with the commands already sent (a Smith predictor), so that the law computes its
command for the state in which it will act.

The controller then sees the observation with e_y, e_phi, v_y, yaw_rate, road_wheel_angle replaced by the
predicted estimates and e_y_dot, e_phi_dot recomputed from them (v_x, the references and the preview are passed
through).

Memory per row (``LateralKalmanFilter.memory_size``): the estimate (5), its covariance (25, row-major), the command
history, the candidate actuator outputs and their residuals (``max_delay_s / T_c + 1`` each); an episode start
initialises the estimate from the measurement and P from R.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.envs.observation import NOISY_FIELDS, ObservationLayout
from vtrack_gym.vehicle.linear import lateral_matrices
from vtrack_gym.vehicle.params import DesignModel

N_STATE = 5
MEASURED = ("e_y", "e_phi", "e_y_dot", "e_phi_dot", "v_y", "yaw_rate", "road_wheel_angle")
"""Observation fields the filter uses as measurements (in the rows of H)."""
BASE_MEMORY = N_STATE + N_STATE * N_STATE
MIN_NOISE_STD = 1e-4
"""Floor of a declared noise standard deviation (a noise-free field keeps R positive definite)."""


@documented
@dataclass(frozen=True)
class ObserverConfig:
    """Process-noise standard deviations per control period and the filter's model speed floor.

    q_e_y [m], q_e_phi [rad], q_v_y [m/s], q_yaw_rate [rad/s], q_delta [rad]: per-period random walks on the
    states. min_speed_mps: floor of the model speed [m/s]. actuator_lag_s: the steering lag tau [s].
    max_delay_s: the longest actuator dead time the delay identification considers [s]; delay_forgetting: the
    forgetting factor of its squared residuals per control period (0.99: a memory of about 1 s).
    """

    q_e_y: float = ranged(0.001, gt=0.0, le=1.0, unit="m")
    q_e_phi: float = ranged(0.0005, gt=0.0, le=1.0, unit="rad")
    q_v_y: float = ranged(0.02, gt=0.0, le=10.0, unit="m/s")
    q_yaw_rate: float = ranged(0.01, gt=0.0, le=10.0, unit="rad/s")
    q_delta: float = ranged(0.003, gt=0.0, le=1.0, unit="rad")
    min_speed_mps: float = ranged(3.0, ge=0.5, le=20.0, unit="m/s")
    actuator_lag_s: float = ranged(0.03, ge=0.001, le=1.0, unit="s")
    max_delay_s: float = ranged(0.1, ge=0.0, le=0.5, unit="s")
    delay_forgetting: float = ranged(0.99, gt=0.0, lt=1.0)

    def __post_init__(self) -> None:
        validate(self)


def declared_noise_std(env: Any) -> tuple[float, ...]:
    """The env's declared sensor-noise standard deviations (``EnvConfig.noise_std``, ``NOISY_FIELDS`` order; the
    default config's when the env does not declare them)."""
    base = getattr(env, "unwrapped", env)
    config = getattr(base, "config", None)
    if config is None and hasattr(env, "get_attr"):   # an SB3 VecEnv: its first env's (if it has one)
        try:
            config = env.get_attr("config")[0]
        except AttributeError:
            config = None
    if config is None or not hasattr(config, "noise_std"):
        from vtrack_gym.envs.config import EnvConfig

        config = EnvConfig()
    return tuple(float(s) for s in config.noise_std)


class LateralKalmanFilter:
    """The filter of the module docstring for one design, layout and control period.

    Memory row: estimate (5), covariance (25), then three blocks of ``n_delays`` = max_delay / T_c + 1 entries:
    the commands of the last periods (newest first) [rad], each candidate dead time's actuator model output [rad]
    and its discounted squared residual against the measured road-wheel angle [rad^2].
    """

    def __init__(self, design: DesignModel, layout: ObservationLayout, control_period_s: float,
                 noise_std: Sequence[float], config: ObserverConfig | None = None) -> None:
        if len(noise_std) != len(NOISY_FIELDS):
            raise ValueError(f"noise_std must have {len(NOISY_FIELDS)} entries, one per {', '.join(NOISY_FIELDS)} "
                             f"(got {len(noise_std)})")
        self.design = design
        self.config = config or ObserverConfig()
        self.dt = float(control_period_s)
        self.max_steer = float(design.max_road_wheel_angle_rad)
        self.max_rate = float(design.max_road_wheel_rate_radps)
        sigma = {name: max(float(s), MIN_NOISE_STD) for name, s in zip(NOISY_FIELDS, noise_std, strict=True)}
        self.r_cov = np.diag([sigma[name] ** 2 for name in MEASURED])
        c = self.config
        self.q_cov = np.diag(np.square([c.q_e_y, c.q_e_phi, c.q_v_y, c.q_yaw_rate, c.q_delta]))
        self.n_delays = math.floor(c.max_delay_s / self.dt + 1e-9) + 1
        self.memory_size = BASE_MEMORY + 3 * self.n_delays
        self._meas_idx = [layout.index(name) for name in MEASURED]
        self._v_idx = layout.index("v_x")
        self._ref_idx = layout.index("yaw_rate_ref")
        self._out_idx = {name: layout.index(name) for name in MEASURED}

    def _blocks(self, mem: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Views of (command history, candidate actuator outputs, candidate residuals) in a memory row."""
        h = self.n_delays
        return mem[BASE_MEMORY:BASE_MEMORY + h], mem[BASE_MEMORY + h:BASE_MEMORY + 2 * h], mem[BASE_MEMORY + 2 * h:]

    def _model(self, v: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Discrete (A_d, G_d, H) at speed ``v`` [m/s]: x+ = A_d x + G_d (psi_ref_dot, u), y = H x + (0, 0, 0,
        -psi_ref_dot, 0, 0, 0)."""
        a_lat, b_lat = lateral_matrices(self.design, v)
        a = np.zeros((N_STATE, N_STATE))
        a[0, 2], a[0, 1], a[1, 3] = 1.0, v, 1.0
        a[2:4, 2:4] = a_lat
        a[2:4, 4] = b_lat
        a[4, 4] = -1.0 / self.config.actuator_lag_s
        g = np.zeros((N_STATE, 2))
        g[1, 0] = -1.0
        g[4, 1] = 1.0 / self.config.actuator_lag_s
        ad_t = a * self.dt
        a_d = np.eye(N_STATE) + ad_t + 0.5 * ad_t @ ad_t
        g_d = (np.eye(N_STATE) + 0.5 * ad_t) @ g * self.dt
        h = np.zeros((len(MEASURED), N_STATE))
        h[0, 0] = h[1, 1] = h[3, 3] = h[4, 2] = h[5, 3] = h[6, 4] = 1.0
        h[2, 2], h[2, 1] = 1.0, v
        return a_d, g_d, h

    def initial_memory(self, obs: np.ndarray) -> np.ndarray:
        """Memory rows (N, memory_size) starting from the measurements of ``obs`` (N, obs_dim)."""
        mem = np.zeros((obs.shape[0], self.memory_size))
        idx = self._out_idx
        mem[:, :N_STATE] = obs[:, [idx["e_y"], idx["e_phi"], idx["v_y"], idx["yaw_rate"], idx["road_wheel_angle"]]]
        p0 = np.diag(np.diag(self.r_cov)[[0, 1, 4, 5, 6]])
        mem[:, N_STATE:BASE_MEMORY] = p0.reshape(-1)
        delta = np.clip(obs[:, idx["road_wheel_angle"]], -self.max_steer, self.max_steer)
        h = self.n_delays
        mem[:, BASE_MEMORY:BASE_MEMORY + 2 * h] = delta[:, None]
        return mem

    def dead_time_steps(self, mem: np.ndarray) -> int:
        """The identified actuator dead time [control periods] of a memory row."""
        return int(np.argmin(self._blocks(mem)[2]))

    def _identify_delay(self, mem: np.ndarray, measured_delta: float) -> int:
        """Advance every candidate dead time's actuator model by one period and score it; the best candidate."""
        commands, outputs, scores = self._blocks(mem)
        step = np.clip((commands - outputs) / self.config.actuator_lag_s, -self.max_rate, self.max_rate) * self.dt
        outputs += step
        scores *= self.config.delay_forgetting
        scores += (measured_delta - outputs) ** 2
        return int(np.argmin(scores))

    def update(self, row: np.ndarray, mem: np.ndarray) -> None:
        """One predict + correct step for one observation row, memory row ``mem`` updated in place."""
        v = max(float(row[self._v_idx]), self.config.min_speed_mps)
        ref = float(row[self._ref_idx])
        delay = self._identify_delay(mem, float(row[self._out_idx["road_wheel_angle"]]))
        a_d, g_d, h = self._model(v)
        x = a_d @ mem[:N_STATE] + g_d @ np.array([ref, self._blocks(mem)[0][delay]])
        p = mem[N_STATE:BASE_MEMORY].reshape(N_STATE, N_STATE)
        p = a_d @ p @ a_d.T + self.q_cov
        innovation = row[self._meas_idx] - h @ x
        innovation[3] += ref
        s = h @ p @ h.T + self.r_cov
        gain = np.linalg.solve(s, h @ p).T
        x = x + gain @ innovation
        p = (np.eye(N_STATE) - gain @ h) @ p
        mem[:N_STATE] = x
        mem[N_STATE:BASE_MEMORY] = (0.5 * (p + p.T)).reshape(-1)

    def predicted_state(self, row: np.ndarray, mem: np.ndarray) -> np.ndarray:
        """The estimate moved forward over the identified dead time with the commands already sent (a Smith
        predictor: the state at which a command issued now starts to act)."""
        x = mem[:N_STATE].copy()
        delay = self.dead_time_steps(mem)
        if delay == 0:
            return x
        a_d, g_d, _ = self._model(max(float(row[self._v_idx]), self.config.min_speed_mps))
        ref = float(row[self._ref_idx])
        commands = self._blocks(mem)[0]
        for j in range(delay - 1, -1, -1):
            x = a_d @ x + g_d @ np.array([ref, commands[j]])
        return x

    def record_command(self, mem: np.ndarray, command: float) -> None:
        """Push the command applied this period [rad] into the history of a memory row."""
        commands = self._blocks(mem)[0]
        commands[1:] = commands[:-1].copy()
        commands[0] = command

    def estimated_observation(self, row: np.ndarray, mem: np.ndarray) -> np.ndarray:
        """``row`` with the measured lateral fields replaced by the (dead-time predicted) estimate of ``mem``."""
        out = row.copy()
        e_y, e_phi, v_y, r, delta = self.predicted_state(row, mem)
        v = float(row[self._v_idx])
        idx = self._out_idx
        out[idx["e_y"]], out[idx["e_phi"]], out[idx["v_y"]] = e_y, e_phi, v_y
        out[idx["yaw_rate"]], out[idx["road_wheel_angle"]] = r, delta
        out[idx["e_y_dot"]] = v * math.sin(e_phi) + v_y * math.cos(e_phi)
        out[idx["e_phi_dot"]] = r - row[self._ref_idx]
        return out


class ObserverOption:
    """Mixin of the controllers with an ``observer`` option (the paper's MPC and SMC).

    The controller implements its law as ``_law_batch(obs, law_state)`` and ``_law_initial_state(obs)``; with
    ``config.observer`` the mixin runs the Kalman filter in front of it and appends the filter's memory to the
    law's state (``_attach_observer`` sets ``state_size``); without it, the law runs on the raw observation
    exactly as before.
    """

    observer: LateralKalmanFilter | None = None
    law_state_size: int = 0

    def _attach_observer(self, noise_std: Sequence[float] | None) -> None:
        """Build the filter when ``config.observer`` is on (``noise_std``: the env's declared sensor noise)."""
        self.law_state_size = self.state_size
        if not self.config.observer:
            return
        if noise_std is None:
            from vtrack_gym.envs.config import EnvConfig

            noise_std = EnvConfig().noise_std
        self.observer = LateralKalmanFilter(self.design, self.layout, self.control_period_s, noise_std)
        self.state_size = self.law_state_size + self.observer.memory_size

    @classmethod
    def from_env(cls, env: Any, preset: str = "default", **overrides: Any) -> Any:
        """As ``Policy.from_env``, also reading the env's declared sensor noise (``declared_noise_std``)."""
        from vtrack_gym.baselines.base import env_contract

        design, layout, period = env_contract(env)
        return cls(design, cls.make_config(preset, **overrides), layout=layout, control_period_s=period,
                   noise_std=declared_noise_std(env))

    def _initial_state_batch(self, obs: np.ndarray) -> np.ndarray:
        if self.observer is None:
            return self._law_initial_state(obs)
        law = self._law_initial_state(obs) if self.law_state_size else np.zeros((obs.shape[0], 0))
        return np.hstack((law, self.observer.initial_memory(obs)))

    def _act_batch(self, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        if self.observer is None:
            return self._law_batch(obs, state)
        assert state is not None
        k = self.law_state_size
        estimated = np.empty_like(obs)
        for n in range(obs.shape[0]):
            self.observer.update(obs[n], state[n, k:])
            estimated[n] = self.observer.estimated_observation(obs[n], state[n, k:])
        law_state = state[:, :k] if k else None
        delta, law_state = self._law_batch(estimated, law_state)
        if k:
            state[:, :k] = law_state
        for n, command in enumerate(np.clip(delta, -self.max_steer_rad, self.max_steer_rad)):
            self.observer.record_command(state[n, k:], float(command))
        return delta, state
