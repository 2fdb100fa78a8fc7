"""The observation layout shared by every env, policy and agent, derived from one field table.

Policies must never hard-code positions: use ``OBS.index("e_y")`` or ``OBS.E_Y`` / ``OBS.preview``.
All entries are raw SI units (m, rad, s); RL code normalises if it wants (VecNormalize or the shipped agents'
own normalisation).

``SCALARS`` is the one table of the scalar fields (``ObservationField``: name, unit, bound of the observation box,
sensor-noise standard deviation at ``sensor_noise = 1``, fixed RL scale, meaning); ``CURVATURE_PREVIEW`` and
``SPEED_PREVIEW`` are the rows of the two preview series. Everything else is derived from them: the field order and
the index attributes (``OBS.E_Y``), the box (``ObservationLayout.bounds``), the noisy fields and their default
noise (``NOISY_FIELDS``, ``DEFAULT_NOISE_STD``: ``EnvConfig.noise_std``), the agents' fixed scaling
(``agents.obs_scaling``) and the table below. Adding a scalar field is one row here plus the line that computes it
in ``envs.kernels.write_scalar_fields``.

Scalar fields (in this order; bound: the box is +- bound; noise: std at ``sensor_noise = 1``, - = not measured;
centre, scale: the agents' fixed scaling (x - centre) / scale):

{table}

Then ``n_preview`` curvature samples kappa(s* + d_k) [1/m] at the look-ahead distances
``d_k = max(v_x, preview_min_speed_mps) * k * preview_dt_s`` for k = 1..n_preview (default: 20 samples every
0.1 s, i.e. two seconds of travel). ``OBS.preview_distances(v_x)`` returns those distances.

Then, at the END (so that no earlier index moves), ``n_speed_preview`` samples of the reference speed
v_ref(s* + d_j) [m/s] named ``v_ref_preview_j``, at ``d_j = max(v_x, preview_min_speed_mps) * j *
speed_preview_dt_s`` for j = 1..n_speed_preview (``OBS``: 10 samples every 0.2 s, two seconds of travel;
``ObservationLayout()`` has none, the 33-entry layout of the shipped agents). ``target_speed`` is the reference
speed now (constant on the paper scenarios, v_ref(s*) on a track with a speed profile).

Then, only when ``tracking_errors`` is set (the layout of the longitudinal control modes ``steer_accel`` and
``steer_rate_accel``, see ``envs.control``), the two rows of ``TRACKING_ERRORS`` at the very end: ``speed_error``
e_v = v_x - v_ref [m/s] and ``time_error`` e_t [s] against the reference's time law (``envs.kernels``). Without it
(every registered id's default) the layout is unchanged.

Every accepted setting keeps the observation inside the box: reference speeds are capped at
``tracks.path.MAX_V_REF_MPS`` (the speed fields' bound) and a loaded track whose fitted curvature or curvature rate
leaves the box is refused by the loader (``tracks.path.MAX_CURVATURE_PER_M``, ``MAX_CURVATURE_RATE_PER_M2``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks.path import MAX_CURVATURE_PER_M, MAX_CURVATURE_RATE_PER_M2, MAX_V_REF_MPS


@dataclass(frozen=True)
class ObservationField:
    """One row of the observation table: an entry (or, with ``series``, a name prefix of numbered samples).

    ``bound``: the box is [-bound, bound] in ``unit``; ``noise_std``: sensor-noise standard deviation at
    ``sensor_noise = 1`` (None: the field is computed from the reference, not measured, and gets no noise);
    ``centre``, ``scale``: the fixed RL scaling ``(x - centre) / scale`` (``agents.obs_scaling``).
    """

    name: str
    unit: str
    bound: float
    noise_std: float | None
    centre: float
    scale: float
    doc: str
    series: bool = False

    def __post_init__(self) -> None:
        if not self.name.isidentifier() or (self.series and not self.name.endswith("_")):
            raise ValueError(f"ObservationField.name must be an identifier (a series' ending in '_'): {self.name!r}")
        if not (math.isfinite(self.bound) and self.bound > 0.0):
            raise ValueError(f"ObservationField {self.name}: bound must be finite and > 0 (got {self.bound!r})")
        if self.noise_std is not None and not (0.0 <= self.noise_std <= self.bound):
            raise ValueError(f"ObservationField {self.name}: noise_std must be None or in [0, bound] "
                             f"(got {self.noise_std!r})")
        if not (math.isfinite(self.centre) and abs(self.centre) <= self.bound and self.scale > 0.0
                and math.isfinite(self.scale)):
            raise ValueError(f"ObservationField {self.name}: need |centre| <= bound and a finite scale > 0 "
                             f"(got centre {self.centre!r}, scale {self.scale!r})")


# The box's bounds are generous physical limits (the envs terminate long before: |e_y| beyond the road half width,
# |e_phi| > pi/2); the speed and curvature bounds are the limits the track settings and loader enforce.
SCALARS: tuple[ObservationField, ...] = (
    ObservationField("e_y", "m", 100.0, 0.02, 0.0, 0.25,
                     "lateral error of the CG from its projection on the path, LEFT-positive"),
    ObservationField("e_phi", "rad", 4.0, 0.005, 0.0, 0.1, "heading error wrap(psi - psi_ref) in (-pi, pi]"),
    ObservationField("e_y_dot", "m/s", 100.0, 0.02, 0.0, 1.0,
                     "v_x sin(e_phi) + v_y cos(e_phi)  (paper eq. 8, exact at the projection)"),
    ObservationField("e_phi_dot", "rad/s", 50.0, 0.005, 0.0, 0.2, "r - psi_ref_dot"),
    ObservationField("v_x", "m/s", MAX_V_REF_MPS, 0.05, 15.0, 10.0, "longitudinal body-frame speed"),
    ObservationField("v_y", "m/s", 100.0, 0.02, 0.0, 0.5, "lateral body-frame speed (left-positive)"),
    ObservationField("yaw_rate", "rad/s", 50.0, 0.005, 0.0, 0.3, "r, counter-clockwise positive"),
    ObservationField("road_wheel_angle", "rad", 2.0, 0.002, 0.0, 0.2,
                     "current (actuator output) front road-wheel angle, left-positive"),
    ObservationField("target_speed", "m/s", MAX_V_REF_MPS, None, 15.0, 10.0, "the inner speed loop's set point"),
    ObservationField("yaw_rate_ref", "rad/s", 50.0, None, 0.0, 0.3, "psi_ref_dot = kappa(s*) * s_dot"),
    ObservationField("yaw_acc_ref", "rad/s^2", 1000.0, None, 0.0, 1.0,
                     "psi_ref_ddot = kappa'(s*) * s_dot^2 + kappa(s*) * a_x"),
    ObservationField("curvature", "1/m", MAX_CURVATURE_PER_M, None, 0.0, 0.02,
                     "kappa(s*) at the projection point (left turn positive)"),
    ObservationField("curvature_rate", "1/m^2", MAX_CURVATURE_RATE_PER_M2, None, 0.0, 0.005,
                     "d kappa / d s at the projection point"),
)
"""The scalar fields, in observation order (the one table; see the module docstring)."""

CURVATURE_PREVIEW = ObservationField("kappa_preview_", "1/m", MAX_CURVATURE_PER_M, None, 0.0, 0.02,
                                     "path curvature kappa(s* + d_k) ahead, k = 1..n_preview", series=True)
SPEED_PREVIEW = ObservationField("v_ref_preview_", "m/s", MAX_V_REF_MPS, None, 15.0, 10.0,
                                 "reference speed v_ref(s* + d_j) ahead, j = 1..n_speed_preview", series=True)
SERIES: tuple[ObservationField, ...] = (CURVATURE_PREVIEW, SPEED_PREVIEW)
"""The preview series, in observation order after the scalars."""
TRACKING_ERRORS: tuple[ObservationField, ...] = (
    ObservationField("speed_error", "m/s", 2.0 * MAX_V_REF_MPS, None, 0.0, 2.0,
                     "e_v = v_x - v_ref(s*), positive = faster than the reference"),
    ObservationField("time_error", "s", 3600.0, None, 0.0, 2.0,
                     "e_t = t - (T(s0 + progress) - T(s0)) against the reference's time law T, positive = behind it"),
)
"""The longitudinal tracking errors appended at the very end with ``ObservationLayout(tracking_errors=True)`` (the
layout of the ``steer_accel`` and ``steer_rate_accel`` control modes, ``envs.control``)."""

SCALAR_FIELDS: tuple[str, ...] = tuple(f.name for f in SCALARS)
N_SCALARS = len(SCALAR_FIELDS)
"""Number of scalar fields; the curvature preview starts at this index in every layout."""
SCALAR_BOUNDS: dict[str, float] = {f.name: f.bound for f in SCALARS}
"""Field name -> bound of the observation box (+- bound); the env saturates each scalar field there
(``envs.kernels.write_scalar_fields``)."""
PREVIEW_BOUND = CURVATURE_PREVIEW.bound  # [1/m]
SPEED_PREVIEW_BOUND = SPEED_PREVIEW.bound  # [m/s]



def noise_columns(rows: tuple[ObservationField, ...]) -> tuple[tuple[str, ...], tuple[float, ...]]:
    """(names, standard deviations at ``sensor_noise = 1``) of the measured rows, in table order."""
    noisy = tuple(f for f in rows if f.noise_std is not None)
    return tuple(f.name for f in noisy), tuple(float(f.noise_std) for f in noisy)  # type: ignore[arg-type]


def scale_columns(rows: tuple[ObservationField, ...]) -> dict[str, tuple[float, float]]:
    """Name (a series' prefix) -> (centre, scale) of the fixed RL scaling, in the rows' units."""
    return {f.name: (f.centre, f.scale) for f in rows}


NOISY_FIELDS, DEFAULT_NOISE_STD = noise_columns(SCALARS)
"""The measured fields that ``reset(options={"sensor_noise": k})`` perturbs (``EnvConfig.noise_std`` order), and
the default ``EnvConfig.noise_std``: each one's standard deviation at ``sensor_noise = 1`` (SI units)."""
NOISY_INDICES: tuple[int, ...] = tuple(SCALAR_FIELDS.index(name) for name in NOISY_FIELDS)


def field_table(rows: tuple[ObservationField, ...] = SCALARS) -> str:
    """The reStructuredText table of ``rows`` (name, unit, bound, noise, RL centre and scale, meaning), as in the
    module docstring."""
    head = ("name", "unit", "bound", "noise", "centre", "scale", "meaning")
    body = [(f.name, f.unit, f"{f.bound:g}", "-" if f.noise_std is None else f"{f.noise_std:g}", f"{f.centre:g}",
             f"{f.scale:g}", f.doc) for f in rows]
    widths = [max(len(r[c]) for r in (head, *body)) for c in range(len(head))]
    rule = "  ".join("=" * w for w in widths)

    def line(cells: tuple[str, ...]) -> str:
        return "  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)).rstrip()

    return "\n".join([rule, line(head), rule, *(line(r) for r in body), rule])


__doc__ = __doc__.replace("{table}", field_table())


@documented
@dataclass(frozen=True)
class ObservationLayout:
    """Named positions in the flat observation vector (see the module docstring for units)."""

    n_preview: int = ranged(20, ge=1, le=200, integer=True)
    preview_dt_s: float = ranged(0.1, gt=0.0, le=1.0, unit="s")
    preview_min_speed_mps: float = ranged(2.0, gt=0.0, le=20.0, unit="m/s")
    n_speed_preview: int = ranged(0, ge=0, le=200, integer=True)
    speed_preview_dt_s: float = ranged(0.2, gt=0.0, le=1.0, unit="s")
    tracking_errors: bool = False

    def __post_init__(self) -> None:
        validate(self)
        if not isinstance(self.tracking_errors, (bool, np.bool_)):
            raise ValueError(f"ObservationLayout.tracking_errors must be a bool (got {self.tracking_errors!r})")

    @property
    def n_scalars(self) -> int:
        """Number of scalar fields before the preview."""
        return N_SCALARS

    @property
    def size(self) -> int:
        """Length of the observation vector."""
        return self.n_scalars + self.n_preview + self.n_speed_preview + self.n_tracking

    @property
    def n_tracking(self) -> int:
        """Number of longitudinal tracking-error fields at the end (``TRACKING_ERRORS``; 0 without them)."""
        return len(TRACKING_ERRORS) if self.tracking_errors else 0

    @property
    def preview(self) -> slice:
        """Slice of the curvature preview samples."""
        return slice(self.n_scalars, self.n_scalars + self.n_preview)

    @property
    def speed_preview(self) -> slice:
        """Slice of the reference-speed preview samples (the last entries but the tracking errors)."""
        return slice(self.n_scalars + self.n_preview, self.size - self.n_tracking)

    @property
    def names(self) -> tuple[str, ...]:
        """Name of every entry: the scalars, ``kappa_preview_k`` (k = 1..n_preview), ``v_ref_preview_j``
        (j = 1..n_speed_preview), then ``speed_error`` and ``time_error`` with ``tracking_errors``."""
        return (SCALAR_FIELDS + tuple(f"{CURVATURE_PREVIEW.name}{k}" for k in range(1, self.n_preview + 1))
                + tuple(f"{SPEED_PREVIEW.name}{j}" for j in range(1, self.n_speed_preview + 1))
                + tuple(f.name for f in TRACKING_ERRORS[:self.n_tracking]))

    def index(self, name: str) -> int:
        """Index of a named entry; ``KeyError`` listing the valid names if unknown."""
        try:
            return self.names.index(name)
        except ValueError:
            speed = f", {SPEED_PREVIEW.name}1..{self.n_speed_preview}" if self.n_speed_preview else ""
            track = "".join(f", {f.name}" for f in TRACKING_ERRORS[:self.n_tracking])
            raise KeyError(f"unknown observation field {name!r}; valid: {', '.join(SCALAR_FIELDS)}, "
                           f"{CURVATURE_PREVIEW.name}1..{self.n_preview}{speed}{track}") from None

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
        high = np.array([f.bound for f in self.fields()], dtype=np.float32)
        return -high, high

    def fields(self) -> tuple[ObservationField, ...]:
        """The table row of every entry, in observation order (a series' row repeated per sample)."""
        return (SCALARS + (CURVATURE_PREVIEW,) * self.n_preview + (SPEED_PREVIEW,) * self.n_speed_preview
                + TRACKING_ERRORS[:self.n_tracking])

    def as_dict(self) -> dict[str, int]:
        """Name -> index mapping."""
        return {n: i for i, n in enumerate(self.names)}


for _index, _field in enumerate(SCALARS):  # OBS.E_Y = OBS.index("e_y"): the upper-cased names, stable per layout
    setattr(ObservationLayout, _field.name.upper(), _index)
del _index, _field

OBS = ObservationLayout(n_speed_preview=10)
"""The default layout used by every registered env (43 entries: 13 scalars, 20 curvature and 10 speed samples)."""
