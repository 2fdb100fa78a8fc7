"""Pure pursuit on the path reconstructed from the curvature preview (peer).

The observation has no global pose, so the path ahead is rebuilt in a frame attached to the car's CG:

1. Frame: origin at the CG, x along the CG velocity (course angle = heading + beta, beta = atan2(v_y, v_x),
   ``use_course_angle=True``) or along the heading (classic). The path's projection point is
   ``P0 = -e_y n0`` with the path heading ``theta0 = -e_phi (- beta)`` and its left normal n0.
2. Arc: the curvature is taken piecewise linear through (kappa(0), preview samples) at the arc lengths
   (0, d_1, ..., d_P) [m]; ``theta`` is integrated exactly and the position with the midpoint rule on each
   preview interval.
3. Look-ahead distance ``L = clip(lookahead_gain_s v, min_lookahead_m, max_lookahead_m)`` [m]; the goal is
   the first point of the reconstructed path at distance L from the CG (linear interpolation on the chord of
   the interval that crosses the circle); if the preview ends earlier, its last point (at its own distance).
4. Pure pursuit: the circle through the CG, tangent to the frame's x axis, through the goal has curvature
   ``kappa_cmd = 2 sin(alpha) / L`` (alpha = goal bearing). Road-wheel angle:
   ``delta = kappa_cmd (l + K_us v^2)`` (steady-state inverse of the dynamic single-track model,
   ``understeer_compensation``) or the kinematic ``atan(l kappa_cmd)``.

5. ``curvature_feedforward`` (OPTION, default False = classic pure pursuit): classic pure pursuit steers for the
   look-ahead chord and therefore cuts into every curvature change by about the look-ahead distance. With this
   option the command is ``kappa_cmd = kappa(0) + (kappa_pp - kappa_nominal)``, where ``kappa_nominal`` is the
   pure-pursuit curvature a car exactly on the path (e_y = 0, velocity tangent to it) would compute from the
   same preview: pure pursuit then acts on the deviation from the nominal geometry, and the path curvature at
   the car is fed forward. On a straight or a constant circle both forms are identical. Measured in the
   linear model it helps at 40 km/h (R100: 12 mm instead of 84 mm) but hurts at 120 km/h, where the classic
   corner cutting is the lead that compensates the yaw lag (R500: 222 mm instead of 69 mm), so it is off.

With the course-angle frame and the understeer compensation, a car on a circle at the steady state of the
linear model gets kappa_cmd = kappa exactly, so e_y,ss = 0 (classic heading-frame pure pursuit keeps a
sideslip-dependent offset). Stateless; output clipped to +-max_road_wheel_angle_rad.

Default: k_v = 0.8 s, L in [4, 40] m. Pure pursuit anticipates by cutting: linear closed loop max|e_y| 84 mm
(11.11 m/s, R 100), 69 mm (33.33 m/s, R 500), 0.37 m (DLC proxy); e_y,ss = 0. Shorter look-ahead is poorly
damped at 120 km/h (k_v = 0.4: a 0.5 m offset still oscillates after 5 s; k_v = 0.6 leaves the road in the
env's DLC120-v0), longer cuts more (k_v = 1.0: R 100 132 mm).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from vtrack_gym.baselines.base import Policy, require_range
from vtrack_gym.baselines.linear_models import understeer_gradient
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel


@dataclass(frozen=True)
class PurePursuitConfig:
    """Pure pursuit parameters.

    lookahead_gain_s: k_v [s], in (0, 5]; min_lookahead_m, max_lookahead_m: clip of L [m] (0 < min <= max <= 200).
    understeer_compensation: delta = kappa_cmd (l + K_us v^2) instead of atan(l kappa_cmd).
    use_course_angle: frame along the CG velocity instead of the heading.
    curvature_feedforward: pursue relative to the nominal goal (see the module docstring, step 5).
    """

    lookahead_gain_s: float = 0.8
    min_lookahead_m: float = 4.0
    max_lookahead_m: float = 40.0
    understeer_compensation: bool = True
    use_course_angle: bool = True
    curvature_feedforward: bool = False

    def __post_init__(self) -> None:
        require_range(self, "lookahead_gain_s", 0.0, 5.0, low_inclusive=False)
        require_range(self, "min_lookahead_m", 0.0, 200.0, low_inclusive=False)
        require_range(self, "max_lookahead_m", self.min_lookahead_m, 200.0)
        for name in ("understeer_compensation", "use_course_angle", "curvature_feedforward"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"PurePursuitConfig.{name} must be a bool (got {getattr(self, name)!r})")


PURE_PURSUIT_PRESETS: dict[str, PurePursuitConfig] = {"default": PurePursuitConfig()}


class PurePursuit(Policy):
    """Pure pursuit on the preview-reconstructed path; stateless. See the module docstring."""

    name: ClassVar[str] = "pure_pursuit"
    PRESETS: ClassVar[dict[str, PurePursuitConfig]] = PURE_PURSUIT_PRESETS
    config_type: ClassVar[type] = PurePursuitConfig
    state_size = 0

    def __init__(self, design: DesignModel, config: PurePursuitConfig | None = None,
                 layout: ObservationLayout = OBS, control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        self._l = design.wheelbase_m
        self._kus = understeer_gradient(design) if self.config.understeer_compensation else 0.0
        L = layout
        self._idx = (L.index("v_x"), L.index("v_y"), L.index("e_y"), L.index("e_phi"), L.index("curvature"))
        self._pv = (layout.preview.start, layout.preview.stop)
        self._steps = (np.arange(1, layout.n_preview + 1) * layout.preview_dt_s).tolist()
        self._vmin = layout.preview_min_speed_mps

    def lookahead(self, v: float) -> float:
        """Look-ahead distance [m] at speed ``v`` [m/s]."""
        cfg: PurePursuitConfig = self.config
        return min(max(cfg.lookahead_gain_s * max(v, 0.0), cfg.min_lookahead_m), cfg.max_lookahead_m)

    def _pursuit_batch(self, obs: np.ndarray, x: np.ndarray, y: np.ndarray, th: np.ndarray, goal: np.ndarray,
                       spacing: np.ndarray) -> np.ndarray:
        n = obs.shape[0]
        g2 = goal * goal
        found = x * x + y * y >= g2
        px, py = x.copy(), y.copy()
        k_prev, s_prev = obs[:, self._idx[4]].copy(), np.zeros(n)
        for j, dk in enumerate(self._steps):
            k_next = obs[:, self._pv[0] + j]
            s_next = spacing * dk
            h = s_next - s_prev
            th_mid = th + h * (3.0 * k_prev + k_next) * 0.125
            nx, ny = x + h * np.cos(th_mid), y + h * np.sin(th_mid)
            th = th + 0.5 * h * (k_prev + k_next)
            cross = ~found & (nx * nx + ny * ny >= g2)
            if cross.any():
                cx, cy = _circle_crossing(x[cross], y[cross], nx[cross], ny[cross], g2[cross])
                px[cross], py[cross] = cx, cy
                found |= cross
            x, y, k_prev, s_prev = nx, ny, k_next, s_next
        px[~found], py[~found] = x[~found], y[~found]
        dist2 = px * px + py * py
        safe = dist2 > 1e-12
        return np.where(safe, 2.0 * py / np.where(safe, dist2, 1.0), 0.0)

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        iv, ivy, iey, iep, ik = self._idx
        n = obs.shape[0]
        v = np.maximum(obs[:, iv], 0.0)
        beta = np.zeros(n)
        cfg: PurePursuitConfig = self.config
        if cfg.use_course_angle:
            moving = v > 0.1
            beta[moving] = np.arctan2(obs[moving, ivy], v[moving])
        th = -obs[:, iep] - beta
        e_y = obs[:, iey]
        goal = np.clip(cfg.lookahead_gain_s * v, cfg.min_lookahead_m, cfg.max_lookahead_m)
        spacing = np.maximum(v, self._vmin)
        kappa_cmd = self._pursuit_batch(obs, e_y * np.sin(th), -e_y * np.cos(th), th, goal, spacing)
        if cfg.curvature_feedforward:
            zero = np.zeros(n)
            kappa_cmd += obs[:, ik] - self._pursuit_batch(obs, zero, zero, zero, goal, spacing)
        if cfg.understeer_compensation:
            return kappa_cmd * (self._l + self._kus * v * v), None
        return np.arctan(self._l * kappa_cmd), None


def _circle_crossing(x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray,
                     r2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points of the segments (x0, y0)-(x1, y1) [m] at squared distance ``r2`` [m^2] from the origin
    (|P0|^2 < r2 <= |P1|^2)."""
    dx, dy = x1 - x0, y1 - y0
    a = dx * dx + dy * dy
    b = x0 * dx + y0 * dy
    c = x0 * x0 + y0 * y0 - r2
    disc = b * b - a * c
    t = np.where(a > 0.0, (-b + np.sqrt(np.maximum(disc, 0.0))) / np.where(a > 0.0, a, 1.0), 1.0)
    return x0 + t * dx, y0 + t * dy
