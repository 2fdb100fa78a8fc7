"""Planned reference lines: the smoothest line a car's body can follow through a manoeuvre's cone lanes.

A cone-lined test (ISO 3888-1/-2, a slalom) says where the car's body must be, not which line its CG must follow.
:func:`plan_line` finds the line y(x) of least peak curvature such that the body rectangle (``BodyRectangle``:
length, width, CG to front end) stays inside every lane while any part of it is within the lane's length, with a
bounded curvature rate (the steering actuator's rate limit, see :func:`curvature_rate_limit_per_m2`).

Method. y(x) is a uniform cubic B-spline (knot spacing ``knot_spacing_m``), so the line is C^2 and y'' is
piecewise linear (its extremes lie at the knots) and y''' piecewise constant. A linear programme (scipy's HiGHS)
minimises the peak curvature t subject to |kappa| <= t at the knots, |dkappa/ds| <= the rate limit on every knot
interval, zero heading and curvature at both ends (the line joins the straight approach and run-out), and every
sampled point of the body's sides (every ``OUTLINE_STEP_M``) inside the lane it is over, ``margin_m`` from the
cone lines. Curvature kappa = y'' / (1 + y'^2)^(3/2) and the body's pose are linearised about the previous
solution (the side points' lengthwise offset through sin(psi) to first order, their half-width offset through
cos(psi) held at the previous heading, which keeps a lane barely wider than the car feasible) and the programme
is solved again (sequential linear programming, ``SLP_ITERATIONS`` times); a small weight on the integral of
|kappa| picks, among lines of equal peak curvature, the one that turns least. The result is checked exactly
(``dlc.gate_violations`` on the path's rows); a violation plans again with the full half width (cos(psi) taken as
1, conservative), then with a wider margin.

Shipped lines. A linear programme with many optima may return another of them when its inputs differ in the last
bit (another CPU's vector code for sin, cos and atan), so the lines the -v1 ISO 3888 ids drive with their default
car are shipped as data (``planned_line_store``): ``plan_line`` returns the stored table when the request's
inputs (``plan_inputs``) equal a recorded entry's exactly, the same on every machine, and plans any other request
(another car, margin or vehicle file) on the machine that runs it.

The line's table is exact: arc length from the spline's slope, heading atan(y'), curvature and its rate from the
spline's derivatives. Gates are anchored rectangles at the lanes' fixed positions (``Gate.anchor``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.dlc import OUTLINE_STEP_M, gate_violations
from vtrack_gym.tracks.lanes import LaneSection, anchored_gates
from vtrack_gym.tracks.path import DEFAULT_DS_M, Path

SLP_ITERATIONS = 4              # linearise-and-solve rounds of the programme
L1_WEIGHT = 1e-4                # weight of the integral of |kappa| [rad] against the peak curvature [1/m]
MARGIN_RETRIES = 4              # re-plans with a wider margin when the exact check finds a touched cone
FINE_STEP_M = 0.01              # x step of the arc-length integration [m]
RATE_TOL = 1e-3                 # accepted relative excess of the exact peak curvature rate over its bound
PLANNER_CONSTANTS = {"slp_iterations": SLP_ITERATIONS, "l1_weight": L1_WEIGHT, "margin_retries": MARGIN_RETRIES,
                     "fine_step_m": FINE_STEP_M, "rate_tol": RATE_TOL, "outline_step_m": OUTLINE_STEP_M}
"""The planner's constants, recorded with every shipped line (``planned_line_store``)."""


@documented
@dataclass(frozen=True)
class BodyRectangle:
    """A car's body outline for gate checks: ``length_m`` [m], ``width_m`` [m], ``cg_to_front_m`` [m] (CG to the
    front end, < length), ``name`` (the car, named in errors)."""

    length_m: float = ranged(gt=0.5, le=20.0, unit="m")
    width_m: float = ranged(gt=0.5, le=4.0, unit="m")
    cg_to_front_m: float = ranged(gt=0.0, lt="length_m", unit="m")
    name: str = "car"

    def __post_init__(self) -> None:
        validate(self)


@dataclass(frozen=True)
class PlannedLine:
    """A planned reference line: the ``path`` (gates anchored at the lanes), its ``peak_curvature_per_m`` [1/m]
    and ``peak_curvature_rate_per_m2`` [1/m^2] (both from the path's table)."""

    path: Path
    peak_curvature_per_m: float
    peak_curvature_rate_per_m2: float

    def peak_lateral_accel_mps2(self, speed_mps: float) -> float:
        """v^2 times the peak curvature [m/s^2] at a constant ``speed_mps`` [m/s]."""
        return float(speed_mps) ** 2 * self.peak_curvature_per_m


def curvature_rate_limit_per_m2(max_road_wheel_rate_radps: float, wheelbase_m: float, speed_mps: float) -> float:
    """Curvature rate [1/m^2] a steering actuator of rate ``max_road_wheel_rate_radps`` [rad/s] can follow at
    ``speed_mps`` [m/s]: kappa ~ delta / l (kinematic single track, wheelbase l [m]), so dkappa/ds = delta_dot /
    (l v). Conservative for every lower speed."""
    for name, value in (("max_road_wheel_rate_radps", max_road_wheel_rate_radps), ("wheelbase_m", wheelbase_m),
                        ("speed_mps", speed_mps)):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be a finite number > 0 (got {value})")
    return max_road_wheel_rate_radps / (wheelbase_m * speed_mps)


@dataclass(frozen=True)
class _Lane:
    x0: float
    x1: float
    left: float
    right: float


def _lanes_in_x(lanes: Sequence[LaneSection], gaps_m: Sequence[float], approach_m: float) -> list[_Lane]:
    out, x = [], approach_m
    for k, lane in enumerate(lanes):
        out.append(_Lane(x, x + lane.length_m, lane.centre_y_m + 0.5 * lane.width_m,
                         lane.centre_y_m - 0.5 * lane.width_m))
        x += lane.length_m + (float(gaps_m[k]) if k < len(gaps_m) else 0.0)
    return out


def _check_fits(lanes: Sequence[LaneSection], body: BodyRectangle, margin_m: float) -> None:
    for lane in lanes:
        if body.width_m + 2.0 * margin_m >= lane.width_m:
            raise ValueError(f"vehicle_width_m = {body.width_m} m of {body.name!r} does not fit "
                             f"{lane.name or 'a lane'}: the lane is {lane.width_m:.3f} m wide, so the car must be "
                             f"narrower than {lane.width_m - 2.0 * margin_m:.3f} m (width minus twice the "
                             f"{margin_m} m margin)")


class _Spline:
    """Uniform cubic B-spline basis on [0, x_end] with knot spacing h."""

    def __init__(self, x_end: float, knot_spacing_m: float) -> None:
        self.n_int = max(4, math.ceil(x_end / knot_spacing_m))
        self.h = x_end / self.n_int
        self.knots = self.h * np.arange(-3, self.n_int + 4)
        self.n = self.n_int + 3
        self.x_end = x_end

    def basis(self, x: np.ndarray, nu: int = 0) -> np.ndarray:
        """(len(x), n) matrix of the nu-th derivatives of the basis functions at x."""
        from scipy.interpolate import BSpline

        spl = BSpline(self.knots, np.eye(self.n), 3, extrapolate=False)
        out = (spl.derivative(nu) if nu else spl)(np.clip(np.asarray(x, dtype=float), 0.0, self.x_end))
        return np.nan_to_num(out)

    def local(self, x: np.ndarray, nu: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Columns (len(x), 4) and values (len(x), 4) of the four basis functions non-zero at each x."""
        cols = np.clip(np.floor(np.asarray(x) / self.h).astype(np.int64), 0, self.n_int - 1)[:, None] + np.arange(4)
        return cols, np.take_along_axis(self.basis(x, nu), cols, axis=1)

    def knot_x(self) -> np.ndarray:
        return self.h * np.arange(self.n_int + 1)

    def interval_mid_x(self) -> np.ndarray:
        return self.h * (np.arange(self.n_int) + 0.5)


def _body_points(body: BodyRectangle) -> tuple[np.ndarray, np.ndarray]:
    """(lon, lat) [m] of points along both long sides of the body, at most ``OUTLINE_STEP_M`` apart."""
    rear = body.cg_to_front_m - body.length_m
    lon = np.linspace(rear, body.cg_to_front_m, max(2, math.ceil(body.length_m / OUTLINE_STEP_M) + 1))
    half = 0.5 * body.width_m
    return np.concatenate((lon, lon)), np.concatenate((np.full(lon.size, half), np.full(lon.size, -half)))


def _body_rows(spline: _Spline, coef: np.ndarray, lanes: list[_Lane], body: BodyRectangle, margin_m: float,
               full_width: bool) -> tuple[Any, np.ndarray]:
    """Rows A, b of A c <= b keeping the body's side points inside the lanes, linearised about ``coef``;
    ``full_width``: the half width counts in full (cos psi taken as 1, conservative)."""
    from scipy.sparse import coo_matrix

    lon, lat = _body_points(body)
    step = 0.5 * spline.h
    lo = lanes[0].x0 - body.cg_to_front_m - 1.0
    hi = lanes[-1].x1 + body.length_m + 1.0
    xc = np.arange(max(lo, 0.0), min(hi, spline.x_end) + 1e-9, step)
    cols, b0 = spline.local(xc)
    b1 = spline.local(xc, 1)[1]
    slope_p = np.sum(b1 * coef[cols], axis=1)
    psi_p = np.arctan(slope_p)
    c, s = np.cos(psi_p)[:, None], np.sin(psi_p)[:, None]
    x_pt = xc[:, None] + lon[None, :] * c - lat[None, :] * s
    gain = lon[None, :] * c / (1.0 + slope_p ** 2)[:, None]      # d(lon sin psi) / d(slope), about slope_p
    y_fix = lon[None, :] * s + lat[None, :] * (1.0 if full_width else c) - gain * slope_p[:, None]
    vals, col_idx, rhs = [], [], []
    for lane in lanes:
        j, p = np.nonzero((x_pt >= lane.x0) & (x_pt <= lane.x1))
        sign = np.where(lat[p] > 0.0, 1.0, -1.0)      # left side: y <= left; right side: -y <= -right
        bound = np.where(lat[p] > 0.0, lane.left - margin_m, -(lane.right + margin_m))
        vals.append(sign[:, None] * (b0[j] + gain[j, p][:, None] * b1[j]))
        col_idx.append(cols[j])
        rhs.append(bound - sign * y_fix[j, p])
    data, columns = np.concatenate(vals), np.concatenate(col_idx)
    rows = np.repeat(np.arange(data.shape[0]), 4)
    matrix = coo_matrix((data.ravel(), (rows, columns.ravel())), shape=(data.shape[0], spline.n))
    return matrix, np.concatenate(rhs)


def _smoothness_rows(spline: _Spline, coef: np.ndarray,
                     rate_limit: float | None) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Rows over z = [c, t, a]: |w y''| <= a_k <= t at the knots; |dkappa/ds| <= rate_limit per interval."""
    n, m = spline.n, spline.n_int + 1
    xk = spline.knot_x()
    slope = spline.basis(xk, 1) @ coef
    d2 = spline.basis(xk, 2) * ((1.0 + slope ** 2) ** -1.5)[:, None]
    eye = np.eye(m)
    zeros_t = np.zeros((m, 1))
    rows = [np.hstack((d2, zeros_t, -eye)), np.hstack((-d2, zeros_t, -eye)),
            np.hstack((np.zeros((m, n)), -np.ones((m, 1)), eye))]
    rhs = [np.zeros(m), np.zeros(m), np.zeros(m)]
    if rate_limit is not None:
        xm = spline.interval_mid_x()
        slope_m = spline.basis(xm, 1) @ coef
        d3 = spline.basis(xm, 3) * ((1.0 + slope_m ** 2) ** -2.0)[:, None]
        pad = np.zeros((xm.size, 1 + m))
        rows += [np.hstack((d3, pad)), np.hstack((-d3, pad))]
        rhs += [np.full(xm.size, rate_limit)] * 2
    return rows, rhs


def _solve(spline: _Spline, coef: np.ndarray, lanes: list[_Lane], body: BodyRectangle, margin_m: float,
           rate_limit: float | None, full_width: bool) -> np.ndarray:
    """One linear programme about ``coef``; returns the new spline coefficients."""
    from scipy.optimize import linprog
    from scipy.sparse import csr_matrix, hstack, vstack

    n, m = spline.n, spline.n_int + 1
    rows, rhs = _smoothness_rows(spline, coef, rate_limit)
    a_body, b_body = _body_rows(spline, coef, lanes, body, margin_m, full_width)
    a_ub = vstack([csr_matrix(r) for r in rows] + [hstack((a_body.tocsr(), csr_matrix((a_body.shape[0], 1 + m))))])
    ends = np.array([0.0, spline.x_end])
    a_eq = np.hstack((np.vstack((spline.basis(ends, 1), spline.basis(ends, 2))), np.zeros((4, 1 + m))))
    cost = np.concatenate((np.zeros(n), [1.0], np.full(m, L1_WEIGHT * spline.h)))
    bounds = [(None, None)] * n + [(0.0, None)] * (1 + m)
    res = linprog(cost, A_ub=a_ub.tocsr(), b_ub=np.concatenate([*rhs, b_body]), A_eq=a_eq, b_eq=np.zeros(4),
                  bounds=bounds, method="highs")
    if res.status != 0:
        raise ValueError(f"no line through the lanes for {body.name!r} (width {body.width_m} m, length "
                         f"{body.length_m} m) within the curvature-rate limit {rate_limit} 1/m^2: {res.message}")
    return np.asarray(res.x[:n])


def _table(spline: _Spline, coef: np.ndarray, ds_m: float) -> tuple[np.ndarray, float]:
    """Path table (exact columns from the spline) on a uniform arc-length grid of spacing <= ``ds_m``."""
    from scipy.interpolate import BSpline

    y = BSpline(spline.knots, coef, 3, extrapolate=False)
    xf = np.linspace(0.0, spline.x_end, max(2, math.ceil(spline.x_end / FINE_STEP_M) + 1))
    speed = np.sqrt(1.0 + np.nan_to_num(y.derivative(1)(xf)) ** 2)
    sf = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(xf))))
    n, ds = tb.uniform_grid(float(sf[-1]), ds_m)
    x = np.clip(np.interp(np.arange(n) * ds, sf, xf), 0.0, spline.x_end)
    d1, d2, d3 = (np.nan_to_num(y.derivative(k)(x)) for k in (1, 2, 3))
    q = 1.0 + d1 ** 2
    table = np.zeros((n, tb.N_COLS))
    table[:, tb.COL_X] = x
    table[:, tb.COL_Y] = np.nan_to_num(y(x))
    table[:, tb.COL_PSI] = np.arctan(d1)
    table[:, tb.COL_KAPPA] = d2 * q ** -1.5
    table[:, tb.COL_DKAPPA] = (d3 * q ** -1.5 - 3.0 * d2 ** 2 * d1 * q ** -2.5) / np.sqrt(q)
    return table, ds


def _build_path(spline: _Spline, coef: np.ndarray, lanes: Sequence[LaneSection], x_starts: Sequence[float], *,
                ds_m: float, half_width_m: float, name: str, version: str) -> Path:
    table, ds = _table(spline, coef, ds_m)
    path = Path(table, ds, closed=False, half_width_m=half_width_m, name=name, version=version)
    return anchored_gates(path, lanes, x_starts)


def plan_line(lanes: Sequence[LaneSection], gaps_m: Sequence[float], body: BodyRectangle, *, approach_m: float,
              run_out_m: float, max_curvature_rate_per_m2: float | None = None, margin_m: float = 0.01,
              knot_spacing_m: float = 0.5, half_width_m: float = 5.0, ds_m: float = DEFAULT_DS_M,
              name: str = "planned_line", version: str = "1", stored: bool = True) -> PlannedLine:
    """The line of least peak curvature along which ``body`` passes every lane of ``lanes`` (``gaps_m[i]`` [m] of X
    between lane i and i + 1), after ``approach_m`` [m] of straight and before ``run_out_m`` [m] (see the module
    docstring). ``max_curvature_rate_per_m2`` [1/m^2]: bound on |dkappa/ds| (None: unbounded). ``margin_m`` [m]:
    least clearance between the body and a cone line. ``stored``: return the shipped line when exactly these
    inputs were recorded (``planned_line_store``: the -v1 ids' lines, the same on every machine), else plan it.
    ValueError when the car is too wide for a lane (naming the car, its width and the lane's limit) or no line
    meets the rate bound."""
    from vtrack_gym.tracks import planned_line_store

    _check_request(lanes, gaps_m, body, approach_m, run_out_m, max_curvature_rate_per_m2, margin_m)
    in_x = _lanes_in_x(lanes, gaps_m, approach_m)
    build = {"lanes": lanes, "x_starts": [ln.x0 for ln in in_x], "half_width_m": half_width_m, "name": name,
             "version": version}
    inputs = plan_inputs(lanes, gaps_m, body, approach_m=approach_m, run_out_m=run_out_m, margin_m=margin_m,
                         max_curvature_rate_per_m2=max_curvature_rate_per_m2, knot_spacing_m=knot_spacing_m,
                         half_width_m=half_width_m, ds_m=ds_m, name=name, version=version)
    found = planned_line_store.stored_table(inputs) if stored else None
    if found is not None:
        return _line_of(anchored_gates(Path(found[0], found[1], closed=False, half_width_m=half_width_m, name=name,
                                            version=version), lanes, build["x_starts"]))
    spline = _Spline(in_x[-1].x1 + run_out_m, knot_spacing_m)
    margin, rate = margin_m, max_curvature_rate_per_m2
    for attempt in range(MARGIN_RETRIES):
        coef = np.full(spline.n, lanes[0].centre_y_m)
        for _ in range(SLP_ITERATIONS):
            coef = _solve(spline, coef, in_x, body, margin, rate, full_width=attempt > 0)
        line = _line_of(_build_path(spline, coef, ds_m=ds_m, **build))
        hits = _gates_touched(line.path, body)
        rate_ok = rate is None or line.peak_curvature_rate_per_m2 <= max_curvature_rate_per_m2 * (1.0 + RATE_TOL)
        if hits == 0 and rate_ok:
            return line
        margin = margin if hits == 0 or attempt == 0 else 2.0 * margin + 0.01
        if not rate_ok:             # the programme's rate is linearised: tighten it by the measured excess
            rate *= max_curvature_rate_per_m2 / line.peak_curvature_rate_per_m2
    raise ValueError(f"no planned line for {body.name!r} within {MARGIN_RETRIES} re-plans: {hits} gate(s) "
                     f"touched (margin {margin} m), peak curvature rate {line.peak_curvature_rate_per_m2:.4g} 1/m^2 "
                     f"(limit {max_curvature_rate_per_m2})")


def plan_inputs(lanes: Sequence[LaneSection], gaps_m: Sequence[float], body: BodyRectangle, *, approach_m: float,
                run_out_m: float, max_curvature_rate_per_m2: float | None = None, margin_m: float = 0.01,
                knot_spacing_m: float = 0.5, half_width_m: float = 5.0, ds_m: float = DEFAULT_DS_M,
                name: str = "planned_line", version: str = "1") -> str:
    """The exact record of a ``plan_line`` request (same arguments and defaults; ``planned_line_store.line_inputs``
    with the planner's constants): the key of a shipped line."""
    from vtrack_gym.tracks import planned_line_store

    return planned_line_store.line_inputs(
        lanes, gaps_m, body, approach_m=approach_m, run_out_m=run_out_m, margin_m=margin_m, ds_m=ds_m,
        max_curvature_rate_per_m2=max_curvature_rate_per_m2, knot_spacing_m=knot_spacing_m,
        half_width_m=half_width_m, name=name, version=version, planner=PLANNER_CONSTANTS)


def _check_request(lanes: Sequence[LaneSection], gaps_m: Sequence[float], body: BodyRectangle, approach_m: float,
                   run_out_m: float, max_curvature_rate_per_m2: float | None, margin_m: float) -> None:
    """ValueError for a ``plan_line`` request it cannot plan (see ``plan_line``)."""
    if len(lanes) < 1 or len(gaps_m) != len(lanes) - 1:
        raise ValueError(f"need >= 1 lane and one gap between consecutive lanes (got {len(lanes)} lanes, "
                         f"{len(gaps_m)} gaps)")
    if approach_m < body.length_m or run_out_m < body.length_m:
        raise ValueError(f"approach_m and run_out_m must be at least the body length {body.length_m} m "
                         f"(got {approach_m}, {run_out_m})")
    if max_curvature_rate_per_m2 is not None and not max_curvature_rate_per_m2 > 0.0:
        raise ValueError(f"max_curvature_rate_per_m2 must be > 0 1/m^2 or None (got {max_curvature_rate_per_m2})")
    _check_fits(lanes, body, margin_m)


def _line_of(path: Path) -> PlannedLine:
    """The ``PlannedLine`` of a planned path (peaks from its table)."""
    return PlannedLine(path, float(np.max(np.abs(path.table[:, tb.COL_KAPPA]))),
                       float(np.max(np.abs(path.table[:, tb.COL_DKAPPA]))))


def _gates_touched(path: Path, body: BodyRectangle) -> int:
    """Gates the body touches when its CG follows ``path`` exactly, heading along it."""
    t = path.table
    return gate_violations(path, t[:, tb.COL_X], t[:, tb.COL_Y], t[:, tb.COL_PSI], body.length_m, body.width_m,
                           body.cg_to_front_m)


__all__ = ["BodyRectangle", "PlannedLine", "curvature_rate_limit_per_m2", "plan_inputs", "plan_line"]
