"""The paper's fuzzy PD speed controller (PD-FLC), batched (paper-math section 7).

Signals (paper-math 7.1): ``e_v = v - v_ref`` [m/s] (times 3.6 if ``speed_error_in_kmh``), ``de_v`` its
first-order filtered time derivative [m/s^2], normalised inputs ``e_hat = clip(G1 e_v, -1, 1)`` and
``de_hat = clip(G2 de_v, -1, 1)``, fuzzy output ``u`` in [-1, 1], ``throttle = clip(G3 max(u, 0), 0, 1)``
(fraction) and ``brake = G4 max(-u, 0)`` [N pedal force].

Fuzzy system (7.2-7.4): five input triangles SM, HSM, NO, HSP, SP (peaks -1, -0.5, 0, 0.5, 1, half-width 0.5;
inputs are clipped so the end triangles act as shoulders), seven output triangles (peaks k/3, k = -3..3,
half-width 1/3, truncated at +-1), the 5x5 rule table ``RULE_TABLE`` (Table 1) and either

* ``"mamdani"`` (default): AND = min, implication = min, aggregation = max, centroid on a 2001-point grid over
  [-1, 1]; range +-0.889; or
* ``"sugeno"``: product AND, output singletons at the peaks, weighted average; range +-1.

Measured properties: Mamdani range +-0.8892; Sugeno differs from the linear PD law
``-clip((2/3)(e_hat + de_hat), -1, 1)`` by at most 1/12 = 0.0833 (at (+-0.75, +-0.75), where Table 1 clips at
level 3; the spec rounds this to 0.08); Mamdani and Sugeno differ by at most 0.222 (near (+-0.82, +-0.82)).
Mamdani is not monotone: where Table 1 clips several rules to level +-3, the max aggregation lets u dip by up
to 0.030 (e.g. de_hat = -0.93: u = 0.776 at e_hat = -0.75 but 0.807 at e_hat = -0.55); the spec's "ripples
<= 0.0067" understates this. The local change per 0.01 step against the trend is at most 0.0028.
``speed_error_in_kmh`` scales e_v only (as the spec says); de_v stays in m/s^2.

``mamdani_direct`` / ``sugeno_direct`` evaluate the inference exactly (slow reference). The controller uses a
precomputed control surface (``control_surface``, cached per method and resolution) and vectorised
interpolation (``pdflc_output``):

* Sugeno: the surface is bilinear in every 0.5 x 0.5 input cell, so bilinear interpolation on any grid that
  contains the multiples of 0.5 is exact (measured max error 4e-16).
* Mamdani: min/max inference puts slope kinks on the diagonals ``e_hat +- de_hat = k/2``, which plain bilinear
  cells straddle (max error 3.9e-3 at 201 x 201, 1.9e-3 at 401 x 401). We therefore split every grid cell into
  two triangles along the kink direction of its 0.25 x 0.25 quadrant and interpolate linearly on the triangles
  (same four corner values as bilinear). Measured max error vs ``mamdani_direct`` at the default 201 x 201 grid:
  8.3e-4 (at all 40 000 cell centres, 10^6 off-grid points and 2 x 10^5 random points; largest near
  (+-1, +-0.5); 99th percentile 1.7e-4), i.e. < 1e-3; 2.2e-4 at 401 x 401.

Building the default Mamdani surface takes about 0.15 s of CPU, once per process (its aggregation compiled,
``pdflc_aggregate``; the numpy level-by-level loop took 0.4 s and gave the same bits).
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from vtrack_gym._ranges import documented, ranged, validate

logger = logging.getLogger(__name__)

INPUT_LABELS = ("SM", "HSM", "NO", "HSP", "SP")
"""Input fuzzy sets, ordered by peak position."""
INPUT_PEAKS = (-1.0, -0.5, 0.0, 0.5, 1.0)
"""Peaks of the five input triangles on the normalised universe [-1, 1]."""
INPUT_HALF_WIDTH = 0.5
"""Half-width of every input triangle (normalised units)."""
OUTPUT_LABELS = ("SM", "TTSM", "HTTSM", "NO", "HTTSP", "TTSP", "SP")
"""Output fuzzy sets for levels -3..3."""
OUTPUT_HALF_WIDTH = 1.0 / 3.0
"""Half-width of every output triangle (normalised units); peaks are at level / 3."""
CENTROID_POINTS = 2001
"""Number of points of the Mamdani centroid grid over [-1, 1]."""
METHODS = ("mamdani", "sugeno")
"""Supported inference methods."""

RULE_TABLE = (
    (3, 3, 2, 1, 0),      # de_v = SM
    (3, 2, 1, 0, -1),     # de_v = HSM
    (2, 1, 0, -1, -2),    # de_v = NO
    (1, 0, -1, -2, -3),   # de_v = HSP
    (0, -1, -2, -3, -3),  # de_v = SP
)
"""Paper Table 1 as output levels -3..3: rows de_v, columns e_v, both ordered SM, HSM, NO, HSP, SP."""


def rule_level(i_e: int, j_de: int) -> int:
    """Closed form of Table 1: output level ``-clip(i_e + j_de, -3, 3)`` for set indices i_e, j_de in -2..2."""
    return -max(-3, min(3, i_e + j_de))


def input_memberships(x: ArrayLike) -> np.ndarray:
    """Memberships of a normalised input in SM..SP, shape ``x.shape + (5,)``; x is clipped to [-1, 1]."""
    xc = np.clip(np.asarray(x, dtype=np.float64), -1.0, 1.0)
    return np.maximum(0.0, 1.0 - np.abs(xc[..., None] - np.asarray(INPUT_PEAKS)) / INPUT_HALF_WIDTH)


def output_memberships(y: ArrayLike) -> np.ndarray:
    """Memberships of an output value y in [-1, 1] in the levels -3..3, shape ``y.shape + (7,)``."""
    yy = np.asarray(y, dtype=np.float64)
    peaks = np.arange(-3, 4) / 3.0
    return np.maximum(0.0, 1.0 - np.abs(yy[..., None] - peaks) / OUTPUT_HALF_WIDTH)


def _level_matrix() -> np.ndarray:
    """Rule output levels indexed ``[i_e, j_de]`` (the transpose of ``RULE_TABLE``)."""
    return np.asarray(RULE_TABLE, dtype=np.int64).T


def _flat_inputs(e_hat: ArrayLike, de_hat: ArrayLike) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """Broadcast, validate and flatten the two normalised inputs."""
    e, de = np.broadcast_arrays(np.asarray(e_hat, dtype=np.float64), np.asarray(de_hat, dtype=np.float64))
    if not (np.isfinite(e).all() and np.isfinite(de).all()):
        raise ValueError("e_hat and de_hat must be finite")
    return e.ravel(), de.ravel(), e.shape


@functools.lru_cache(maxsize=1)
def _centroid_grid() -> tuple[np.ndarray, np.ndarray, tuple[tuple[int, int], ...]]:
    """The centroid grid y, the output memberships on it (7, 2001) and each level's support slice."""
    y = np.linspace(-1.0, 1.0, CENTROID_POINTS)
    tri = np.ascontiguousarray(output_memberships(y).T)
    support = tuple((int(np.flatnonzero(row)[0]), int(np.flatnonzero(row)[-1]) + 1) for row in tri)
    y.setflags(write=False)
    tri.setflags(write=False)
    return y, tri, support


@functools.lru_cache(maxsize=1)
def _centroid_cover() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The centroid grid y and, per point of it, the two output levels over it and their memberships
    (``pdflc_aggregate.grid_cover``)."""
    from vtrack_gym.envs.pdflc_aggregate import grid_cover

    y, tri, support = _centroid_grid()
    levels, tops = grid_cover(tri, support)
    levels.setflags(write=False)
    tops.setflags(write=False)
    return y, levels, tops


def _rule_heights(e: np.ndarray, de: np.ndarray) -> np.ndarray:
    """Mamdani clipping height of each output level (min AND, max over rules), shape (P, 7)."""
    w = np.minimum(input_memberships(e)[:, :, None], input_memberships(de)[:, None, :])
    levels = _level_matrix()
    heights = np.empty((e.size, 7))
    for k in range(-3, 4):
        heights[:, k + 3] = w[:, levels == k].max(axis=1)
    return heights


def mamdani_direct(e_hat: ArrayLike, de_hat: ArrayLike, chunk: int = 1024) -> np.ndarray:
    """Exact Mamdani output u (dimensionless, in [-0.889, 0.889]) for normalised inputs (broadcast).

    Min AND, min implication, max aggregation and the centroid on the 2001-point grid over [-1, 1]: the reference
    for the interpolated ``pdflc_output``. The aggregation runs compiled (``pdflc_aggregate``, about 2.5 us per
    point); the centroid's sums stay numpy's, over blocks of ``chunk`` points.
    """
    from vtrack_gym.envs.pdflc_aggregate import aggregate

    e, de, shape = _flat_inputs(e_hat, de_hat)
    y, levels, tops = _centroid_cover()
    out = np.empty(e.size)
    for start in range(0, e.size, chunk):
        heights = _rule_heights(e[start:start + chunk], de[start:start + chunk])
        mu = np.empty((heights.shape[0], y.size))
        aggregate(heights, levels, tops, mu)
        out[start:start + chunk] = (mu @ y) / mu.sum(axis=1)
    return out.reshape(shape)


def sugeno_direct(e_hat: ArrayLike, de_hat: ArrayLike) -> np.ndarray:
    """Exact Sugeno output u (dimensionless, in [-1, 1]): product AND, singletons at level/3, weighted mean."""
    e, de, shape = _flat_inputs(e_hat, de_hat)
    w = input_memberships(e)[:, :, None] * input_memberships(de)[:, None, :]
    num = np.einsum("pij,ij->p", w, _level_matrix() / 3.0)
    return (num / w.sum(axis=(1, 2))).reshape(shape)


def _check_method_resolution(method: str, resolution: int) -> None:
    """Raise ValueError for an unknown method or a grid that misses the 0.25 kink lines."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS} (got {method!r})")
    if (not isinstance(resolution, int) or isinstance(resolution, bool) or not 9 <= resolution <= 2001
            or (resolution - 1) % 8):
        raise ValueError(f"surface_resolution must be an int in [9, 2001] with (resolution - 1) divisible by 8 "
                         f"(got {resolution!r})")


@functools.lru_cache(maxsize=8)
def control_surface(method: str = "mamdani", resolution: int = 201) -> np.ndarray:
    """Read-only surface ``S[i, j] = u(g_i, g_j)`` on the grid ``g = linspace(-1, 1, resolution)``.

    Axis 0 is e_hat, axis 1 is de_hat. Computed once per (method, resolution) and cached.
    """
    _check_method_resolution(method, resolution)
    g = np.linspace(-1.0, 1.0, resolution)
    e, de = np.meshgrid(g, g, indexing="ij")
    direct = mamdani_direct if method == "mamdani" else sugeno_direct
    surface = direct(e, de)
    surface.setflags(write=False)
    logger.debug("built the %s PD-FLC surface on a %d^2 grid", method, resolution)
    return surface


def _cell(x: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell index in 0..n-2 and local coordinate in [0, 1] of x in [-1, 1] on an n-point grid."""
    pos = (x + 1.0) * (0.5 * (n - 1))
    idx = np.minimum(pos.astype(np.intp), n - 2)
    return idx, pos - idx


def _interpolate(surface: np.ndarray, e: np.ndarray, de: np.ndarray, kink_aligned: bool) -> np.ndarray:
    """Bilinear (or kink-aligned triangle) interpolation of a surface at clipped inputs."""
    n = surface.shape[0]
    i, fx = _cell(e, n)
    j, fy = _cell(de, n)
    f00, f10 = surface[i, j], surface[i + 1, j]
    f01, f11 = surface[i, j + 1], surface[i + 1, j + 1]
    if not kink_aligned:
        return f00 + fx * (f10 - f00) + fy * (f01 - f00) + fx * fy * (f00 - f10 - f01 + f11)
    cells_per_quadrant = (n - 1) // 8
    main = ((i // cells_per_quadrant + j // cells_per_quadrant) % 2) == 0
    # Main diagonal (0,0)-(1,1): kinks on e - de = const; anti-diagonal (1,0)-(0,1): e + de = const.
    lower = fx >= fy
    u_main = np.where(lower, f00 + fx * (f10 - f00) + fy * (f11 - f10), f00 + fy * (f01 - f00) + fx * (f11 - f01))
    below = fx + fy <= 1.0
    u_anti = np.where(below, f00 + fx * (f10 - f00) + fy * (f01 - f00),
                      f11 + (1.0 - fx) * (f01 - f11) + (1.0 - fy) * (f10 - f11))
    return np.where(main, u_main, u_anti)


def pdflc_output(e_hat: ArrayLike, de_hat: ArrayLike, method: str = "mamdani",
                 resolution: int = 201) -> np.ndarray:
    """Fast fuzzy output u (dimensionless) for normalised inputs (broadcast; clipped to [-1, 1]).

    Interpolates ``control_surface(method, resolution)``; max error vs the direct inference is 8.3e-4
    (Mamdani, 201 x 201) and 0 up to rounding (Sugeno).
    """
    surface = control_surface(method, resolution)
    e, de, shape = _flat_inputs(e_hat, de_hat)
    u = _interpolate(surface, np.clip(e, -1.0, 1.0), np.clip(de, -1.0, 1.0), kink_aligned=method == "mamdani")
    return u.reshape(shape)


@documented
@dataclass(frozen=True)
class PDFLCConfig:
    """PD-FLC parameters; defaults are the paper's Table 3 gains (GA-tuned) and the spec's choices."""

    g1: float = ranged(1.3187, gt=0.0)  # e_v gain [1/(m/s)] ([1/(km/h)] with speed_error_in_kmh); e_hat saturates at 1
    g2: float = ranged(0.1, gt=0.0, unit="s^2/m")  # de_v gain [s^2/m]
    g3: float = ranged(0.5225, gt=0.0)  # throttle fraction per unit of positive u [-]
    g4: float = ranged(161.5577, gt=0.0, unit="N")  # brake pedal force per unit of negative u [N]
    # time constant of the de_v low-pass filter [s]; 0 = raw backward difference
    tau_f_s: float = ranged(0.05, ge=0.0, le=10.0, unit="s")
    speed_error_in_kmh: bool = False  # multiply e_v by 3.6 before G1 (if the paper's CarSim used km/h)
    method: str = "mamdani"         # "mamdani" or "sugeno"
    surface_resolution: int = 201   # points per axis of the control surface; (n - 1) % 8 == 0

    def __post_init__(self) -> None:
        validate(self)
        if self.method not in METHODS:
            raise ValueError(f"PDFLCConfig.method must be one of {METHODS} (got {self.method!r})")
        try:
            _check_method_resolution(self.method, self.surface_resolution)
        except ValueError as err:
            raise ValueError(f"PDFLCConfig.{err}") from None


class PDFLC:
    """Batched PD-FLC speed controller for ``n`` cars with a fixed control period ``dt_s`` [s].

    Call it once per control period with the measured and the reference speeds (both (n,) [m/s]); it returns the
    throttle fraction (n,) in [0, 1] and the brake pedal force (n,) [N] >= 0. At most one of them is non-zero.
    The derivative ``de_v`` [m/s^2] is the backward difference of e_v passed through the exact discretisation of
    ``1 / (tau_f s + 1)`` (pole exp(-dt/tau_f)); on the first call after a reset it is 0.
    """

    def __init__(self, config: PDFLCConfig, n: int, dt_s: float) -> None:
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"PDFLC.n must be an int >= 1 (got {n!r})")
        if isinstance(dt_s, bool) or not isinstance(dt_s, (int, float)) or not 0.0 < dt_s <= 1.0:
            raise ValueError(f"PDFLC.dt_s must be in (0, 1] s (got {dt_s!r})")
        self.config = config
        self.n = int(n)
        self.dt_s = float(dt_s)
        self._pole = math.exp(-self.dt_s / config.tau_f_s) if config.tau_f_s > 0.0 else 0.0
        self._surface = control_surface(config.method, config.surface_resolution)
        self._e_prev = np.zeros(self.n)
        self._de = np.zeros(self.n)
        self._fresh = np.ones(self.n, dtype=bool)
        self._v_reset = np.full(self.n, np.nan)
        self._u = np.zeros(self.n)

    @property
    def last_output(self) -> np.ndarray:
        """Copy of the fuzzy output u (n,) of the last call (dimensionless, in [-1, 1])."""
        return self._u.copy()

    @property
    def filtered_derivative(self) -> np.ndarray:
        """Copy of the filtered error derivative de_v (n,) of the last call [m/s^2]."""
        return self._de.copy()

    def reset(self, mask: ArrayLike | None = None, v_now: ArrayLike | None = None) -> None:
        """Forget the derivative memory of the cars selected by ``mask`` ((n,) bool; None = all).

        ``v_now`` [m/s] (scalar or (n,)) optionally primes the memory with the speed at the reset instant: the
        first call then differentiates from it (reference assumed unchanged). Without it the first derivative is 0.
        """
        sel = np.ones(self.n, dtype=bool) if mask is None else np.asarray(mask)
        if sel.shape != (self.n,) or sel.dtype != np.bool_:
            raise ValueError(f"mask must be a bool array of shape ({self.n},) (got {sel.dtype} {sel.shape})")
        self._de[sel] = 0.0
        self._u[sel] = 0.0
        self._fresh[sel] = True
        if v_now is None:
            self._v_reset[sel] = np.nan
            return
        v0 = self._as_vector(v_now, "v_now")
        if not np.isfinite(v0[sel]).all():
            raise ValueError("v_now must be finite")
        self._v_reset[sel] = v0[sel]

    def _as_vector(self, x: ArrayLike, name: str) -> np.ndarray:
        """Broadcast a scalar or (n,) input to a float (n,) array."""
        arr = np.asarray(x, dtype=np.float64)
        if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] not in (1, self.n)):
            raise ValueError(f"{name} must be a scalar or have shape ({self.n},) (got {arr.shape})")
        return np.broadcast_to(arr, (self.n,))

    def __call__(self, v_mps: ArrayLike, v_ref_mps: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Throttle fraction (n,) in [0, 1] and brake pedal force (n,) [N] for speeds v, v_ref [m/s]."""
        v = self._as_vector(v_mps, "v_mps")
        v_ref = self._as_vector(v_ref_mps, "v_ref_mps")
        if not (np.isfinite(v).all() and np.isfinite(v_ref).all()):
            raise ValueError("v_mps and v_ref_mps must be finite")
        cfg = self.config
        e_v = v - v_ref
        primed = self._fresh & np.isfinite(self._v_reset)
        e_prev = np.where(self._fresh, np.where(primed, self._v_reset - v_ref, e_v), self._e_prev)
        raw = (e_v - e_prev) / self.dt_s
        self._de = np.where(self._fresh, 0.0, self._pole * self._de) + (1.0 - self._pole) * raw
        self._e_prev = e_v
        self._fresh[:] = False
        self._v_reset[:] = np.nan
        e_scaled = e_v * 3.6 if cfg.speed_error_in_kmh else e_v
        e_hat = np.clip(cfg.g1 * e_scaled, -1.0, 1.0)
        de_hat = np.clip(cfg.g2 * self._de, -1.0, 1.0)
        self._u = _interpolate(self._surface, e_hat, de_hat, kink_aligned=cfg.method == "mamdani")
        throttle = np.clip(cfg.g3 * np.maximum(self._u, 0.0), 0.0, 1.0)
        brake_n = cfg.g4 * np.maximum(-self._u, 0.0)
        return throttle, brake_n


def speed_loop_throttle_authority(config: PDFLCConfig) -> float:
    """The largest throttle fraction [-] the PD-FLC holds while it follows a profile: ``G3 u`` at a saturated
    speed error (e_hat = -1) and a steady one (de_hat = 0), clipped to 1; the paper's gains: 0.5225 x 2/3 = 0.348.

    Only a speed error that keeps growing (de_v < 0) opens it further, up to ``G3`` x the surface's range (0.465
    Mamdani, 0.5225 Sugeno): a profile that needs more than this lets the car fall ever further behind it. A speed
    profile for the env's speed loop therefore assumes this authority (``powertrain_limits.SPEED_LOOP``)."""
    u = float(np.asarray(pdflc_output(np.array([-1.0]), np.array([0.0]), config.method,
                                      config.surface_resolution))[0])
    return min(max(config.g3 * u, 0.0), 1.0)
