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
   Radius cap (``radius_lookahead_ratio``, default 0.35): L is capped at that fraction of the tightest radius
   among the curvature at the car and the preview samples up to L (floor ``min_radius_lookahead_m`` = 2.5 m):
   the chord's cut into a curvature change grows with L^2 kappa, so a 6 m hairpin at 25 km/h is pursued 2.5 m
   ahead instead of 5 m. Paper scenarios: inactive on DLC120-v0; on LateralTracking-v0 (R 20 m at 11.1 m/s,
   L 8.9 m) it shortens L in the tightest corners (max|e_y| 0.373 -> 0.373 m, ITAE 1432 -> 1403).
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

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines.base import Policy
from vtrack_gym.baselines.linear_models import understeer_gradient
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel


@documented
@dataclass(frozen=True)
class PurePursuitConfig:
    """Pure pursuit parameters.

    lookahead_gain_s: k_v [s]; min_lookahead_m, max_lookahead_m: clip of L [m].
    understeer_compensation: delta = kappa_cmd (l + K_us v^2) instead of atan(l kappa_cmd).
    use_course_angle: frame along the CG velocity instead of the heading.
    curvature_feedforward: pursue relative to the nominal goal (see the module docstring, step 5).
    radius_lookahead_ratio: cap L at this fraction of the tightest radius previewed within L (0: no cap);
    min_radius_lookahead_m: the cap's floor [m].
    """

    lookahead_gain_s: float = ranged(0.8, gt=0.0, le=5.0, unit="s")
    min_lookahead_m: float = ranged(4.0, gt=0.0, le=200.0, unit="m")
    max_lookahead_m: float = ranged(40.0, ge="min_lookahead_m", le=200.0, unit="m")
    understeer_compensation: bool = True
    use_course_angle: bool = True
    curvature_feedforward: bool = False
    radius_lookahead_ratio: float = ranged(0.35, ge=0.0, le=10.0)
    min_radius_lookahead_m: float = ranged(2.5, gt=0.0, le=200.0, unit="m")

    def __post_init__(self) -> None:
        validate(self)


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
        cfg: PurePursuitConfig = self.config
        kus = understeer_gradient(design) if cfg.understeer_compensation else 0.0
        idx = np.array([layout.index(n) for n in ("v_x", "v_y", "e_y", "e_phi", "curvature")])
        steps = np.arange(1, layout.n_preview + 1) * layout.preview_dt_s
        self.law = PurePursuitLaw(idx, layout.preview.start, steps, float(layout.preview_min_speed_mps),
                                  float(cfg.lookahead_gain_s), float(cfg.min_lookahead_m), float(cfg.max_lookahead_m),
                                  bool(cfg.use_course_angle), bool(cfg.curvature_feedforward),
                                  bool(cfg.understeer_compensation), float(design.wheelbase_m), float(kus),
                                  float(cfg.radius_lookahead_ratio), float(cfg.min_radius_lookahead_m))

    def lookahead(self, v: float) -> float:
        """Nominal look-ahead distance [m] at speed ``v`` [m/s] (before the radius cap of step 3)."""
        cfg: PurePursuitConfig = self.config
        return min(max(cfg.lookahead_gain_s * max(v, 0.0), cfg.min_lookahead_m), cfg.max_lookahead_m)

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        delta = np.empty(obs.shape[0])
        pure_pursuit_rows(self.law, obs, delta)
        return delta, None


class PurePursuitLaw(NamedTuple):
    """Parameters of the pure-pursuit law (``pure_pursuit_row``)."""

    idx: np.ndarray          # int64 (5,): v_x, v_y, e_y, e_phi, curvature
    pv0: int                 # first preview entry of the observation
    steps: np.ndarray        # (P,) preview sample times [s] (distance = spacing speed x time)
    pv_vmin: float           # preview spacing speed floor [m/s]
    gain_s: float            # look-ahead gain [s]
    min_lookahead_m: float
    max_lookahead_m: float
    use_course_angle: bool
    curvature_feedforward: bool
    understeer_compensation: bool
    wheelbase_m: float
    kus: float               # understeer gradient [rad s^2/m] (0 without compensation)
    radius_ratio: float      # cap of L as a fraction of the tightest previewed radius (0: none)
    radius_floor_m: float    # floor of that cap [m]


@kernel
def _circle_crossing(x0: float, y0: float, x1: float, y1: float, r2: float) -> tuple[float, float]:
    """Point of the segment (x0, y0)-(x1, y1) [m] at squared distance ``r2`` [m^2] from the origin
    (|P0|^2 < r2 <= |P1|^2)."""
    dx, dy = x1 - x0, y1 - y0
    a = dx * dx + dy * dy
    b = x0 * dx + y0 * dy
    c = x0 * x0 + y0 * y0 - r2
    disc = b * b - a * c
    t = (-b + math.sqrt(max(disc, 0.0))) / a if a > 0.0 else 1.0
    return x0 + t * dx, y0 + t * dy


@kernel
def _pursuit(law: PurePursuitLaw, obs: np.ndarray, i: int, x: float, y: float, th: float, goal: float,
             spacing: float) -> float:
    """kappa_cmd [1/m] of the arc to the goal on the path starting at (x, y) with heading th."""
    g2 = goal * goal
    k_prev, s_prev = float(obs[i, law.idx[4]]), 0.0
    px, py = x, y
    if x * x + y * y < g2:
        for j in range(law.steps.shape[0]):
            k_next = float(obs[i, law.pv0 + j])
            s_next = spacing * law.steps[j]
            h = s_next - s_prev
            th_mid = th + h * (3.0 * k_prev + k_next) * 0.125
            nx, ny = x + h * math.cos(th_mid), y + h * math.sin(th_mid)
            th += 0.5 * h * (k_prev + k_next)
            if nx * nx + ny * ny >= g2:
                x, y = _circle_crossing(x, y, nx, ny, g2)
                break
            x, y, k_prev, s_prev = nx, ny, k_next, s_next
        px, py = x, y
    dist2 = px * px + py * py
    return 2.0 * py / dist2 if dist2 > 1e-12 else 0.0


@kernel
def radius_capped_lookahead(law: PurePursuitLaw, obs: np.ndarray, i: int, goal: float, spacing: float) -> float:
    """Look-ahead [m]: ``goal`` capped at ``radius_ratio`` x the tightest radius among the curvature at the car and
    the preview samples up to the first one at or beyond ``goal`` (never below ``radius_floor_m``, never above
    ``goal``): the chord then cuts a curvature change by a bounded fraction of its radius."""
    k_max = abs(float(obs[i, law.idx[4]]))
    for j in range(law.steps.shape[0]):
        k_max = max(k_max, abs(float(obs[i, law.pv0 + j])))
        if spacing * law.steps[j] >= goal:
            break
    if law.radius_ratio >= goal * k_max:
        return goal
    return min(goal, max(law.radius_ratio / k_max, law.radius_floor_m))


@kernel
def pure_pursuit_row(law: PurePursuitLaw, obs: np.ndarray, i: int) -> float:
    """Road-wheel angle [rad] of observation row ``i``."""
    idx = law.idx
    v = max(float(obs[i, idx[0]]), 0.0)
    beta = math.atan2(float(obs[i, idx[1]]), v) if (law.use_course_angle and v > 0.1) else 0.0
    th = -float(obs[i, idx[3]]) - beta
    e_y = float(obs[i, idx[2]])
    goal = min(max(law.gain_s * v, law.min_lookahead_m), law.max_lookahead_m)
    spacing = max(v, law.pv_vmin)
    if law.radius_ratio > 0.0:
        goal = radius_capped_lookahead(law, obs, i, goal, spacing)
    kappa_cmd = _pursuit(law, obs, i, e_y * math.sin(th), -e_y * math.cos(th), th, goal, spacing)
    if law.curvature_feedforward:
        kappa_cmd += float(obs[i, idx[4]]) - _pursuit(law, obs, i, 0.0, 0.0, 0.0, goal, spacing)
    if law.understeer_compensation:
        return kappa_cmd * (law.wheelbase_m + law.kus * v * v)
    return math.atan(law.wheelbase_m * kappa_cmd)


@kernel
def pure_pursuit_rows(law: PurePursuitLaw, obs: np.ndarray, delta: np.ndarray) -> None:
    """``pure_pursuit_row`` of every row of ``obs`` into ``delta`` [rad]."""
    for i in range(obs.shape[0]):
        delta[i] = pure_pursuit_row(law, obs, i)
