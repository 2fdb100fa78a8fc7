"""A minimum-curvature racing line inside a track's drivable widths, solved as a quadratic programme.

The method of the minimum-curvature planner of Heilmeier et al. (2019, "Minimum curvature trajectory planning and
control for an autonomous race car", Vehicle System Dynamics; TUM's global race-trajectory optimiser), written here
with finite differences and a sparse solver:

- Nodes r_j every ``step_m`` along the track's centre line (the reference), with left unit normals n_j; the line
  passes through p_j = r_j + alpha_j n_j, alpha_j [m] the lateral offset (left-positive, like e_y).
- Bounds: -(w_right,j - c) <= alpha_j <= w_left,j - c with c = body_width / 2 + ``margin_m``: the car's half
  width and a margin inside the drivable half widths (``Path.half_widths``).
- Curvature of the line at node j, kappa_j = (p'_j x p''_j) / |p'_j|^3, with p' = (p_{j+1} - p_{j-1}) / 2 and
  p'' = p_{j+1} - 2 p_j + p_{j-1} (per node index). Objective: the integral of kappa^2 along the line, sum_j
  r_j^2 with r_j = sqrt(|p'_j|) kappa_j = (p'_j x p''_j) / |p'_j|^(5/2), plus ``REGULARISATION`` x sum alpha^2
  (picks one line among those of equal curvature, such as shifts along a straight).
- The residuals are linearised in alpha about the current line, r = r0 + J (alpha - alpha0) with J sparse (three
  entries a row), which makes each step a box-constrained convex QP with a banded (cyclic on a closed track)
  Hessian J^T J: ``tracks.box_qp``. The step is taken with a backtracking on the true objective and the
  linearisation repeated about the new line (Gauss-Newton) until the offsets move less than ``tol_m`` or the
  objective falls by less than ``RELATIVE_DECREASE`` of it, at most ``max_iterations`` times. Unlike Heilmeier et
  al., who hold p' at the reference line and linearise only p'', the whole curvature is linearised: with p'
  held, moving inwards on a circle shortens p'' but not p', so the linearised curvature falls and the iteration
  ends on the inner edge of a ring, whereas the true curvature 1 / R is least on the outer edge (the line this
  module finds).
- The line: ``Path.from_points`` through the nodes (an interpolating quintic spline, exact curvature). Its rows are
  checked against the track's edges (``tracks.track_edges``: the distance to each edge polyline, which is less than
  the lateral offset where the widths change); where a row comes closer than c, the nearby nodes' bounds are
  tightened by the shortfall and the QP solved again (``MAX_REPAIRS`` rounds).

The returned ``Path`` carries its own half widths: each row's distance to the track's left and right edges, so edge
judgments on the racing line still work.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.path import Path

REGULARISATION = 1e-10
"""Weight of sum alpha^2 against the curvature integral [1/m^3 per m^2 of offset]: negligible against any bend."""
RELATIVE_DECREASE = 1e-5
"""The linearisation has also converged when a step lowers the objective by less than this share of it (a line
drifting along a flat valley, e.g. a shift along a straight, by millimetres a step)."""
MAX_REPAIRS = 6
"""Rounds of bound tightening where a row of the fitted line comes closer to an edge than the clearance."""
EDGE_TOL_M = 1e-3
"""A row may come this much closer to an edge than the clearance [m] (the check's own resolution)."""


@documented
@dataclass(frozen=True)
class RacingLineSpec:
    """How the racing line is solved: ``margin_m`` [m] kept between the car's body side and the track edge
    (besides its half width), ``step_m`` [m] the spacing of the optimisation nodes, ``max_iterations`` of the
    linearisation, ``tol_m`` [m] the largest change of an offset at which it has converged, ``ds_m`` [m] the row
    spacing of the returned line (None: the track's)."""

    margin_m: float = ranged(0.2, ge=0.0, le=5.0, unit="m")
    step_m: float = ranged(1.0, ge=0.25, le=10.0, unit="m")
    max_iterations: int = ranged(8, ge=1, le=50, integer=True)
    tol_m: float = ranged(1e-3, gt=0.0, le=1.0, unit="m")
    ds_m: float | None = ranged(None, ge=0.05, le=5.0, unit="m")

    def __post_init__(self) -> None:
        validate(self)


@dataclass(frozen=True, eq=False)
class RacingLine:
    """A solved racing line: ``path`` (the line, with half widths to the track edges), the ``track`` it lies on,
    the node ``stations_m`` [m] along the track and their ``offsets_m`` [m] (left-positive), the clearance
    ``clearance_m`` [m] (body half width + margin) the line keeps from each edge, ``min_edge_margin_m`` [m] the
    least distance of a row of the line to an edge minus the body half width, the linearisation ``iterations``,
    ``qp_iterations`` (Newton steps of all QPs), ``repairs`` (bound tightenings) and ``solve_time_s`` [s]."""

    path: Path
    track: Path
    stations_m: np.ndarray = field(repr=False)
    offsets_m: np.ndarray = field(repr=False)
    clearance_m: float
    min_edge_margin_m: float
    iterations: int
    qp_iterations: int
    repairs: int
    solve_time_s: float
    vehicle_name: str


@dataclass(frozen=True, eq=False)
class _Nodes:
    """The reference nodes: stations s [m], points r (N, 2) [m], unit left normals n (N, 2), bounds lo/hi [m]."""

    s: np.ndarray
    r: np.ndarray
    n: np.ndarray
    z: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    closed: bool


def _nodes(track: Path, spec: RacingLineSpec, clearance_m: float, vehicle_name: str) -> _Nodes:
    """The optimisation nodes of ``track`` every ``spec.step_m`` (closed: the end node is the start node, dropped)
    and their offset bounds; ValueError where the track is narrower than the car plus margins."""
    count = max(4 if track.closed else 3, round(track.length_m / spec.step_m))
    s = np.arange(count + (0 if track.closed else 1)) * (track.length_m / count)
    row = track.sample(s)
    n = np.column_stack((-np.sin(row.psi), np.cos(row.psi)))
    w_left, w_right = track.half_widths(s)
    lo, hi = -(w_right - clearance_m), w_left - clearance_m
    if np.any(lo > hi):
        k = int(np.argmax(lo - hi))
        raise ValueError(f"track {track.name!r} is too narrow for {vehicle_name!r} at s = {s[k]:.1f} m: drivable "
                         f"width {w_left[k] + w_right[k]:.3f} m < 2 x {clearance_m:.3f} m (body width plus twice "
                         "margin_m); lower margin_m, or use a narrower car")
    return _Nodes(s, np.column_stack((row.x, row.y)), n, row.z, lo, hi, track.closed)


def _residuals(nodes: _Nodes, alpha: np.ndarray, jacobian: bool = True) -> tuple[np.ndarray, object]:
    """The residuals r_j = sqrt(|p'_j|) kappa_j = (p'_j x p''_j) / |p'_j|^(5/2) of the line of offsets ``alpha``
    (sum r^2 = the integral of kappa^2 along the line) and, if asked, their sparse Jacobian in alpha (three entries
    a row: p' and p'' of node j depend on the offsets of j - 1, j, j + 1)."""
    from scipy.sparse import coo_matrix

    p = nodes.r + alpha[:, None] * nodes.n
    count = p.shape[0]
    rows = np.arange(count) if nodes.closed else np.arange(1, count - 1)
    prev, nxt = (rows - 1) % count, (rows + 1) % count
    d1 = 0.5 * (p[nxt] - p[prev])
    d2 = p[nxt] - 2.0 * p[rows] + p[prev]
    c = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    m = d1[:, 0] ** 2 + d1[:, 1] ** 2
    r = c * m ** -1.25
    if not jacobian:
        return r, None
    parts = []
    # d p'/d alpha and d p''/d alpha for the offsets of j - 1, j, j + 1: (coefficient of n in p', in p'')
    for col, w1, w2 in ((prev, -0.5, 1.0), (rows, 0.0, -2.0), (nxt, 0.5, 1.0)):
        n = nodes.n[col]
        dc = w1 * (n[:, 0] * d2[:, 1] - n[:, 1] * d2[:, 0]) + w2 * (d1[:, 0] * n[:, 1] - d1[:, 1] * n[:, 0])
        dm = 2.0 * w1 * (d1[:, 0] * n[:, 0] + d1[:, 1] * n[:, 1])
        parts.append(dc * m ** -1.25 - 1.25 * c * m ** -2.25 * dm)
    k = np.arange(rows.size)
    jac = coo_matrix((np.concatenate(parts), (np.tile(k, 3), np.concatenate((prev, rows, nxt)))),
                     shape=(rows.size, count))
    return r, jac.tocsr()


def _objective(nodes: _Nodes, alpha: np.ndarray) -> float:
    """sum r^2 + ``REGULARISATION`` sum alpha^2 (the integral of kappa^2 [1/m] plus the tie-break)."""
    r, _ = _residuals(nodes, alpha, jacobian=False)
    return float(np.einsum("i,i->", r, r) + REGULARISATION * np.einsum("i,i->", alpha, alpha))  # no BLAS threads


def _solve_offsets(nodes: _Nodes, spec: RacingLineSpec, alpha0: np.ndarray) -> tuple[np.ndarray, int, int]:
    """The offsets of the minimum-curvature line: Gauss-Newton steps (each a box QP of the residuals linearised
    about the current line) with a backtracking on the true objective; the linearisations and QP steps used."""
    from scipy.sparse import identity

    from vtrack_gym.tracks.box_qp import solve_box_qp

    alpha, qp_steps = np.clip(alpha0, nodes.lo, nodes.hi), 0
    value = _objective(nodes, alpha)
    for it in range(1, spec.max_iterations + 1):
        r, jac = _residuals(nodes, alpha)
        h = (jac.T @ jac + REGULARISATION * identity(alpha.size)).tocsr()
        f = jac.T @ (r - jac @ alpha)
        result = solve_box_qp(h, f, nodes.lo, nodes.hi)
        if not result.converged:
            raise RuntimeError(f"the racing-line QP did not converge (residual {result.residual:.3g} after "
                               f"{result.iterations} interior-point steps)")
        qp_steps += result.iterations
        step, delta = 1.0, result.x - alpha
        while step > 1e-3 and _objective(nodes, alpha + step * delta) > value:
            step *= 0.5
        change = float(np.max(np.abs(step * delta)))
        alpha = alpha + step * delta
        value, before = _objective(nodes, alpha), value
        if change < spec.tol_m or before - value <= RELATIVE_DECREASE * abs(before):
            return alpha, it, qp_steps
    return alpha, spec.max_iterations, qp_steps


def _line_path(track: Path, nodes: _Nodes, alpha: np.ndarray, ds_m: float) -> Path:
    """The racing line through the nodes' offset points (interpolating spline), without widths yet."""
    p = nodes.r + alpha[:, None] * nodes.n
    z = nodes.z if np.any(nodes.z != 0.0) else None
    return Path.from_points(p[:, 0], p[:, 1], z, closed=nodes.closed, ds_m=ds_m, half_width_m=track.half_width_m,
                            name=f"{track.name} racing line", version=track.version)


def _row_stations(nodes: _Nodes, alpha: np.ndarray, line: Path) -> np.ndarray:
    """Approximate station [m] on the track of every row of ``line``: the node stations interpolated against the
    nodes' chord length along the line (rescaled to the line's length)."""
    p = nodes.r + alpha[:, None] * nodes.n
    if nodes.closed:
        p = np.vstack((p, p[:1]))
        s_nodes = np.append(nodes.s, nodes.s[-1] + (nodes.s[1] - nodes.s[0]))
    else:
        s_nodes = nodes.s
    chord = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))))
    return np.interp(line.s_m * chord[-1] / line.length_m, chord, s_nodes)


def _row_clearance(track: Path, line: Path, stations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row's (left, right) signed distance [m] to the track's edges (``track_edges.edge_clearance``)."""
    from vtrack_gym.tracks.track_edges import edge_clearance

    return edge_clearance(track, line.table[:, tb.COL_X], line.table[:, tb.COL_Y], stations)


def _tighten(nodes: _Nodes, track: Path, stations: np.ndarray, short_left: np.ndarray,
             short_right: np.ndarray, spread: int) -> _Nodes:
    """The nodes with bounds tightened where rows of the line came too close to an edge: each short row's
    shortfall (plus ``EDGE_TOL_M``) taken off the bound of the two nodes around its station on the track and of
    ``spread`` more either side (the nearest edge point may lie beside the row's station: the sharp inner edge of a
    corner nearly as tight as the track is wide)."""
    lo, hi = nodes.lo.copy(), nodes.hi.copy()
    count = nodes.s.size
    step = track.length_m / (count if nodes.closed else count - 1)
    for short, bound, sign in ((short_left, hi, -1.0), (short_right, lo, 1.0)):
        rows = np.flatnonzero(short > 0.0)
        if rows.size == 0:
            continue
        s = stations[rows]
        base = np.floor(s / step).astype(np.int64)
        for j in (base + k for k in range(-spread, spread + 2)):
            j = j % count if nodes.closed else np.clip(j, 0, count - 1)
            np.add.at(bound, j, sign * (short[rows] + EDGE_TOL_M))
    if np.any(lo > hi):
        k = int(np.argmax(lo - hi))
        raise ValueError(f"track {track.name!r}: no room for the line at s = {nodes.s[k]:.1f} m once the edges' "
                         "bends are allowed for; lower margin_m")
    return replace(nodes, lo=lo, hi=hi)


def solve_racing_line(track: object, vehicle: object = None, spec: RacingLineSpec | None = None) -> RacingLine:
    """The minimum-curvature racing line of ``track`` (a ``Path``, a built-in name or a track file:
    ``tracks.load_track``) for ``vehicle`` (``VehicleParams``, a shipped car's name or a vehicle file; None: the
    paper's car), as the module docstring says. ValueError if the track is too narrow for the car."""
    from vtrack_gym.tracks.sources import load_track
    from vtrack_gym.vehicle.catalog import resolve_vehicle

    spec = RacingLineSpec() if spec is None else spec
    if not isinstance(spec, RacingLineSpec):
        raise ValueError(f"spec must be a RacingLineSpec (got {type(spec).__name__})")
    start = time.perf_counter()
    path = load_track(track)
    car = resolve_vehicle(vehicle)
    clearance = 0.5 * car.chassis.body_width_m + spec.margin_m
    nodes = _nodes(path, spec, clearance, car.name)
    ds = path.ds_m if spec.ds_m is None else spec.ds_m
    alpha, iterations, qp_steps = _solve_offsets(nodes, spec, np.zeros(nodes.s.size))
    repairs = 0
    while True:
        line = _line_path(path, nodes, alpha, ds)
        stations = _row_stations(nodes, alpha, line)
        left, right = _row_clearance(path, line, stations)
        short_left, short_right = clearance - left, clearance - right
        if max(float(short_left.max()), float(short_right.max())) <= EDGE_TOL_M or repairs == MAX_REPAIRS:
            break
        nodes = _tighten(nodes, path, stations, short_left, short_right, repairs)
        alpha, more, steps = _solve_offsets(nodes, spec, alpha)
        iterations, qp_steps, repairs = iterations + more, qp_steps + steps, repairs + 1
    widths = np.column_stack((left, right))
    if line.closed:
        widths[-1] = widths[0]
    if float(widths.min()) <= 0.0:
        raise ValueError(f"the racing line of {path.name!r} leaves the track (a row {widths.min():.3f} m beyond "
                         "an edge); lower step_m")
    line = replace(line, widths_m=np.minimum(widths, 100.0))
    margin = float(widths.min()) - 0.5 * car.chassis.body_width_m
    return RacingLine(line, path, nodes.s, alpha, clearance, margin, iterations, qp_steps, repairs,
                      time.perf_counter() - start, car.name)


def racing_line(track: object, vehicle: object = None, *, margin_m: float = 0.2, step_m: float = 1.0,
                max_iterations: int = 8, ds_m: float | None = None) -> Path:
    """The minimum-curvature racing line of ``track`` for ``vehicle`` as a ``Path`` whose half widths are its
    distances to the track's edges; ``margin_m`` [m] kept between the body side and an edge, nodes every
    ``step_m`` [m] (``RacingLineSpec``; :func:`solve_racing_line` returns the offsets and solve figures too)."""
    spec = RacingLineSpec(margin_m=margin_m, step_m=step_m, max_iterations=max_iterations, ds_m=ds_m)
    return solve_racing_line(track, vehicle, spec).path


__all__ = ["RacingLine", "RacingLineSpec", "racing_line", "solve_racing_line"]
