"""Arc-length parameterised, C^2-smooth centre-line (``Path``): a uniformly sampled table (schema in ``table``)
with numpy interpolation and projection (``interpolation``), built by curvature integration (``integration``) or a
spline fit of points (``fitting``).

Conventions (ISO 8855): global X, Y, Z up; heading psi counter-clockwise from +X; curvature kappa > 0 for a left
turn; lateral error e_y LEFT-positive at the projection s* of the point onto the path. The numba versions used by
the env live in ``kernels`` (imported lazily, never by this module).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.integration import (
    ElevationLike,
    Profile1D,
    derivative_fd,
    elevation_columns,
    integrate_curvature,
)
from vtrack_gym.tracks.interpolation import interp, interp_linear, project, wrap_angle, wrap_s
from vtrack_gym.tracks.profiles import CurvatureProfile
from vtrack_gym.tracks.table import CLOSURE_TOL_M, DEFAULT_DS_M, PathSample, Projection, close_exactly, uniform_grid

__all__ = ["DEFAULT_DS_M", "ElevationLike", "Gate", "Path", "PathSample", "Profile1D", "Projection", "wrap_angle"]

MAX_HALF_WIDTH_M = 100.0        # per-station half widths beyond this are not a road [m]
MAX_V_REF_MPS = 100.0           # reference speeds beyond this (360 km/h) are not a car's; the bound of the
                                # observation's speed fields [m/s]
MAX_CURVATURE_PER_M = 2.0       # |kappa| beyond this (a 0.5 m radius) is a kink, not a road; the bound of the
                                # observation's curvature fields [1/m]
MAX_CURVATURE_RATE_PER_M2 = 10.0  # |d kappa / d s| beyond this is a kink; the observation's bound [1/m^2]
MIN_V_REF_MPS = 1.0             # set speeds of a profile / a file's speed column below this are a standstill [m/s]


@dataclass(frozen=True)
class Gate:
    """A cone gate: the lane section s in [s_start_m, s_end_m] [m] along the path, with lane boundaries y_right_m <
    y_left_m [m] as lateral offsets from the centre-line (left-positive, like e_y).

    With ``anchor`` = (x [m], y [m], psi [rad]) the lane is instead a fixed straight rectangle (the cone lines of a
    test track): it starts at the anchor point, runs ``length_m`` [m] (default s_end_m - s_start_m) along the
    heading psi, and y_left_m / y_right_m are offsets from the line through the anchor; s_start_m / s_end_m are then
    the stations of the path where it enters and leaves the lane. Use it when the centre-line curves
    inside the lane; without an anchor the centre-line must be straight there for the boundaries to be straight.
    """

    s_start_m: float
    s_end_m: float
    y_left_m: float
    y_right_m: float
    name: str = ""
    anchor: tuple[float, float, float] | None = None
    length_m: float | None = None

    def __post_init__(self) -> None:
        for name in ("s_start_m", "s_end_m", "y_left_m", "y_right_m"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"Gate.{name} must be a finite number (got {value!r})")
        if self.anchor is not None:
            anchor = tuple(float(v) for v in self.anchor)
            if len(anchor) != 3 or not all(math.isfinite(v) for v in anchor):
                raise ValueError(f"Gate.anchor must be (x_m, y_m, psi_rad), 3 finite numbers (got {self.anchor!r})")
            object.__setattr__(self, "anchor", anchor)
        if self.length_m is not None and (self.anchor is None or not (math.isfinite(self.length_m)
                                                                        and self.length_m > 0.0)):
            raise ValueError(f"Gate.length_m must be > 0 m and needs an anchor (got {self.length_m!r})")
        if self.s_end_m <= self.s_start_m:
            raise ValueError(f"Gate.s_end_m must be > s_start_m (got {self.s_end_m} <= {self.s_start_m})")
        if self.y_left_m <= self.y_right_m:
            raise ValueError(f"Gate.y_left_m must be > y_right_m (got {self.y_left_m} <= {self.y_right_m})")

    @property
    def width_m(self) -> float:
        """Lane width y_left_m - y_right_m [m]."""
        return self.y_left_m - self.y_right_m

    @property
    def lane_length_m(self) -> float:
        """Length of the lane [m]: ``length_m`` if given, else s_end_m - s_start_m."""
        return self.s_end_m - self.s_start_m if self.length_m is None else float(self.length_m)


@dataclass(frozen=True, eq=False)
class Path:
    """Arc-length parameterised centre-line (see the module docstring for the table layout and conventions).

    ``table`` (n, 8) float64 [see COL_*], ``ds_m`` sample spacing [m], ``length_m`` = (n - 1) ds_m [m] (derived),
    ``closed`` (s wraps modulo length_m), ``half_width_m`` drivable half width either side of the centre-line [m]
    (off-road termination where no per-station widths are given), ``name``, ``version`` and ``gates`` (cone gates,
    e.g. of the double lane change). Optional per-row data on the same s grid: ``widths_m`` (n, 2) the drivable half
    widths LEFT and RIGHT of the centre-line [m] (query :meth:`half_widths`), ``v_ref_mps`` (n,) a reference speed
    [m/s] (e.g. a racing line's speed column; used by ``speed_profiles.FileSpeed``). ``source_sha256``: the SHA-256
    (64 lowercase hex digits) of the file bytes the path was read from (``load_track_csv`` sets it; rows record it
    as the driven content), None otherwise. ``cones_m`` (K, 3): the cones lining a cone-lined track (x, y [m],
    radius [m]; ``tracks.cones`` sets them), judged as discs by ``track_limits=``, None otherwise. Closed paths
    repeat the first row's values in the last row. Arrays are copied and made read-only; equality is identity.
    """

    table: np.ndarray = field(repr=False)
    ds_m: float
    closed: bool = False
    half_width_m: float = 3.5
    name: str = "path"
    version: str = "1"
    gates: tuple[Gate, ...] = ()
    widths_m: np.ndarray | None = field(default=None, repr=False)
    v_ref_mps: np.ndarray | None = field(default=None, repr=False)
    source_sha256: str | None = field(default=None, repr=False)
    cones_m: np.ndarray | None = field(default=None, repr=False)
    length_m: float = field(init=False)

    def __post_init__(self) -> None:
        table = np.array(self.table, dtype=np.float64, order="C", copy=True)
        if table.ndim != 2 or table.shape[1] != tb.N_COLS:
            raise ValueError(f"Path.table must have shape (n, {tb.N_COLS}) (got {table.shape})")
        if table.shape[0] < 4:
            raise ValueError(f"Path.table must have >= 4 rows (got {table.shape[0]})")
        if not np.all(np.isfinite(table)):
            raise ValueError("Path.table must be finite (found NaN or inf)")
        ds = self.ds_m
        if not isinstance(ds, (int, float)) or not math.isfinite(ds) or ds <= 0.0:
            raise ValueError(f"Path.ds_m must be > 0 (got {ds!r})")
        if not isinstance(self.closed, (bool, np.bool_)):
            raise ValueError(f"Path.closed must be a bool (got {self.closed!r})")
        hw = self.half_width_m
        if not isinstance(hw, (int, float)) or not math.isfinite(hw) or hw <= 0.0:
            raise ValueError(f"Path.half_width_m must be > 0 (got {hw!r})")
        if not isinstance(self.name, str) or not isinstance(self.version, str):
            raise ValueError("Path.name and Path.version must be str")
        sha = self.source_sha256
        if sha is not None and not (isinstance(sha, str) and len(sha) == 64 and set(sha) <= set("0123456789abcdef")):
            raise ValueError(f"Path.source_sha256 must be None or 64 lowercase hex digits (got {sha!r:.80})")
        length = (table.shape[0] - 1) * float(ds)
        if self.closed:
            gap = math.hypot(table[-1, tb.COL_X] - table[0, tb.COL_X], table[-1, tb.COL_Y] - table[0, tb.COL_Y])
            turns = (table[-1, tb.COL_PSI] - table[0, tb.COL_PSI]) / (2.0 * math.pi)
            if gap > CLOSURE_TOL_M or abs(turns - round(turns)) * 2.0 * math.pi > CLOSURE_TOL_M:
                raise ValueError("Path.table of a closed path must end where it starts (|dX, dY| <= "
                                 f"{CLOSURE_TOL_M} m, dpsi a multiple of 2 pi; got gap {gap:.3g} m, "
                                 f"dpsi = {turns:.6f} x 2 pi)")
        gates = tuple(self.gates)
        for k, g in enumerate(gates):
            if not isinstance(g, Gate):
                raise ValueError(f"Path.gates[{k}] must be a Gate (got {type(g).__name__})")
            if g.s_start_m < 0.0 or g.s_end_m > length + 1e-9:
                raise ValueError(f"Path.gates[{k}] must lie within [0, {length}] m (got [{g.s_start_m}, {g.s_end_m}])")
        cones = self._cones()
        widths = self._row_data("widths_m", table.shape[0], 2, 0.0, MAX_HALF_WIDTH_M, "m")
        v_ref = self._row_data("v_ref_mps", table.shape[0], 0, 0.0, MAX_V_REF_MPS, "m/s")
        table.flags.writeable = False
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "widths_m", widths)
        object.__setattr__(self, "v_ref_mps", v_ref)
        object.__setattr__(self, "cones_m", cones)
        object.__setattr__(self, "ds_m", float(ds))
        object.__setattr__(self, "closed", bool(self.closed))
        object.__setattr__(self, "half_width_m", float(hw))
        object.__setattr__(self, "gates", gates)
        object.__setattr__(self, "length_m", length)

    def _cones(self) -> np.ndarray | None:
        """Validated read-only copy of ``cones_m`` (K, 3): x, y [m] and radius in (0, 1] m, or None."""
        if self.cones_m is None:
            return None
        cones = np.array(self.cones_m, dtype=np.float64, order="C", copy=True)
        if cones.ndim != 2 or cones.shape[1] != 3 or not np.all(np.isfinite(cones)):
            raise ValueError(f"Path.cones_m must be a finite (K, 3) array: x, y, radius [m] (got {cones.shape})")
        if np.any((cones[:, 2] <= 0.0) | (cones[:, 2] > 1.0)):
            raise ValueError("Path.cones_m radii must be in (0, 1] m")
        cones.flags.writeable = False
        return cones

    def _row_data(self, name: str, n: int, width: int, low: float, high: float, unit: str) -> np.ndarray | None:
        """Validated read-only copy of the optional per-row array ``name`` (shape (n,) or (n, width)), or None."""
        value = getattr(self, name)
        if value is None:
            return None
        arr = np.array(value, dtype=np.float64, order="C", copy=True)
        shape = (n, width) if width else (n,)
        if arr.shape != shape:
            raise ValueError(f"Path.{name} must have shape {shape}, one row per table row (got {arr.shape})")
        bad = ~(np.isfinite(arr) & (arr > low) & (arr <= high))
        if np.any(bad):
            row = int(np.argwhere(bad)[0][0])
            raise ValueError(f"Path.{name} must be in ({low}, {high}] {unit} (row {row}: {arr[row]})")
        if self.closed and not np.allclose(arr[0], arr[-1], rtol=0.0, atol=1e-9):
            raise ValueError(f"Path.{name} of a closed path must repeat its first row in the last row "
                             f"(got {arr[0]} and {arr[-1]})")
        arr.flags.writeable = False
        return arr

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle through the constructor (re-validates; the restored arrays are read-only again), every field
        included: a copy keeps the ``source_sha256`` of the bytes it was built from."""
        return (type(self), (self.table, self.ds_m, self.closed, self.half_width_m, self.name, self.version,
                             self.gates, self.widths_m, self.v_ref_mps, self.source_sha256, self.cones_m))

    # ----------------------------------------------------------------------------------------------- constructors
    @classmethod
    def from_curvature(cls, kappa: CurvatureProfile | Sequence[tuple[float, float]] | Profile1D,
                       length_m: float | None = None, *, dkappa: Callable[[np.ndarray], np.ndarray] | None = None,
                       elevation: ElevationLike | Callable[[np.ndarray], np.ndarray] | None = None,
                       x0_m: float = 0.0, y0_m: float = 0.0, psi0_rad: float = 0.0, ds_m: float = DEFAULT_DS_M,
                       closed: bool = False, half_width_m: float = 3.5, name: str = "path", version: str = "1",
                       gates: tuple[Gate, ...] = ()) -> Path:
        """Integrate heading and position from a curvature profile.

        ``kappa`` is a :class:`CurvatureProfile` (exact integration, analytic dkappa/ds), a sequence of
        ``(length_m, kappa_end_per_m)`` segments starting from kappa = 0 (see ``CurvatureProfile.from_segments``)
        or any vectorised callable kappa(s) [1/m] (then ``dkappa`` [1/m^2] is taken from the callable ``dkappa``
        or a 4th-order finite difference with h = 1 mm, so kappa must accept s slightly outside [0, length_m]).
        ``length_m`` [m]
        defaults to the profile length. ``elevation`` is None (flat), an :class:`ElevationLike` or a callable z(s)
        [m]. Start pose (x0_m, y0_m) [m], psi0_rad [rad]. The spacing is the largest value <= ``ds_m`` [m] that
        divides the length. A closed path must close within 1e-6 m and a multiple of 2 pi in heading (else
        ValueError); the residual round-off is spread linearly along s so that it closes exactly.
        """
        knots = np.zeros(0)
        if isinstance(kappa, (list, tuple)):
            kappa = CurvatureProfile.from_segments(0.0, kappa)
        if isinstance(kappa, CurvatureProfile):
            if length_m is None:
                length_m = kappa.length_m
            knots = np.asarray(kappa.knots_m, dtype=float)
            if dkappa is None:
                dkappa = kappa.dkappa
            kappa_fn: Callable[[np.ndarray], np.ndarray] = kappa.kappa
        elif callable(kappa):
            kappa_fn = kappa
        else:
            raise ValueError(f"kappa must be a CurvatureProfile or a callable (got {type(kappa).__name__})")
        if length_m is None:
            raise ValueError("length_m is required when kappa is a plain callable")
        n, ds = uniform_grid(float(length_m), float(ds_m))
        s = np.arange(n) * ds

        def kap(v: np.ndarray) -> np.ndarray:
            return np.asarray(kappa_fn(v), dtype=float)

        psi, dx, dy = integrate_curvature(kap, s, knots, float(psi0_rad))
        if dkappa is None:
            dk = derivative_fd(kap, s, 1e-3)
        else:
            dk = np.asarray(dkappa(s), dtype=float)
        table = np.empty((n, tb.N_COLS))
        table[:, tb.COL_X] = x0_m + dx
        table[:, tb.COL_Y] = y0_m + dy
        table[:, tb.COL_PSI] = psi
        table[:, tb.COL_KAPPA] = kap(s)
        table[:, tb.COL_DKAPPA] = dk
        table[:, tb.COL_Z], table[:, tb.COL_GRADE], table[:, tb.COL_ZPP] = elevation_columns(elevation, s)
        if closed:
            close_exactly(table, s, name)
        return cls(table, ds, closed=closed, half_width_m=half_width_m, name=name, version=version, gates=gates)

    @classmethod
    def from_points(cls, x: np.ndarray, y: np.ndarray, z: np.ndarray | None = None, closed: bool = False, *,
                    smoothing_m: float = 0.0, ds_m: float = DEFAULT_DS_M, half_width_m: float = 3.5,
                    name: str = "path", version: str = "1", widths_m: np.ndarray | None = None,
                    v_ref_mps: np.ndarray | None = None) -> Path:
        """Fit a smooth parametric spline (scipy ``splprep``, quintic when >= 8 points, periodic when closed)
        through points x, y [m] (optional elevation z [m]) and resample it uniformly in arc length.

        ``smoothing_m`` [m] is the allowed RMS deviation from the points (0 interpolates). For a closed path do not
        repeat the first point at the end (an exact repeat is dropped). Curvature and its rate come from the
        spline derivatives. Optional per-point ``widths_m`` (m, 2) [left, right half widths, m] and ``v_ref_mps``
        (m,) [m/s] are carried to the table rows by linear interpolation along the points' chord length.
        """
        from vtrack_gym.tracks.fitting import fit_points

        m = np.asarray(x).shape[0] if np.ndim(x) == 1 else -1
        extra = []
        if widths_m is not None:
            w = np.asarray(widths_m, dtype=float)
            if w.shape != (m, 2):
                raise ValueError(f"widths_m must have shape ({m}, 2): left, right per point (got {w.shape})")
            extra.append(w)
        if v_ref_mps is not None:
            v = np.asarray(v_ref_mps, dtype=float)
            if v.shape != (m,):
                raise ValueError(f"v_ref_mps must have shape ({m},), one speed per point (got {v.shape})")
            extra.append(v[:, None])
        fit = fit_points(np.asarray(x, dtype=float), np.asarray(y, dtype=float),
                         None if z is None else np.asarray(z, dtype=float), bool(closed), float(smoothing_m),
                         float(ds_m), np.hstack(extra) if extra else None)
        rows = fit.point_data
        widths = None if widths_m is None or rows is None else rows[:, :2]
        v_ref = None if v_ref_mps is None or rows is None else rows[:, -1]
        return cls(fit.table, fit.ds_m, closed=bool(closed), half_width_m=half_width_m, name=name, version=version,
                   widths_m=widths, v_ref_mps=v_ref)

    # ---------------------------------------------------------------------------------------------------- queries
    @property
    def n_samples(self) -> int:
        """Number of table rows."""
        return int(self.table.shape[0])

    @property
    def s_m(self) -> np.ndarray:
        """Arc length of every row [m]."""
        return np.arange(self.n_samples) * self.ds_m

    def wrap_s(self, s: np.ndarray) -> np.ndarray:
        """Arc length wrapped into [0, length) (closed) or clamped to [0, length] (open) [m]."""
        return wrap_s(np.asarray(s, dtype=float), self.length_m, self.closed)

    def _linear_rows(self, data: np.ndarray, s: np.ndarray | float) -> np.ndarray:
        """Per-row data linearly interpolated at s [m] (wrapped / clamped like the table)."""
        return interp_linear(data, self.ds_m, self.length_m, self.closed, s)

    def half_widths(self, s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Drivable half widths (left [m], right [m]) of the road at arc length(s) s [m].

        Per-station widths where the path has them (``widths_m``), else ``half_width_m`` on both sides. A car is
        off the road when e_y > left or -e_y > right (e_y left-positive).
        """
        s = np.asarray(s, dtype=float)
        if self.widths_m is None:
            full = np.full(s.shape, self.half_width_m)
            return full, full.copy()
        w = self._linear_rows(self.widths_m, s)
        return w[..., 0], w[..., 1]

    def half_widths_rows(self) -> np.ndarray:
        """Drivable half widths (left, right) [m] at every table row, shape (n, 2) (``half_width_m`` if the path
        has no per-station widths): the array an env's compiled step can index like the table."""
        if self.widths_m is None:
            return np.full((self.n_samples, 2), self.half_width_m)
        return np.array(self.widths_m)

    def sample(self, s: np.ndarray | float) -> PathSample:
        """Interpolated columns at arc length(s) s [m] (wrapped for closed, clamped for open paths)."""
        out = interp(self.table, self.ds_m, self.length_m, self.closed, np.asarray(s, dtype=float))
        return PathSample(*(out[..., k] for k in range(tb.N_COLS)))

    def sample_array(self, s: np.ndarray | float) -> np.ndarray:
        """Interpolated columns at s [m] as an array of shape s.shape + (8,) in table column order."""
        return interp(self.table, self.ds_m, self.length_m, self.closed, np.asarray(s, dtype=float))

    def preview(self, s: np.ndarray | float, distances: np.ndarray) -> np.ndarray:
        """Curvature [1/m] at s + d for every s (N,) [m] and preview distance d (K,) [m] -> shape (N, K)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        d = np.atleast_1d(np.asarray(distances, dtype=float))
        out = interp(self.table, self.ds_m, self.length_m, self.closed, s[:, None] + d[None, :])
        return out[..., tb.COL_KAPPA]

    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the centre-line samples [m]."""
        x = self.table[:, tb.COL_X]
        y = self.table[:, tb.COL_Y]
        return float(x.min()), float(x.max()), float(y.min()), float(y.max())

    @cached_property
    def _kdtree(self) -> Any:
        from scipy.spatial import cKDTree

        rows = self.n_samples - 1 if self.closed else self.n_samples
        return cKDTree(self.table[:rows, :2])

    def project(self, x: np.ndarray | float, y: np.ndarray | float, s_guess: np.ndarray | float | None = None,
                window_m: float = 10.0) -> Projection:
        """Closest point s* [m] of the path to each point (x, y) [m], with e_y [m] (left-positive), psi_ref [rad].

        Coarse search over the samples within +- window_m [m] of s_guess [m] (where s_guess is None or negative:
        from the nearest sample, found with a KD-tree), then refinement by exact projection onto the local
        osculating circle (exact on arcs and straights; converges in a few steps on clothoids): the env's
        compiled ``kernels.project_point``.
        """
        x = np.atleast_1d(np.asarray(x, dtype=float))
        y = np.atleast_1d(np.asarray(y, dtype=float))
        x, y = np.broadcast_arrays(x, y)
        shape = x.shape
        x, y = x.ravel(), y.ravel()
        guess = np.full(x.shape, -1.0) if s_guess is None else np.broadcast_to(
            np.asarray(s_guess, dtype=float), shape).ravel().copy()
        glob = guess < 0.0
        if np.any(glob):  # start the kernel's window at the nearest sample
            _, nearest = self._kdtree.query(np.column_stack((x[glob], y[glob])))
            guess[glob] = nearest * self.ds_m
        s, e_y, psi = project(self.table, self.ds_m, self.length_m, self.closed, x, y, guess, float(window_m))
        row = interp(self.table, self.ds_m, self.length_m, self.closed, s)
        return Projection(*(a.reshape(shape) for a in (s, e_y, psi, row[:, tb.COL_KAPPA], row[:, tb.COL_X],
                                                        row[:, tb.COL_Y])))

    def frenet_errors(self, x: np.ndarray, y: np.ndarray, psi: np.ndarray,
                      s_guess: np.ndarray | float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s* [m], e_y [m], e_phi = wrap(psi - psi_ref) in (-pi, pi] [rad]) of poses (x, y, psi)."""
        p = self.project(x, y, s_guess)
        return p.s, p.e_y, wrap_angle(np.asarray(psi, dtype=float) - p.psi_ref)

    def self_intersects(self, clearance_m: float = 0.0) -> bool:
        """True if the centre-line crosses itself; with clearance_m > 0 [m] also if two parts more than
        (pi/2) clearance_m apart along the path come closer than clearance_m (checked on ~1 m spaced samples)."""
        from vtrack_gym.tracks.geometry import polyline_min_gap_violated, polyline_self_intersects

        xy = self.table[:, :2]
        if polyline_self_intersects(xy, self.closed):
            return True
        if clearance_m > 0.0:
            step = max(1, round(1.0 / self.ds_m))
            sub = xy[::step]
            s_sub = np.arange(sub.shape[0]) * step * self.ds_m
            return polyline_min_gap_violated(sub, s_sub, self.length_m if self.closed else None, clearance_m)
        return False

