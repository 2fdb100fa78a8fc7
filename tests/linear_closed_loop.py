"""Test helper: closed-loop simulation of a steering policy on the paper-math linear model (sections 2.2 + 3.1).

Plant (constant speed v [m/s], ideal steering actuator: the commanded road-wheel angle is applied at once and
held over the control period):

* lateral/yaw dynamics: the linear single-track model of paper-math 2.2 in (v_y, r), axle stiffnesses;
* exact Frenet error kinematics of paper-math 3.1 on a curvature profile kappa(s):
  ``s' = (v cos e_phi - v_y sin e_phi)/(1 - kappa e_y)``, ``e_y' = v sin e_phi + v_y cos e_phi``,
  ``e_phi' = r - kappa(s) s'``.

Integration: classic RK4 at 1 ms; the policy is called every ``control_period_s`` (10 ms) with an observation
built exactly like the env's (``ObservationLayout``: e_y_dot = v sin e_phi + v_y cos e_phi, e_phi_dot = r -
kappa s', yaw_rate_ref = kappa s', yaw_acc_ref = kappa'(s) s'^2 (a_x = 0), curvature, curvature_rate and the
curvature preview at ``layout.preview_distances(v)`` ahead of the projection point).

Curvature profiles (``CurvatureProfile``, kappa and d kappa/ds as functions of arc length s):

* ``curve_entry(v, radius)``: kappa ramps from 0 to 1/R through a C^1 smoothstep 3x^2 - 2x^3 over the arc
  travelled between t = 1 s and t = 2 s (paper-math 6);
* ``dlc_proxy()``: 20 m straight, a 3.5 m cosine lane change over 60 m (kappa = (H/2)(pi/L)^2 cos(pi x/L), the
  small-angle curvature of y = (H/2)(1 - cos(pi x/L)); peak 0.0048 1/m), 30 m hold, the same back over 60 m,
  then straight (paper-math 6's "DLC proxy"); kappa steps at the ends of each transition as for the cosine path;
* ``straight()``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel, paper_vehicle

DESIGN = DesignModel.from_vehicle(paper_vehicle())


@dataclass(frozen=True)
class CurvatureProfile:
    """kappa(s) [1/m] and d kappa/ds [1/m^2] along arc length s [m]."""

    kappa: Callable[[float], float]
    dkappa: Callable[[float], float]
    name: str = "profile"


def straight() -> CurvatureProfile:
    """A straight line."""
    return CurvatureProfile(lambda s: 0.0, lambda s: 0.0, "straight")


def curve_entry(v: float, radius: float, t_start: float = 1.0, t_ramp: float = 1.0) -> CurvatureProfile:
    """0 -> 1/radius through a C^1 smoothstep over [v t_start, v (t_start + t_ramp)] of arc length."""
    s0, length, k_end = v * t_start, v * t_ramp, 1.0 / radius

    def kappa(s: float) -> float:
        x = min(max((s - s0) / length, 0.0), 1.0)
        return k_end * x * x * (3.0 - 2.0 * x)

    def dkappa(s: float) -> float:
        x = (s - s0) / length
        if x <= 0.0 or x >= 1.0:
            return 0.0
        return k_end * 6.0 * x * (1.0 - x) / length

    return CurvatureProfile(kappa, dkappa, f"curve_R{radius:g}")


def dlc_proxy(offset: float = 3.5, change: float = 60.0, hold: float = 30.0, lead: float = 20.0) -> CurvatureProfile:
    """Cosine lane change ``offset`` [m] over ``change`` [m], hold ``hold`` [m], back; starts after ``lead`` [m]."""
    amp = 0.5 * offset * (math.pi / change) ** 2
    w = math.pi / change
    back = lead + change + hold

    def kappa(s: float) -> float:
        if lead <= s < lead + change:
            return amp * math.cos(w * (s - lead))
        if back <= s < back + change:
            return -amp * math.cos(w * (s - back))
        return 0.0

    def dkappa(s: float) -> float:
        if lead <= s < lead + change:
            return -amp * w * math.sin(w * (s - lead))
        if back <= s < back + change:
            return amp * w * math.sin(w * (s - back))
        return 0.0

    return CurvatureProfile(kappa, dkappa, "dlc_proxy")


@dataclass
class ClosedLoopResult:
    """Logged at every control step: time [s], e_y [m], e_phi [rad], delta [rad], s [m], v_y [m/s], r [rad/s]."""

    t: np.ndarray
    e_y: np.ndarray
    e_phi: np.ndarray
    delta: np.ndarray
    s: np.ndarray
    v_y: np.ndarray
    r: np.ndarray

    def max_abs_e_y(self, t_from: float = 0.0) -> float:
        """max |e_y| [m] from ``t_from`` [s] on."""
        return float(np.max(np.abs(self.e_y[self.t >= t_from])))

    def final(self, name: str, window_s: float = 0.5) -> float:
        """Mean of a logged signal over the last ``window_s`` [s]."""
        x = getattr(self, name)
        return float(np.mean(x[self.t >= self.t[-1] - window_s]))


class LinearPlant:
    """One car on one curvature profile at constant speed (state e_y, e_phi, v_y, r, s)."""

    def __init__(self, v: float, profile: CurvatureProfile, design: DesignModel = DESIGN,
                 layout: ObservationLayout = OBS, e_y0: float = 0.0, e_phi0: float = 0.0) -> None:
        self.v = v
        self.profile = profile
        self.layout = layout
        m, iz = design.mass_kg, design.yaw_inertia_kgm2
        a1, a2 = design.cg_to_front_axle_m, design.cg_to_rear_axle_m
        cf, cr = design.front_cornering_stiffness_npr, design.rear_cornering_stiffness_npr
        self.a = ((-(cf + cr) / (m * v), (-a1 * cf + a2 * cr) / (m * v) - v),
                  ((-a1 * cf + a2 * cr) / (iz * v), -(a1 * a1 * cf + a2 * a2 * cr) / (iz * v)))
        self.b = (cf / m, a1 * cf / iz)
        self.x = [e_y0, e_phi0, 0.0, 0.0, 0.0]
        self.delta = 0.0

    def _deriv(self, x: list[float], delta: float) -> list[float]:
        e_y, e_phi, v_y, r, s = x
        k = self.profile.kappa(s)
        c, sn = math.cos(e_phi), math.sin(e_phi)
        s_dot = (self.v * c - v_y * sn) / (1.0 - k * e_y)
        (a11, a12), (a21, a22) = self.a
        return [self.v * sn + v_y * c, r - k * s_dot, a11 * v_y + a12 * r + self.b[0] * delta,
                a21 * v_y + a22 * r + self.b[1] * delta, s_dot]

    def step(self, delta: float, duration: float, dt: float = 1e-3) -> None:
        """Hold ``delta`` [rad] for ``duration`` [s], RK4 steps of ``dt`` [s]."""
        self.delta = delta
        n = max(1, round(duration / dt))
        h = duration / n
        x = self.x
        for _ in range(n):
            k1 = self._deriv(x, delta)
            k2 = self._deriv([xi + 0.5 * h * ki for xi, ki in zip(x, k1, strict=True)], delta)
            k3 = self._deriv([xi + 0.5 * h * ki for xi, ki in zip(x, k2, strict=True)], delta)
            k4 = self._deriv([xi + h * ki for xi, ki in zip(x, k3, strict=True)], delta)
            x = [xi + h / 6.0 * (a + 2.0 * b + 2.0 * c + d) for xi, a, b, c, d in zip(x, k1, k2, k3, k4, strict=True)]
        self.x = x

    def observation(self) -> np.ndarray:
        """The env-style observation (float64) of the current state."""
        e_y, e_phi, v_y, r, s = self.x
        lay, prof, v = self.layout, self.profile, self.v
        k = prof.kappa(s)
        c, sn = math.cos(e_phi), math.sin(e_phi)
        s_dot = (v * c - v_y * sn) / (1.0 - k * e_y)
        obs = np.zeros(lay.size)
        obs[lay.E_Y], obs[lay.E_PHI] = e_y, e_phi
        obs[lay.E_Y_DOT], obs[lay.E_PHI_DOT] = v * sn + v_y * c, r - k * s_dot
        obs[lay.V_X], obs[lay.V_Y], obs[lay.YAW_RATE] = v, v_y, r
        obs[lay.ROAD_WHEEL_ANGLE], obs[lay.TARGET_SPEED] = self.delta, v
        obs[lay.YAW_RATE_REF], obs[lay.YAW_ACC_REF] = k * s_dot, prof.dkappa(s) * s_dot * s_dot
        obs[lay.CURVATURE], obs[lay.CURVATURE_RATE] = k, prof.dkappa(s)
        obs[lay.preview] = [prof.kappa(s + d) for d in lay.preview_distances(v)]
        return obs


def simulate_many(policy, plants: list[LinearPlant], t_end: float, control_period_s: float = 0.01,
                  batched: bool = True) -> list[ClosedLoopResult]:
    """Run ``plants`` in lock-step; one batched ``predict`` per control step (or one call per plant)."""
    n_steps = round(t_end / control_period_s)
    max_steer = policy.max_steer_rad
    logs = [[] for _ in plants]
    states: list = [None] * len(plants)
    state = None
    for k in range(n_steps + 1):
        if batched:
            obs = np.stack([p.observation() for p in plants])
            action, state = policy.predict(obs, state, episode_start=state is None)
            deltas = action.reshape(-1).astype(np.float64) * max_steer
        else:
            deltas = []
            for i, p in enumerate(plants):
                action, states[i] = policy.predict(p.observation(), states[i], episode_start=states[i] is None)
                deltas.append(float(action[0]) * max_steer)
        for i, (p, d) in enumerate(zip(plants, deltas, strict=True)):
            logs[i].append((k * control_period_s, p.x[0], p.x[1], float(d), p.x[4], p.x[2], p.x[3]))
            if k < n_steps:
                p.step(float(d), control_period_s)
    out = []
    for rows in logs:
        arr = np.asarray(rows)
        out.append(ClosedLoopResult(*(arr[:, j] for j in range(7))))
    return out


def simulate(policy, v: float, profile: CurvatureProfile, t_end: float, e_y0: float = 0.0,
             control_period_s: float = 0.01, design: DesignModel = DESIGN) -> ClosedLoopResult:
    """One closed-loop run of ``policy`` at constant speed ``v`` [m/s] on ``profile`` for ``t_end`` [s]."""
    plant = LinearPlant(v, profile, design, policy.layout, e_y0=e_y0)
    return simulate_many(policy, [plant], t_end, control_period_s, batched=False)[0]
