"""Planned reference lines, second version: one line for given inputs, its body checked exactly, its curvature exact.

:func:`plan_exact_line` finds, like ``tracks.planned_line.plan_line``, the line y(x) of least peak curvature along
which a car's body (``BodyRectangle``) stays inside every lane while any part of it is within the lane's length,
with a bounded curvature rate. What differs:

- **Unique.** Each round solves a strictly convex quadratic programme: minimise t + t^2 / 2 + (w / 2) mean(y''^2)
  + (r / 2) |c - c_ref|^2 over the spline coefficients c and the peak-curvature bound t, subject to |kappa| <= t (at the
  knots and mid-intervals), |dkappa/ds| <= the rate limit and the body constraints. The objective is strictly convex,
  so the optimum is one point, and it is found by an active-set method (the quadratic programme as a least-distance
  problem solved by non-negative least squares, Lawson and Hanson, scipy's ``nnls``, over a working set of rows grown
  until the solution violates none, started from the rows tightest at the last round's solution, ``_least_distance``):
  the result is the exact solution of the final active set's linear system, so a last-bit change of the inputs moves
  it by a last-bit amount (no linear programme's choice among equal optima). With w = 0.1 the peak curvature exceeds
  the least one by at most w t / 2 relative (t ~ 0.03 1/m: 0.15 %), measured against the linear programme of least
  peak curvature in the tests.
- **Exact body geometry.** The body's four corners and the points of its outline at the cone lines' ends (the
  first and last cone of each line) are held inside the lane, for CG positions every ``CG_STEP_M`` (linearised
  about the previous round, ``SLP_ITERATIONS`` rounds). The planned line is then checked with the exact gate judge
  (``tracks.gate_judge``: the body rectangle against the cone lines, swept between poses 1 cm apart, exact to
  0.1 mm); a clearance below ``margin_m`` minus ``CHECK_TOL_M`` plans again with the margin raised by the deficit.
- **The same bits.** The solve's last-bit differences (5e-13 m between numpy's AVX-512 and generic code paths,
  or with another memory alignment) would still reach a closed loop's trajectory; the coefficients are rounded to
  ``QUANTUM_M`` (2^-24 m, 6e-8 m), so the line is bit-identical unless a coefficient lies within those 5e-13 m of
  a rounding boundary (about one line in 200), and then it moves by 6e-8 m. The check below runs on the rounded
  line.
- **Exact curvature.** ``ExactLine.kappa_at(s)`` is the spline's curvature at arc length s and
  ``peak_curvature_per_m`` its maximum (the path's table holds the same values at its rows; between rows the
  env's cubic interpolation of a curvature whose rate jumps at the knots overshoots, so bounds use this).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.lanes import LaneSection, anchored_gates
from vtrack_gym.tracks.path import DEFAULT_DS_M, Path
from vtrack_gym.tracks.planned_line import BodyRectangle, _check_request, _Lane, _lanes_in_x, _Spline

SLP_ITERATIONS = 6              # linearise-and-solve rounds
CG_STEP_M = 0.02                # X step of the CG positions at which the body is held in the lanes [m]
FIRST_STEP_M = 0.1              # ... in the first round (from a straight line, every row kept)
PRUNE_M = 0.3                   # later rounds drop body rows with more slack than this at the previous line [m]
SMOOTH_WEIGHT = 0.1             # w: weight of mean(y''^2) [1/m^2] against the peak curvature t [1/m]
RIDGE_WEIGHT = 1e-6             # r: weight of |c - c_ref|^2 [1/m^3]: among lines of (nearly) equal curvature, the
                                # one nearest the lane centres (c_ref); keeps a sideways shift well determined
PAD_M = 20.0                    # the spline spans the lanes plus this much before and after [m]
CHECK_TOL_M = 2e-4              # accepted shortfall of the exact clearance below the margin [m]
CHECK_STEP_M = 0.01             # arc-length step of the exact check's poses [m]
MARGIN_RETRIES = 3              # re-plans with a raised margin when the exact check finds a shortfall
FINE_STEP_M = 0.01              # x step of the arc-length integration and of the peak search [m]
WORKING_ROWS = 600              # rows of the first working set of each solve (``_least_distance``)
WORKING_ADD = 150               # most violated rows added to the working set per re-solve
QUANTUM_M = 2.0 ** -24          # the line's coefficients are rounded to this (6e-8 m) [m]


class _Knots(_Spline):
    """``_Spline`` whose interval count ignores a last-bit excess of the span over a whole number of knot spacings
    (ceil(100.00000000001 / 0.5) would add an interval: a last-bit change of an input must not change the basis)."""

    def __init__(self, x_end: float, knot_spacing_m: float) -> None:
        self.n_int = max(4, math.ceil(x_end / knot_spacing_m - 1e-9))
        self.h = x_end / self.n_int
        self.knots = self.h * np.arange(-3, self.n_int + 4)
        self.n = self.n_int + 3
        self.x_end = x_end


@dataclass(frozen=True, eq=False)
class ExactLine:
    """A planned line: its ``path`` (gates anchored at the lanes), the spline's exact ``peak_curvature_per_m``
    [1/m] and ``peak_curvature_rate_per_m2`` [1/m^2], the body's least exact clearance to the cone lines
    ``clearance_m`` [m] (perfect follower) and the ``margin_m`` [m] it was planned with."""

    path: Path
    peak_curvature_per_m: float
    peak_curvature_rate_per_m2: float
    clearance_m: float
    margin_m: float
    _spline: _Spline
    _coef: np.ndarray
    _x_lo: float
    _s_of_x: tuple[np.ndarray, np.ndarray]

    def kappa_at(self, s_m: np.ndarray | float) -> np.ndarray:
        """The spline's exact curvature [1/m] at arc lengths ``s_m`` [m] (0 on the straight approach and run-out)."""
        xf, sf = self._s_of_x
        x = np.interp(np.asarray(s_m, dtype=float), sf, xf)
        return _kappa(self._spline, self._coef, x - self._x_lo)[0]

    def peak_lateral_accel_mps2(self, speed_mps: float) -> float:
        """v^2 times the exact peak curvature [m/s^2] at a constant ``speed_mps`` [m/s]."""
        return float(speed_mps) ** 2 * self.peak_curvature_per_m


def _kappa(spline: _Spline, coef: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact (kappa [1/m], dkappa/ds [1/m^2]) of the spline at local x ``u`` [m] (clamped: straight beyond)."""
    from scipy.interpolate import BSpline

    y = BSpline(spline.knots, coef, 3, extrapolate=False)
    uc = np.clip(np.asarray(u, dtype=float), 0.0, spline.x_end)
    d1, d2, d3 = (np.nan_to_num(y.derivative(k)(uc)) for k in (1, 2, 3))
    q = 1.0 + d1 ** 2
    kappa = d2 * q ** -1.5
    dkappa = (d3 * q ** -1.5 - 3.0 * d2 ** 2 * d1 * q ** -2.5) / np.sqrt(q)
    outside = (np.asarray(u) < 0.0) | (np.asarray(u) > spline.x_end)
    return np.where(outside, 0.0, kappa), np.where(outside, 0.0, dkappa)


def _ends_matrix(n: int) -> np.ndarray:
    """(n, n - 4) map from the free coefficients to the spline's: the first three equal, the last three equal
    (zero slope and curvature at both ends of a uniform cubic B-spline: the line joins its straights C^2)."""
    e = np.zeros((n, n - 4))
    e[:3, 0] = 1.0
    e[3:n - 3, 1:n - 5] = np.eye(n - 6)
    e[n - 3:, n - 5] = 1.0
    return e


def _pose(spline: _Spline, coef: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
    """(cols, b0, b1, y, slope) of the spline at local x ``u``: local basis columns and values."""
    cols, b0 = spline.local(u)
    b1 = spline.local(u, 1)[1]
    return cols, b0, b1, np.sum(b0 * coef[cols], axis=1), np.sum(b1 * coef[cols], axis=1)


def _corners(front: float, rear: float, half: float) -> tuple[np.ndarray, np.ndarray]:
    return np.array([front, rear, rear, front]), np.array([half, half, -half, -half])


def _outline_at(x_cut: float, xc: np.ndarray, c: np.ndarray, s: np.ndarray, lon: np.ndarray, lat: np.ndarray,
                upper: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body-frame (lon, lat) of the highest (``upper``) or lowest point of each body's outline on the vertical
    line X = ``x_cut``, for bodies with CG at X ``xc`` and heading cos ``c``, sin ``s``; and where one exists."""
    best_lon = np.zeros(xc.size)
    best_lat = np.zeros(xc.size)
    best_y = np.full(xc.size, -np.inf if upper else np.inf)
    for j in range(4):
        i = (j + 1) % 4
        xa = xc + lon[j] * c - lat[j] * s
        xb = xc + lon[i] * c - lat[i] * s
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (x_cut - xa) / (xb - xa)
        ok = np.isfinite(t) & (t >= 0.0) & (t <= 1.0)
        t = np.where(ok, t, 0.0)
        p_lon = lon[j] + t * (lon[i] - lon[j])
        p_lat = lat[j] + t * (lat[i] - lat[j])
        y = p_lon * s + p_lat * c
        better = ok & ((y > best_y) if upper else (y < best_y))
        best_lon = np.where(better, p_lon, best_lon)
        best_lat = np.where(better, p_lat, best_lat)
        best_y = np.where(better, y, best_y)
    return best_lon, best_lat, np.isfinite(best_y)


def _lane_rows(spline: _Spline, coef: np.ndarray, lane: _Lane, body: BodyRectangle, margin_m: float,
               x_lo: float, step_m: float) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """(values (k, 4), columns (k, 4), bounds (k,)) of rows ``sign * y_point <= bound`` holding the body's corners
    and its outline at the cone lines' ends inside ``lane``, linearised about ``coef``."""
    front, rear, half = body.cg_to_front_m, body.cg_to_front_m - body.length_m, 0.5 * body.width_m
    lon, lat = _corners(front, rear, half)
    reach = math.hypot(max(front, -rear), half)
    xc = np.arange(lane.x0 - reach, lane.x1 + reach + step_m, step_m)
    cols, b0, b1, _, slope = _pose(spline, coef, xc - x_lo)
    q = 1.0 + slope ** 2
    c, s = q ** -0.5, slope * q ** -0.5
    pts_lon, pts_lat, pts_ok = [], [], []
    for k in range(4):
        xk = xc + lon[k] * c - lat[k] * s
        pts_lon.append(np.full(xc.size, lon[k]))
        pts_lat.append(np.full(xc.size, lat[k]))
        pts_ok.append((xk >= lane.x0) & (xk <= lane.x1))
    vals, cols_out, rhs = [], [], []
    for sign, bound in ((1.0, lane.left - margin_m), (-1.0, -(lane.right + margin_m))):
        cand = [(a, b, ok) for a, b, ok in zip(pts_lon, pts_lat, pts_ok, strict=True)]
        cand += [_outline_at(x_cut, xc, c, s, lon, lat, sign > 0.0) for x_cut in (lane.x0, lane.x1)]
        for p_lon, p_lat, ok in cand:
            j = np.flatnonzero(ok)
            # y_pt = y + lon sin(psi) + lat cos(psi), linear in the slope about the previous one
            gain = p_lon[j] * c[j] ** 3 - p_lat[j] * s[j] * c[j] ** 2
            fixed = p_lon[j] * s[j] + p_lat[j] * c[j] - gain * slope[j]
            vals.append(sign * (b0[j] + gain[:, None] * b1[j]))
            cols_out.append(cols[j])
            rhs.append(bound - sign * fixed)
    return vals, cols_out, rhs


def _curvature_rows(spline: _Spline, coef: np.ndarray, rate: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Rows over (c, t) of |kappa| <= t at the knots and mid-intervals and |dkappa/ds| <= ``rate``."""
    xk = np.sort(np.concatenate((spline.knot_x(), spline.interval_mid_x())))
    slope = spline.basis(xk, 1) @ coef
    d2 = spline.basis(xk, 2) * ((1.0 + slope ** 2) ** -1.5)[:, None]
    minus = -np.ones((xk.size, 1))
    rows = [np.hstack((d2, minus)), np.hstack((-d2, minus))]
    rhs = [np.zeros(xk.size)] * 2
    if rate is not None:   # dkappa/ds varies inside an interval (y''' is constant there): held near both ends and mid
        xm = (spline.interval_mid_x()[:, None] + spline.h * np.array([-0.499, 0.0, 0.499])).ravel()
        slope_m = spline.basis(xm, 1) @ coef
        d3 = spline.basis(xm, 3) * ((1.0 + slope_m ** 2) ** -2.0)[:, None]
        zero = np.zeros((xm.size, 1))
        rows += [np.hstack((d3, zero)), np.hstack((-d3, zero))]
        rhs += [np.full(xm.size, rate)] * 2
    return np.vstack(rows), np.concatenate(rhs)


def _objective(spline: _Spline, ends: np.ndarray, lanes: list[_Lane], x_lo: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, g): the Cholesky factor R (upper) of the quadratic term and the linear term g of the objective over
    z = (free coefficients, t) (module docstring). c_ref: the lane centres at the lanes' middles, linear between
    them, at each coefficient's abscissa."""
    n_free = ends.shape[1]
    d2 = spline.basis(spline.knot_x(), 2) @ ends
    quad = SMOOTH_WEIGHT / d2.shape[0] * d2.T @ d2 + RIDGE_WEIGHT * ends.T @ ends
    mids = [0.5 * (ln.x0 + ln.x1) - x_lo for ln in lanes]
    c_ref = np.interp(spline.h * (np.arange(spline.n) - 1.0), mids, [0.5 * (ln.left + ln.right) for ln in lanes])
    q = np.zeros((n_free + 1, n_free + 1))
    q[:n_free, :n_free] = quad
    q[n_free, n_free] = 1.0
    g = np.concatenate((-RIDGE_WEIGHT * ends.T @ c_ref, [1.0]))
    return np.linalg.cholesky(q).T, g


def _solve_qp(r_upper: np.ndarray, lin: np.ndarray, a: np.ndarray, b: np.ndarray,
              guess: np.ndarray | None = None) -> np.ndarray | None:
    """argmin 1/2 z'Qz + lin'z subject to a z <= b (Q = R'R), as the least-distance problem min |x|,
    x = R z + R^-T lin, solved by non-negative least squares (Lawson and Hanson) over a working set of rows
    (``_least_distance``) started from the rows tightest at ``guess`` (a z near the optimum, default 0); None when
    infeasible."""
    from scipy.linalg import solve_triangular

    shift = solve_triangular(r_upper, lin, trans="T")                 # R^-T lin
    g = solve_triangular(r_upper, a.T, trans="T").T                   # a R^-1
    h = b + g @ shift
    scale = np.linalg.norm(g, axis=1)
    scale[scale == 0.0] = 1.0
    near = shift if guess is None else r_upper @ guess + shift
    x = _least_distance(g / scale[:, None], h / scale, near)
    if x is None:
        return None
    return solve_triangular(r_upper, x - shift)


def _least_distance(g: np.ndarray, h: np.ndarray, near: np.ndarray) -> np.ndarray | None:
    """min |x| subject to g x <= h (rows of unit norm); None when infeasible. ``near``: an x near the optimum.

    Only a few hundred of the thousands of rows are active at the optimum, and the non-negative least squares'
    cost grows with the rows it sees, so it is solved over a working set: the ``WORKING_ROWS`` rows of least
    slack at ``near``, then repeatedly with the ``WORKING_ADD`` rows the last solution violates most added, until
    it violates none. The problem is strictly convex, so that solution is the one over all rows (to the solve's
    last bits, which the coefficient rounding removes); a working set that is infeasible makes the whole problem
    infeasible."""
    work = np.zeros(h.size, dtype=bool)
    work[np.argsort(h - g @ near, kind="stable")[:WORKING_ROWS]] = True
    while True:
        x = _nnls_distance(g[work], h[work])
        if x is None:
            return None
        excess = np.where(work, 0.0, g @ x - h)
        worst = np.argsort(-excess, kind="stable")[:WORKING_ADD]
        worst = worst[excess[worst] > 0.0]
        if worst.size == 0:
            return x
        work[worst] = True


def _nnls_distance(g: np.ndarray, h: np.ndarray) -> np.ndarray | None:
    """min |x| subject to g x <= h by non-negative least squares on [-g^T; -h^T] u = [0; 1]; None when
    infeasible."""
    from scipy.optimize import nnls

    n = g.shape[1]
    e = np.vstack((-g.T, -h[None, :]))
    f = np.zeros(n + 1)
    f[-1] = 1.0
    u, _ = nnls(e, f, maxiter=50 * e.shape[1])
    res = e @ u - f
    if abs(res[-1]) < 1e-12:
        return None
    return -res[:n] / res[-1]


def _round(spline: _Spline, coef: np.ndarray, lanes: list[_Lane], body: BodyRectangle, margin_m: float,
           rate: float | None, x_lo: float, ends: np.ndarray, objective: tuple[np.ndarray, np.ndarray],
           first: bool, guess: np.ndarray | None) -> np.ndarray:
    """One linearised quadratic programme about ``coef``: its solution z (free coefficients, t), the last round's
    z as ``guess``. The ``first`` round (about a
    straight line) holds the body every ``FIRST_STEP_M``; the later ones every ``CG_STEP_M``, leaving out rows
    with more than ``PRUNE_M`` of slack at ``coef`` (inactive at an optimum that close)."""
    n = spline.n
    a_k, b_k = _curvature_rows(spline, coef, rate)
    blocks = [np.hstack((a_k[:, :n] @ ends, a_k[:, n:]))]
    rhs = [b_k]
    for lane in lanes:
        vals, cols, bounds = _lane_rows(spline, coef, lane, body, margin_m, x_lo,
                                        FIRST_STEP_M if first else CG_STEP_M)
        for v, cl, bd in zip(vals, cols, bounds, strict=True):
            if not first:
                keep = bd - np.sum(v * coef[cl], axis=1) <= PRUNE_M
                v, cl, bd = v[keep], cl[keep], bd[keep]
            dense = np.zeros((v.shape[0], n))
            np.add.at(dense, (np.repeat(np.arange(v.shape[0]), 4), cl.ravel()), v.ravel())
            blocks.append(np.hstack((dense @ ends, np.zeros((v.shape[0], 1)))))
            rhs.append(bd)
    z = _solve_qp(*objective, np.vstack(blocks), np.concatenate(rhs), guess)
    if z is None:
        raise ValueError(f"no line through the lanes for {body.name!r} (width {body.width_m} m, length "
                         f"{body.length_m} m, margin {margin_m} m) within the curvature-rate limit {rate} 1/m^2")
    return z


def _arc(spline: _Spline, coef: np.ndarray, x_lo: float, x_end: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, s) on a fine grid over [0, x_end]: the arc length of the line (straight outside the spline)."""
    from scipy.interpolate import BSpline

    y = BSpline(spline.knots, coef, 3, extrapolate=False)
    xf = np.linspace(0.0, x_end, max(2, math.ceil(x_end / FINE_STEP_M) + 1))
    u = np.clip(xf - x_lo, 0.0, spline.x_end)
    speed = np.sqrt(1.0 + np.nan_to_num(y.derivative(1)(u)) ** 2)
    sf = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(xf))))
    return xf, sf


def _path(spline: _Spline, coef: np.ndarray, x_lo: float, arc: tuple[np.ndarray, np.ndarray], ds_m: float,
          half_width_m: float, name: str, version: str) -> Path:
    """The line's path: a table on a uniform arc-length grid, every column from the spline exactly."""
    from scipy.interpolate import BSpline

    xf, sf = arc
    n, ds = tb.uniform_grid(float(sf[-1]), ds_m)
    x = np.clip(np.interp(np.arange(n) * ds, sf, xf), 0.0, xf[-1])
    u = np.clip(x - x_lo, 0.0, spline.x_end)
    y = BSpline(spline.knots, coef, 3, extrapolate=False)
    table = np.zeros((n, tb.N_COLS))
    table[:, tb.COL_X] = x
    table[:, tb.COL_Y] = np.nan_to_num(y(u))
    table[:, tb.COL_PSI] = np.arctan(np.nan_to_num(y.derivative(1)(u)))
    table[:, tb.COL_KAPPA], table[:, tb.COL_DKAPPA] = _kappa(spline, coef, x - x_lo)
    return Path(table, ds, closed=False, half_width_m=half_width_m, name=name, version=version)


def _check(path: Path, spline: _Spline, coef: np.ndarray, x_lo: float, arc: tuple[np.ndarray, np.ndarray],
           body: BodyRectangle) -> float:
    """The body's least exact clearance [m] to the cone lines, its CG on the spline every ``CHECK_STEP_M``."""
    from scipy.interpolate import BSpline

    from vtrack_gym.tracks.gate_judge import path_gate_clearance_m

    xf, sf = arc
    lo = min(g.s_start_m for g in path.gates) - body.length_m - 1.0
    hi = max(g.s_end_m for g in path.gates) + body.length_m + 1.0
    s = np.arange(max(lo, 0.0), min(hi, float(sf[-1])), CHECK_STEP_M)
    x = np.interp(s, sf, xf)
    y = BSpline(spline.knots, coef, 3, extrapolate=False)
    u = np.clip(x - x_lo, 0.0, spline.x_end)
    pose = (x, np.nan_to_num(y(u)), np.arctan(np.nan_to_num(y.derivative(1)(u))))
    front, half = body.cg_to_front_m, 0.5 * body.width_m
    row = np.array([front, front - body.length_m, half])
    return float(np.min(path_gate_clearance_m(path, row, tol=1e-4, pose=pose)))


def plan_exact_line(lanes: Sequence[LaneSection], gaps_m: Sequence[float], body: BodyRectangle, *,
                    approach_m: float, run_out_m: float, max_curvature_rate_per_m2: float | None = None,
                    margin_m: float = 0.0, knot_spacing_m: float = 0.5, half_width_m: float = 5.0,
                    ds_m: float = DEFAULT_DS_M, name: str = "planned_line", version: str = "2") -> ExactLine:
    """The line of least peak curvature along which ``body`` passes every lane of ``lanes`` at least ``margin_m``
    [m] from every cone line, judged exactly (module docstring); arguments as ``planned_line.plan_line``.
    ValueError when the car is too wide for a lane or no line meets the bounds."""
    if not (math.isfinite(margin_m) and 0.0 <= margin_m <= 0.5):
        raise ValueError(f"margin_m must be in [0, 0.5] m (got {margin_m})")
    _check_request(lanes, gaps_m, body, approach_m, run_out_m, max_curvature_rate_per_m2, margin_m)
    in_x = _lanes_in_x(lanes, gaps_m, approach_m)
    x_end = in_x[-1].x1 + run_out_m
    x_lo, x_hi = max(0.0, in_x[0].x0 - PAD_M), min(x_end, in_x[-1].x1 + PAD_M)
    spline = _Knots(x_hi - x_lo, knot_spacing_m)
    ends = _ends_matrix(spline.n)
    objective = _objective(spline, ends, in_x, x_lo)
    planned, rate = margin_m, max_curvature_rate_per_m2
    for _ in range(MARGIN_RETRIES):
        coef, z = np.full(spline.n, lanes[0].centre_y_m), None
        for k in range(SLP_ITERATIONS):
            z = _round(spline, coef, in_x, body, planned, rate, x_lo, ends, objective, k == 0, z)
            coef = ends @ z[:-1]
        coef = np.round(coef / QUANTUM_M) * QUANTUM_M   # last-bit differences of the solve (~5e-13 m) vanish
        arc = _arc(spline, coef, x_lo, x_end)
        path = anchored_gates(_path(spline, coef, x_lo, arc, ds_m, half_width_m, name, version), lanes,
                              [ln.x0 for ln in in_x])
        clearance = _check(path, spline, coef, x_lo, arc, body)
        kappa, dkappa = _kappa(spline, coef, arc[0] - x_lo)
        rate_peak = float(np.max(np.abs(dkappa)))
        rate_ok = rate is None or rate_peak <= max_curvature_rate_per_m2 * (1.0 + 1e-3)
        if clearance >= margin_m - CHECK_TOL_M and rate_ok:
            return ExactLine(path, float(np.max(np.abs(kappa))), rate_peak, clearance, margin_m, spline, coef, x_lo,
                             arc)
        planned += max(margin_m - clearance, 0.0) + CHECK_TOL_M
        if not rate_ok:
            rate *= max_curvature_rate_per_m2 / rate_peak
    raise ValueError(f"no planned line for {body.name!r} within {MARGIN_RETRIES} re-plans: exact clearance "
                     f"{clearance:.4f} m (margin {margin_m} m), peak curvature rate {rate_peak:.4g} 1/m^2 "
                     f"(limit {max_curvature_rate_per_m2})")


__all__ = ["ExactLine", "plan_exact_line"]
