"""Smooth spline fit of centre-line points and uniform arc-length resampling (used by ``Path.from_points``)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.integration import gauss_legendre
from vtrack_gym.tracks.table import close_exactly, uniform_grid

MIN_POINTS = 4
MAX_COORDINATE_M = 1.0e7     # |x|, |y|, |z| up to 10 000 km: UTM northings (< 1e7 m) load as they are
MAX_LENGTH_M = 200_000.0     # longest centre-line accepted (polyline and fitted) [m]
MAX_LENGTH_GROWTH = 1.5      # a fit may not be longer than this x the polyline (smoothing gone wrong)
_NEWTON_ITER = 4
FINE_PER_POINT = 2           # arc-length quadrature intervals per input point (plus 4 per table row)


def check_points(x: np.ndarray, y: np.ndarray, z: np.ndarray | None) -> None:
    """Raise ValueError for malformed centre-line points (shape, count, non-finite, repeated points)."""
    if x.ndim != 1 or y.shape != x.shape or (z is not None and z.shape != x.shape):
        raise ValueError(f"x, y (and z) must be 1-D arrays of equal length (got {x.shape}, {y.shape}"
                         f"{'' if z is None else ', ' + str(z.shape)})")
    if x.size < MIN_POINTS:
        raise ValueError(f"a path needs >= {MIN_POINTS} points (got {x.size})")
    for name, v in (("x", x), ("y", y), ("z", z)):
        if v is not None and not np.all(np.isfinite(v)):
            k = int(np.flatnonzero(~np.isfinite(v))[0])
            raise ValueError(f"point {k}: {name} is not finite ({v[k]})")
    for name, v in (("x", x), ("y", y), ("z", z)):
        if v is not None and float(np.max(np.abs(v))) > MAX_COORDINATE_M:
            k = int(np.argmax(np.abs(v)))
            raise ValueError(f"point {k}: |{name}| = {abs(v[k]):.3g} m exceeds {MAX_COORDINATE_M:.0e} m; fix: "
                             "subtract an offset (e.g. the first point's coordinates) from every point")
    step = np.hypot(np.diff(x), np.diff(y))
    if float(step.sum()) > MAX_LENGTH_M:
        raise ValueError(f"the centre-line is {step.sum():.3g} m long; at most {MAX_LENGTH_M:.0f} m is accepted")
    scale = max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(y))))
    dup = np.flatnonzero(step <= 1e-9 * scale)
    if dup.size:
        k = int(dup[0])
        raise ValueError(f"points {k} and {k + 1} are duplicates ({x[k]}, {y[k]})")


FITPACK_SEARCH_MAX_POINTS = 2000
"""Up to this many points a smoothing fit uses FITPACK's own knot search (its cost grows with the square of the
points: about 1.5 s of CPU at 2,000); beyond, ``smoothing_spline`` finds the knot spacing by bisection."""


def smoothing_spline(fit: Callable[..., tuple[Any, float]], u: np.ndarray, k: int, budget: float) -> Any:
    """A spline of degree ``k`` on the chord parameters ``u`` whose sum of squared residuals is at most ``budget``
    [m^2], in O(n log n) for n points. ``fit(**options)`` runs ``splprep``/``splrep`` with FITPACK's options and
    returns (spline, sum of squared residuals).

    ``budget`` 0 interpolates, and up to ``FITPACK_SEARCH_MAX_POINTS`` points FITPACK chooses the knots itself
    (``s=budget``). Beyond, a least-squares spline with an interior knot at every ``stride``-th point: the widest
    stride whose residuals fit the budget, found by doubling then bisection (each least-squares fit is linear in
    the points); when even every second point leaves too large residuals, the spline interpolates (as FITPACK
    would end with a knot at every point).
    """
    m = u.size
    if budget <= 0.0 or m <= FITPACK_SEARCH_MAX_POINTS:
        return fit(s=budget)[0]

    def residual(stride: int) -> tuple[Any, float]:
        return fit(task=-1, t=u[stride:m - 1:stride])

    widest = max(2, m // (2 * (k + 1)))
    good: tuple[int, Any] | None = None
    bad = widest + 1
    stride = 2
    while stride <= widest:
        tck, fp = residual(stride)
        if fp > budget:
            bad = stride
            break
        good = (stride, tck)
        stride *= 2
    if good is None:
        return fit(s=0.0)[0]
    while bad - good[0] > 1:
        mid = (good[0] + bad) // 2
        tck, fp = residual(mid)
        if fp <= budget:
            good = (mid, tck)
        else:
            bad = mid
    return good[1]


def _splines(pts: list[np.ndarray], u: np.ndarray, k: int, closed: bool, budget: float) -> tuple[Any, Any]:
    """The plan-view spline of ``pts[:2]`` and, with a third column, the elevation spline z(u), each with residuals
    within ``budget`` [m^2] (``smoothing_spline``); the elevation's is None without a z column."""
    from scipy.interpolate import splprep, splrep

    def plane(**options: Any) -> tuple[Any, float]:
        (spline, _), fp, _, _ = splprep(pts[:2], u=u, k=k, per=int(closed), quiet=2, full_output=1, **options)
        return spline, float(fp)

    def elevation(**options: Any) -> tuple[Any, float]:
        spline, fp, _, _ = splrep(u, pts[2], k=k, per=int(closed), quiet=2, full_output=1, **options)
        return spline, float(fp)

    return (smoothing_spline(plane, u, k, budget),
            smoothing_spline(elevation, u, k, budget) if len(pts) > 2 else None)


class Fit(NamedTuple):
    """Result of :func:`fit_points`."""

    table: np.ndarray                  # (n, 8) path table
    ds_m: float                        # row spacing [m]
    point_data: np.ndarray | None      # (n, k) per-point data carried to the rows, or None


def fit_points(x: np.ndarray, y: np.ndarray, z: np.ndarray | None, closed: bool, smoothing_m: float,
               ds_m: float, point_data: np.ndarray | None = None) -> Fit:
    """Path table (n, 8) and spacing [m] of a parametric spline through points x, y [m] (and elevation z [m]).

    Quintic (cubic below 8 points) ``scipy.interpolate.splprep`` spline, periodic when closed, sum of squared
    residuals at most ``n * smoothing_m^2`` (``smoothing_spline``: O(n log n)); arc length by Gauss-Legendre
    quadrature of |r'(u)|, inverted by Newton steps.
    ``point_data`` (m, k), one row per point, is interpolated linearly in the chord parameter onto the rows.
    """
    from scipy.interpolate import splev

    check_points(x, y, z)
    if not (math.isfinite(smoothing_m) and smoothing_m >= 0.0):
        raise ValueError(f"smoothing_m must be >= 0 (got {smoothing_m})")
    pts = [x, y] if z is None else [x, y, z]
    data = None if point_data is None else [point_data[:, k] for k in range(point_data.shape[1])]
    if data is not None:
        pts = pts + data
    if closed:
        scale = max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(y))))
        if math.hypot(x[-1] - x[0], y[-1] - y[0]) <= 1e-9 * scale:
            pts = [p[:-1] for p in pts]
        if pts[0].size < MIN_POINTS:
            raise ValueError(f"a closed path needs >= {MIN_POINTS} distinct points (got {pts[0].size})")
        pts = [np.append(p, p[0]) for p in pts]
    if data is not None:
        data = pts[-len(data):]
        pts = pts[:-len(data)]
    m = pts[0].size
    chord = np.hypot(np.diff(pts[0]), np.diff(pts[1]))
    u = np.concatenate(([0.0], np.cumsum(chord)))
    k = 5 if m - int(closed) >= 8 else 3
    # x, y are fitted together; the elevation separately as z(u) on the same chord parameter, so that metres of
    # elevation never spend the horizontal smoothing budget (a joint fit can bend the plan view wildly).
    tck, tck_z = _splines(pts, u, k, closed, m * smoothing_m ** 2)
    u_end = float(u[-1])

    def speed(uu: np.ndarray) -> np.ndarray:
        d = splev(uu, tck, der=1)
        return np.hypot(d[0], d[1])

    # Cumulative arc length on a fine parameter grid.
    n_fine = 4 * math.ceil(u_end / ds_m) + FINE_PER_POINT * m
    grid_u = np.linspace(0.0, u_end, n_fine + 1)
    xi, om = gauss_legendre(8)
    h = np.diff(grid_u)
    nodes = grid_u[:-1, None] + h[:, None] * xi[None, :]
    seg = h * (speed(nodes.ravel()).reshape(nodes.shape) @ om)
    s_cum = np.concatenate(([0.0], np.cumsum(seg)))
    length = float(s_cum[-1])
    if length > MAX_LENGTH_GROWTH * u_end + 10.0 * ds_m:
        raise ValueError(f"the fitted centre-line ({length:.4g} m) is much longer than the points' polyline "
                         f"({u_end:.4g} m): smoothing_m = {smoothing_m} is too large for these points")
    n, ds = uniform_grid(length, ds_m)
    s_target = np.arange(n) * ds

    # Invert s(u) with Newton steps from linear interpolation.
    uj = np.interp(s_target, s_cum, grid_u)
    for _ in range(_NEWTON_ITER):
        kk = np.clip(np.searchsorted(grid_u, uj, side="right") - 1, 0, n_fine - 1)
        du = uj - grid_u[kk]
        part = du * (speed((grid_u[kk, None] + du[:, None] * xi[None, :]).ravel()).reshape(-1, xi.size) @ om)
        uj = np.clip(uj - (s_cum[kk] + part - s_target) / speed(uj), 0.0, u_end)
    uj[0] = 0.0
    uj[-1] = u_end

    p0 = splev(uj, tck)
    p1 = splev(uj, tck, der=1)
    p2 = splev(uj, tck, der=2)
    p3 = splev(uj, tck, der=3)
    sp = np.hypot(p1[0], p1[1])
    cross = p1[0] * p2[1] - p1[1] * p2[0]
    dot = p1[0] * p2[0] + p1[1] * p2[1]
    dcross = p1[0] * p3[1] - p1[1] * p3[0]
    table = np.zeros((n, tb.N_COLS))
    table[:, tb.COL_X] = p0[0]
    table[:, tb.COL_Y] = p0[1]
    table[:, tb.COL_PSI] = np.unwrap(np.arctan2(p1[1], p1[0]))
    table[:, tb.COL_KAPPA] = cross / sp ** 3
    table[:, tb.COL_DKAPPA] = (dcross / sp ** 3 - 3.0 * cross * dot / sp ** 5) / sp
    if tck_z is not None:
        z1 = splev(uj, tck_z, der=1)
        table[:, tb.COL_Z] = splev(uj, tck_z)
        table[:, tb.COL_GRADE] = z1 / sp
        table[:, tb.COL_ZPP] = splev(uj, tck_z, der=2) / sp ** 2 - z1 * dot / sp ** 4
    if closed:
        close_exactly(table, s_target, "from_points", allow_zero_turns=True)  # a figure-eight turns 0 times
    rows = None if data is None else np.column_stack([np.interp(uj, u, d) for d in data])
    return Fit(table, ds, rows)
