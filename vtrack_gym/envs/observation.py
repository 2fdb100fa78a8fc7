"""The observation layout shared by every env, policy and agent.

Policies must never hard-code positions: use ``OBS.index("e_y")`` or ``OBS.E_Y`` / ``OBS.preview``.
All entries are raw SI units (m, rad, s); RL code normalises if it wants (VecNormalize or the shipped agents'
own normalisation).

Scalar fields (in this order):

================  =========  =========================================================================
name              unit       meaning
================  =========  =========================================================================
e_y               m          lateral error of the CG from its projection on the path, LEFT-positive
e_phi             rad        heading error wrap(psi - psi_ref) in (-pi, pi]
e_y_dot           m/s        v_x sin(e_phi) + v_y cos(e_phi)  (paper eq. 8, exact at the projection)
e_phi_dot         rad/s      r - psi_ref_dot
v_x               m/s        longitudinal body-frame speed
v_y               m/s        lateral body-frame speed (left-positive)
yaw_rate          rad/s      r, counter-clockwise positive
road_wheel_angle  rad        current (actuator output) front road-wheel angle, left-positive
target_speed      m/s        the inner speed loop's set point
yaw_rate_ref      rad/s      psi_ref_dot = kappa(s*) * s_dot
yaw_acc_ref       rad/s^2    psi_ref_ddot = kappa'(s*) * s_dot^2 + kappa(s*) * a_x
curvature         1/m        kappa(s*) at the projection point (left turn positive)
curvature_rate    1/m^2      d kappa / d s at the projection point
================  =========  =========================================================================

Then ``n_preview`` curvature samples kappa(s* + d_k) [1/m] at the look-ahead distances
``d_k = max(v_x, preview_min_speed_mps) * k * preview_dt_s`` for k = 1..n_preview (default: 20 samples every
0.1 s, i.e. two seconds of travel). ``OBS.preview_distances(v_x)`` returns those distances.

Then, at the END (so that no earlier index moves), ``n_speed_preview`` samples of the reference speed
v_ref(s* + d_j) [m/s] named ``v_ref_preview_j``, at ``d_j = max(v_x, preview_min_speed_mps) * j *
speed_preview_dt_s`` for j = 1..n_speed_preview (``OBS``: 10 samples every 0.2 s, two seconds of travel;
``ObservationLayout()`` has none, the 33-entry layout of the shipped agents). ``target_speed`` is the reference
speed now (constant on the paper scenarios, v_ref(s*) on a track with a speed profile).

Adding a scalar field touches three files: here (``SCALAR_FIELDS``, ``SCALAR_BOUNDS``, the ``ObservationLayout``
index attribute and the table above), ``envs/kernels.py`` (a parameter of ``write_observation`` and its value in
``observe_one``) and ``interop/lane_observation.py`` (its value on a highway-env lane).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate

# Bounds of the observation box per scalar field (generous physical limits; the envs terminate long before:
# |e_y| beyond the road half width, |e_phi| > pi/2). Preview samples are bounded by PREVIEW_BOUND.
SCALAR_BOUNDS: dict[str, float] = {
    "e_y": 100.0, "e_phi": 4.0, "e_y_dot": 100.0, "e_phi_dot": 50.0, "v_x": 100.0, "v_y": 100.0,
    "yaw_rate": 50.0, "road_wheel_angle": 2.0, "target_speed": 100.0, "yaw_rate_ref": 50.0,
    "yaw_acc_ref": 1000.0, "curvature": 2.0, "curvature_rate": 10.0,
}
PREVIEW_BOUND = 2.0  # [1/m]
SPEED_PREVIEW_BOUND = 100.0  # [m/s]

SCALAR_FIELDS: tuple[str, ...] = (
    "e_y", "e_phi", "e_y_dot", "e_phi_dot", "v_x", "v_y", "yaw_rate", "road_wheel_angle",
    "target_speed", "yaw_rate_ref", "yaw_acc_ref", "curvature", "curvature_rate",
)
N_SCALARS = len(SCALAR_FIELDS)
"""Number of scalar fields; the curvature preview starts at this index in every layout."""

NOISY_FIELDS: tuple[str, ...] = (
    "e_y", "e_phi", "e_y_dot", "e_phi_dot", "v_x", "v_y", "yaw_rate", "road_wheel_angle")
"""The measured fields that ``reset(options={"sensor_noise": k})`` perturbs (``EnvConfig.noise_std`` order)."""
NOISY_INDICES: tuple[int, ...] = tuple(SCALAR_FIELDS.index(name) for name in NOISY_FIELDS)


@documented
@dataclass(frozen=True)
class ObservationLayout:
    """Named positions in the flat observation vector (see the module docstring for units)."""

    n_preview: int = ranged(20, ge=1, le=200, integer=True)
    preview_dt_s: float = ranged(0.1, gt=0.0, le=1.0, unit="s")
    preview_min_speed_mps: float = ranged(2.0, gt=0.0, le=20.0, unit="m/s")
    n_speed_preview: int = ranged(0, ge=0, le=200, integer=True)
    speed_preview_dt_s: float = ranged(0.2, gt=0.0, le=1.0, unit="s")

    def __post_init__(self) -> None:
        validate(self)

    # Scalar indices as attributes (``OBS.E_Y`` = ``OBS.index("e_y")``: the upper-cased field names, in
    # SCALAR_FIELDS order; stable across layouts because the preview comes last).
    (E_Y, E_PHI, E_Y_DOT, E_PHI_DOT, V_X, V_Y, YAW_RATE, ROAD_WHEEL_ANGLE, TARGET_SPEED, YAW_RATE_REF, YAW_ACC_REF,
     CURVATURE, CURVATURE_RATE) = range(N_SCALARS)

    @property
    def n_scalars(self) -> int:
        """Number of scalar fields before the preview."""
        return N_SCALARS

    @property
    def size(self) -> int:
        """Length of the observation vector."""
        return self.n_scalars + self.n_preview + self.n_speed_preview

    @property
    def preview(self) -> slice:
        """Slice of the curvature preview samples."""
        return slice(self.n_scalars, self.n_scalars + self.n_preview)

    @property
    def speed_preview(self) -> slice:
        """Slice of the reference-speed preview samples (the last entries)."""
        return slice(self.n_scalars + self.n_preview, self.size)

    @property
    def names(self) -> tuple[str, ...]:
        """Name of every entry: the scalars, ``kappa_preview_k`` (k = 1..n_preview), ``v_ref_preview_j``
        (j = 1..n_speed_preview)."""
        return (SCALAR_FIELDS + tuple(f"kappa_preview_{k}" for k in range(1, self.n_preview + 1))
                + tuple(f"v_ref_preview_{j}" for j in range(1, self.n_speed_preview + 1)))

    def index(self, name: str) -> int:
        """Index of a named entry; ``KeyError`` listing the valid names if unknown."""
        try:
            return self.names.index(name)
        except ValueError:
            speed = f", v_ref_preview_1..{self.n_speed_preview}" if self.n_speed_preview else ""
            raise KeyError(f"unknown observation field {name!r}; valid: {', '.join(SCALAR_FIELDS)}, "
                           f"kappa_preview_1..{self.n_preview}{speed}") from None

    def preview_distances(self, v_x: np.ndarray | float) -> np.ndarray:
        """Look-ahead distances [m] of the preview samples; shape (..., n_preview)."""
        v = np.maximum(np.asarray(v_x, dtype=np.float64), self.preview_min_speed_mps)
        k = np.arange(1, self.n_preview + 1, dtype=np.float64) * self.preview_dt_s
        return v[..., None] * k

    def speed_preview_distances(self, v_x: np.ndarray | float) -> np.ndarray:
        """Look-ahead distances [m] of the reference-speed preview samples; shape (..., n_speed_preview)."""
        v = np.maximum(np.asarray(v_x, dtype=np.float64), self.preview_min_speed_mps)
        j = np.arange(1, self.n_speed_preview + 1, dtype=np.float64) * self.speed_preview_dt_s
        return v[..., None] * j

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) float32 arrays of the observation box."""
        high = np.array([SCALAR_BOUNDS[n] for n in SCALAR_FIELDS] + [PREVIEW_BOUND] * self.n_preview
                        + [SPEED_PREVIEW_BOUND] * self.n_speed_preview, dtype=np.float32)
        return -high, high

    def as_dict(self) -> dict[str, int]:
        """Name -> index mapping."""
        return {n: i for i, n in enumerate(self.names)}


OBS = ObservationLayout(n_speed_preview=10)
"""The default layout used by every registered env (43 entries: 13 scalars, 20 curvature and 10 speed samples)."""
