"""The exact geometry judge: the body as its rectangle, cones as discs, track edges as polylines, cone gates as
boxes.

Every rule that asks "did the car touch X" asks it here (track limits and cones on a track: ``judge_edges``,
``judge_cones``; the anchored cone gates of ISO 3888: ``tracks.gate_judge``, which sweeps ``rect_gate`` through
``sweep_min``), in the body frame of the car's data: the rectangle from
``cg_to_front_end_m`` ahead of the CG to ``body_length_m - cg_to_front_end_m`` behind it, ``body_width_m / 2`` to
each side; the wheel contact points at (``cg_to_front_axle_m``, +-``track_width_m / 2``) and
(-``cg_to_rear_axle_m``, +-``track_width_m / 2``).

Clearances are signed distances [m]: positive is the gap between the body (or a point) and the object, negative
how far it reaches into it. Exact closed forms:

- point to rectangle: the Euclidean distance outside, minus the distance to the nearest side inside;
- rectangle to disc (a cone of radius r): point-to-rectangle of the cone's centre minus r;
- point to polyline (a track edge): the distance to the nearest segment, signed by the side of the edge it lies on
  along the centre line's normal there (robust where a tight bend folds an inner edge onto itself); an open
  road's edges go on straight before its first row and after its last (its approach and run-out);
- rectangle to polyline: the least of the corners' signed distances and of the polyline vertices' signed
  distances to the rectangle (the gap between two polygonal chains is attained at a vertex of one of them; a
  crossing puts a corner beyond the edge or a vertex inside the body);
- rectangle to an anchored gate (``rect_gate``; a row of ``gate_judge.gate_table``): in the gate's frame (u along
  the lane, v to the left) the body has left the lane exactly when its rectangle meets one of the two forbidden
  boxes u in [0, L], v >= y_left or v <= y_right (``FAR_M`` deep); the clearance is the signed distance to the
  nearer box: the gap between the two convex polygons when apart (attained at a vertex of one of them), minus the
  penetration depth when they overlap (the separating-axis value over the four edge normals).

Between two control steps the pose is interpolated linearly in (x, y, psi) (``sweep_min``), and each clearance is
minimised over the interval by branch and bound: a body point moves at most L = |dp| + |dpsi| r_max over the
step (r_max: the farthest body point from the CG), every clearance is 1-Lipschitz in the points, so on a
sub-interval [a, b] with end values fa, fb no value lies below (fa + fb - L (b - a)) / 2. Intervals whose bound
could still beat the best value found by more than ``tol`` (1 mm) are halved. The result is a clearance that
was reached at a sampled pose and lies within ``tol`` of the true minimum along the interpolated motion: sub-stepped
adaptively, exact to 1 mm (a search may stop earlier once nothing below a ``floor`` can be missed: a rule needs only
the sign of its clearance, a margin only its values near an edge, ``EXACT_BELOW_M``). The interpolated pose leaves
the simulated one by at most the chord's sagitta, (v dt)^2 / (8 R): 0.1 mm at 120 km/h on a 110 m radius, 0.7 mm
at 54 km/h on a 4 m hairpin (10 ms steps).
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel

SWEEP_TOL_M = 1e-3
"""Tolerance of ``sweep_min`` [m]: the least clearance along a step is found to within this."""
EXACT_BELOW_M = 0.5
"""``judge_edges``: the body's clearance to an edge is exact to ``SWEEP_TOL_M`` wherever it is below this [m];
farther from the edges it is the least value sampled along the step (the step's travel at most above the exact
one). A rule's measure is searched for its sign alone (exact to ``SWEEP_TOL_M`` around 0)."""
MAX_SWEEP_EVALS = 4096
"""Safety cap on clearance evaluations per sweep (a 1 mm search needs a few dozen)."""

MEASURE_CENTRE, MEASURE_WHEELS, MEASURE_BODY, MEASURE_CONES, MEASURE_GATES = 0, 1, 2, 3, 4
"""What ``sweep_min`` measures: the CG's least signed distance to an edge; the largest over the four wheel
contact points of each one's least signed distance to an edge (negative: all four beyond an edge); the body
rectangle's least clearance to an edge (the first three: ``pose_measure``); the body rectangle's least clearance
to the cones (discs) or to the anchored gates (``rect_gate``) of its ``objects`` rows."""
FAR_M = 1.0e3
"""Depth of a gate's forbidden box beyond its cone line [m] (a body never reaches that far past a lane)."""

N_BODY = 11
"""Entries of a body row (``body_row``): front, rear, half width [m]; four wheel points (lon, lat) [m]."""


def body_row(chassis: object) -> np.ndarray:
    """The (N_BODY,) float64 row of a ``ChassisParams``: body front/rear/half width, wheel contact points [m]."""
    c = chassis
    front = float(c.cg_to_front_end_m)
    rear = front - float(c.body_length_m)
    half = 0.5 * float(c.body_width_m)
    a, b, t = float(c.cg_to_front_axle_m), float(c.cg_to_rear_axle_m), 0.5 * float(c.track_width_m)
    return np.array([front, rear, half, a, t, a, -t, -b, t, -b, -t], dtype=np.float64)


@kernel
def reach_m(body: np.ndarray) -> float:
    """Farthest distance [m] from the CG of a body corner, and of a wheel point when ``body`` is a full
    ``body_row`` (N_BODY entries); a 3-entry row (front, rear, half width [m]) is read in its own entries only."""
    r = math.hypot(max(body[0], -body[1]), body[2])
    if body.shape[0] >= N_BODY:
        for w in range(4):
            r = max(r, math.hypot(body[3 + 2 * w], body[4 + 2 * w]))
    return r


@kernel
def point_rect(px: float, py: float, x: float, y: float, psi: float, front: float, rear: float,
               half: float) -> float:
    """Signed distance [m] from point (px, py) to the rectangle of a car at (x, y, psi): + outside, - inside."""
    c = math.cos(psi)
    s = math.sin(psi)
    dx = px - x
    dy = py - y
    lon = c * dx + s * dy
    lat = -s * dx + c * dy
    mid = 0.5 * (front + rear)
    hl = 0.5 * (front - rear)
    qx = abs(lon - mid) - hl
    qy = abs(lat) - half
    if qx > 0.0 or qy > 0.0:
        return math.hypot(max(qx, 0.0), max(qy, 0.0))
    return max(qx, qy)


@kernel
def rect_disc(x: float, y: float, psi: float, front: float, rear: float, half: float, cx: float, cy: float,
              radius: float) -> float:
    """Clearance [m] between a car's rectangle and a disc (cone) of ``radius`` at (cx, cy); negative: overlap."""
    return point_rect(cx, cy, x, y, psi, front, rear, half) - radius


@kernel
def _rect_box(cu: np.ndarray, cv: np.ndarray, ax: float, ay: float, u0: float, u1: float, v0: float,
              v1: float) -> float:
    """Signed distance [m] between the rectangle of corners (cu, cv) (4,) whose long axis is (ax, ay) and the box
    [u0, u1] x [v0, v1]: + the gap, - the penetration depth."""
    sep = -math.inf
    for k in range(4):   # the separating-axis value over the box's axes and the rectangle's
        if k == 0:
            nx, ny = 1.0, 0.0
        elif k == 1:
            nx, ny = 0.0, 1.0
        elif k == 2:
            nx, ny = ax, ay
        else:
            nx, ny = -ay, ax
        pmin, pmax = math.inf, -math.inf
        for j in range(4):
            p = cu[j] * nx + cv[j] * ny
            pmin, pmax = min(pmin, p), max(pmax, p)
        qmin, qmax = math.inf, -math.inf
        for bu in (u0, u1):
            for bv in (v0, v1):
                q = bu * nx + bv * ny
                qmin, qmax = min(qmin, q), max(qmax, q)
        sep = max(sep, max(qmin - pmax, pmin - qmax))
    if sep < 0.0:
        return sep
    best = math.inf
    for j in range(4):   # rectangle corners to the box
        du = max(u0 - cu[j], 0.0, cu[j] - u1)
        dv = max(v0 - cv[j], 0.0, cv[j] - v1)
        best = min(best, math.hypot(du, dv))
    for bu in (u0, u1):   # box corners to the rectangle's edges
        for bv in (v0, v1):
            for j in range(4):
                i = (j + 1) % 4
                ex, ey = cu[i] - cu[j], cv[i] - cv[j]
                t = ((bu - cu[j]) * ex + (bv - cv[j]) * ey) / (ex * ex + ey * ey)
                t = min(1.0, max(0.0, t))
                best = min(best, math.hypot(bu - cu[j] - t * ex, bv - cv[j] - t * ey))
    return best


@kernel
def rect_gate(x: float, y: float, psi: float, front: float, rear: float, half: float, gate: np.ndarray) -> float:
    """Clearance [m] of a car's rectangle at (x, y, psi) to the cone lines of one anchored gate (a row: anchor x,
    y [m], heading [rad], length [m], left and right cone-line offsets [m]): + the gap to the nearer forbidden box,
    - how far the body reaches into it (module docstring)."""
    c0, s0 = math.cos(gate[2]), math.sin(gate[2])
    dx, dy = x - gate[0], y - gate[1]
    u, v = c0 * dx + s0 * dy, -s0 * dx + c0 * dy
    c, s = math.cos(psi - gate[2]), math.sin(psi - gate[2])
    cu = np.empty(4)
    cv = np.empty(4)
    k = 0
    for lon, lat in ((front, half), (rear, half), (rear, -half), (front, -half)):
        cu[k] = u + c * lon - s * lat
        cv[k] = v + s * lon + c * lat
        k += 1
    left = _rect_box(cu, cv, c, s, 0.0, gate[3], gate[4], gate[4] + FAR_M)
    return min(left, _rect_box(cu, cv, c, s, 0.0, gate[3], gate[5] - FAR_M, gate[5]))


@kernel
def _segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> tuple[float, float, float]:
    """(squared distance, cross, t) of point p to segment a-b: cross = (b - a) x (p - a), t the fraction of the
    foot of the perpendicular on the line a-b (outside [0, 1]: the nearest point is an end)."""
    ux = bx - ax
    uy = by - ay
    vx = px - ax
    vy = py - ay
    uu = ux * ux + uy * uy
    t = 0.0 if uu <= 0.0 else (ux * vx + uy * vy) / uu
    tc = min(1.0, max(0.0, t))
    dx = vx - tc * ux
    dy = vy - tc * uy
    return dx * dx + dy * dy, ux * vy - uy * vx, t


@kernel
def _vertex(k: int, n: int, closed: bool) -> int:
    """Row of polyline vertex k (wrapped modulo n - 1 on a closed polyline, clamped to [0, n - 1] on an open one)."""
    if closed:
        return k % (n - 1)
    return min(max(k, 0), n - 1)


@kernel
def point_polyline(px: float, py: float, ex: np.ndarray, ey: np.ndarray, nx: np.ndarray, ny: np.ndarray, i0: int,
                   i1: int, closed: bool, side: float) -> float:
    """Signed distance [m] from a point to the polyline through rows i0..i1 of (ex, ey) (wrapped modulo n - 1
    on a closed polyline whose last row repeats the first): + on the track's side, - beyond it. The side is read
    along the centre line's normal (nx, ny) (left-pointing, per row) at the nearest point: ``side`` -1 for a left
    edge (the track lies against the normal), +1 for a right one. Read this way the sign stays right where a
    tight bend folds an inner edge back on itself (a half width above the bend's radius)."""
    n = ex.shape[0]
    best = math.inf
    best_k = i0
    best_t = 0.5
    best_cross = 0.0
    a = _vertex(i0, n, closed)
    for k in range(i0, i1):
        b = a + 1 if a + 1 < n else 1    # a closed polyline's last row repeats its first
        d2, cross, t = _segment(px, py, ex[a], ey[a], ex[b], ey[b])
        if d2 < best:
            best, best_k, best_t, best_cross = d2, k, t, cross
        a = b
    best = math.sqrt(best)
    a = _vertex(best_k, n, closed)
    b = a + 1 if a + 1 < n else 1
    if not closed and ((best_k == 0 and best_t < 0.0) or (best_k == n - 2 and best_t > 1.0)):
        # beyond an open road's first or last row: the edge goes on straight (an approach, a run-out)
        best = abs(best_cross) / math.hypot(ex[b] - ex[a], ey[b] - ey[a])
    tc = min(1.0, max(0.0, best_t))
    qx = ex[a] + tc * (ex[b] - ex[a])
    qy = ey[a] + tc * (ey[b] - ey[a])
    mx = nx[a] + tc * (nx[b] - nx[a])
    my = ny[a] + tc * (ny[b] - ny[a])
    if best_t < 0.0 or best_t > 1.0:   # beyond a ray's end: measure along the end row's normal
        qx, qy = (ex[a], ey[a]) if best_t < 0.0 else (ex[b], ey[b])
    outward = (px - qx) * mx + (py - qy) * my      # > 0: on the normal's side of the edge
    return best if side * outward >= 0.0 else -best


@kernel
def rect_polyline(x: float, y: float, psi: float, front: float, rear: float, half: float, ex: np.ndarray,
                  ey: np.ndarray, nx: np.ndarray, ny: np.ndarray, i0: int, i1: int, closed: bool,
                  side: float) -> float:
    """Clearance [m] of a car's rectangle to the track edge through rows i0..i1 (see ``point_polyline``):
    the gap while the whole body is on the track's side, negative once any part reaches beyond the edge."""
    c = math.cos(psi)
    s = math.sin(psi)
    best = math.inf
    for lon in (front, rear):
        for lat in (half, -half):
            best = min(best, point_polyline(x + c * lon - s * lat, y + s * lon + c * lat, ex, ey, nx, ny, i0, i1,
                                            closed, side))
    n = ex.shape[0]
    for k in range(i0, i1 + 1):
        v = _vertex(k, n, closed)
        best = min(best, point_rect(ex[v], ey[v], x, y, psi, front, rear, half))
    return best


@kernel
def _point_edges(px: float, py: float, edges: np.ndarray, i0: int, i1: int, closed: bool) -> float:
    """Least signed distance [m] of a point to the left edge (rows edges[:, 0:2]) and the right one (2:4)."""
    left = point_polyline(px, py, edges[:, 0], edges[:, 1], edges[:, 4], edges[:, 5], i0, i1, closed, -1.0)
    return min(left, point_polyline(px, py, edges[:, 2], edges[:, 3], edges[:, 4], edges[:, 5], i0, i1, closed, 1.0))


@kernel
def pose_measure(mode: int, x: float, y: float, psi: float, body: np.ndarray, edges: np.ndarray, i0: int, i1: int,
                 closed: bool) -> float:
    """The ``MEASURE_*`` clearance [m] of a car at (x, y, psi) to the edges (n, 6): ``edge_polylines``."""
    if mode == MEASURE_CENTRE:
        return _point_edges(x, y, edges, i0, i1, closed)
    if mode == MEASURE_WHEELS:
        c = math.cos(psi)
        s = math.sin(psi)
        most = -math.inf
        for w in range(4):
            lon = body[3 + 2 * w]
            lat = body[4 + 2 * w]
            most = max(most, _point_edges(x + c * lon - s * lat, y + s * lon + c * lat, edges, i0, i1, closed))
        return most
    left = rect_polyline(x, y, psi, body[0], body[1], body[2], edges[:, 0], edges[:, 1], edges[:, 4], edges[:, 5],
                         i0, i1, closed, -1.0)
    return min(left, rect_polyline(x, y, psi, body[0], body[1], body[2], edges[:, 2], edges[:, 3], edges[:, 4],
                                   edges[:, 5], i0, i1, closed, 1.0))


@kernel
def _wrap(a: float) -> float:
    """Angle a [rad] wrapped to [-pi, pi]."""
    return a - 2.0 * math.pi * math.floor(a / (2.0 * math.pi) + 0.5)


@kernel
def _push(stack: np.ndarray, k: int, a: float, b: float, fa: float, fb: float) -> None:
    """Row k of the search stack := (a, b, fa, fb)."""
    stack[k, 0] = a
    stack[k, 1] = b
    stack[k, 2] = fa
    stack[k, 3] = fb


@kernel
def _measure_at(t: float, mode: int, pose0: np.ndarray, pose1: np.ndarray, body: np.ndarray, edges: np.ndarray,
                i0: int, i1: int, closed: bool, objects: np.ndarray) -> float:
    """The ``mode`` clearance at fraction t of the step (pose linear in x, y and the wrapped heading change)."""
    dpsi = _wrap(pose1[2] - pose0[2])
    x = pose0[0] + t * (pose1[0] - pose0[0])
    y = pose0[1] + t * (pose1[1] - pose0[1])
    psi = pose0[2] + t * dpsi
    if mode == MEASURE_CONES:
        best = math.inf
        for k in range(objects.shape[0]):
            best = min(best, rect_disc(x, y, psi, body[0], body[1], body[2], objects[k, 0], objects[k, 1],
                                       objects[k, 2]))
        return best
    if mode == MEASURE_GATES:
        best = math.inf
        for k in range(objects.shape[0]):
            best = min(best, rect_gate(x, y, psi, body[0], body[1], body[2], objects[k]))
        return best
    return pose_measure(mode, x, y, psi, body, edges, i0, i1, closed)


@kernel
def sweep_min(mode: int, pose0: np.ndarray, pose1: np.ndarray, body: np.ndarray, edges: np.ndarray, i0: int, i1: int,
              closed: bool, objects: np.ndarray, tol: float, floor: float = math.inf,
              start: float = math.nan) -> tuple[float, float]:
    """(least clearance along the step, clearance at its end) [m] of a car moving from ``pose0`` to ``pose1``
    ((3,): x, y [m], psi [rad]): the ``mode`` measure, against the edges (``edges``, rows i0..i1), the cones
    (``MEASURE_CONES``: ``objects`` (K, 3) x, y, radius [m]) or the anchored gates (``MEASURE_GATES``: ``objects``
    (G, 6) rows of ``gate_judge.gate_table``). ``body``: a ``body_row``, or (cones, gates) its first 3 entries.
    The least value is within ``tol`` [m] of the exact one wherever it lies below
    ``floor`` [m] (module docstring); above it, it is the least value sampled (the search stops once no
    sub-interval can hold a value below ``floor``: a rule needs the sign, a margin the values near an edge).
    ``start``: the clearance at ``pose0`` when known (the last step's end value), NaN to compute it."""
    reach = reach_m(body)
    lip = math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1]) + \
        abs(_wrap(pose1[2] - pose0[2])) * reach
    f0 = start if start == start else _measure_at(0.0, mode, pose0, pose1, body, edges, i0, i1, closed, objects)
    f1 = _measure_at(1.0, mode, pose0, pose1, body, edges, i0, i1, closed, objects)
    best = min(f0, f1)
    stack = np.empty((64, 4))   # intervals still to search: a, b, f(a), f(b)
    _push(stack, 0, 0.0, 1.0, f0, f1)
    top = 1
    evals = 2
    while top > 0 and evals < MAX_SWEEP_EVALS:
        top -= 1
        a, b, fa, fb = stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3]
        if 0.5 * (fa + fb - lip * (b - a)) >= min(best, floor) - tol or top >= 62:
            continue
        m = 0.5 * (a + b)
        fm = _measure_at(m, mode, pose0, pose1, body, edges, i0, i1, closed, objects)
        evals += 1
        best = min(best, fm)
        _push(stack, top, m, b, fm, fb)
        _push(stack, top + 1, a, m, fa, fm)
        top += 2
    return best, f1


def edge_polylines(path: object) -> np.ndarray:
    """The (n, 6) track edges of a ``tracks.Path``: left x, y and right x, y [m] at every table row (the centre
    line offset by the per-station half widths along its normal), the polylines the judge measures against, and
    the centre line's left-pointing unit normal x, y there (the side a point lies on)."""
    from vtrack_gym.tracks.table import COL_PSI, COL_X, COL_Y

    t = path.table
    w = path.half_widths_rows()
    nx, ny = -np.sin(t[:, COL_PSI]), np.cos(t[:, COL_PSI])
    out = np.empty((t.shape[0], 6))
    out[:, 4] = nx
    out[:, 5] = ny
    out[:, 0] = t[:, COL_X] + w[:, 0] * nx
    out[:, 1] = t[:, COL_Y] + w[:, 0] * ny
    out[:, 2] = t[:, COL_X] - w[:, 1] * nx
    out[:, 3] = t[:, COL_Y] - w[:, 1] * ny
    return out


@kernel
def _window(s0: float, s1: float, pad: float, ds: float, n: int, closed: bool) -> tuple[int, int]:
    """Rows (i0, i1) of the edge polylines within ``pad`` [m] of stations s0..s1 [m] (clamped on an open path,
    unwrapped on a closed one: ``_vertex`` wraps them; at most one lap)."""
    lo = min(s0, s1)
    hi = max(s0, s1)
    if closed and hi - lo > 0.5 * (n - 1) * ds:   # the step crossed the start line: s1 wrapped past it
        lo, hi = hi, lo + (n - 1) * ds
    i0 = math.floor((lo - pad) / ds)
    i1 = math.ceil((hi + pad) / ds)
    if closed:
        return i0, min(i1, i0 + n - 1)
    return max(i0, 0), min(max(i1, 1), n - 1)


@kernel
def judge_edges(mode: int, edges: np.ndarray, ds: float, closed: bool, body: np.ndarray, idx: np.ndarray,
                prev: np.ndarray, x: np.ndarray, y: np.ndarray, psi: np.ndarray, s: np.ndarray, tol: float,
                rule_min: np.ndarray, rule_end: np.ndarray, body_min: np.ndarray, body_end: np.ndarray,
                known: np.ndarray) -> None:
    """For each car i in ``idx``, moving over the last step from ``prev[i]`` (x, y [m], psi [rad], station [m])
    to (x[i], y[i], psi[i]) at station s[i]: ``rule_min[i]`` / ``rule_end[i]`` the least / final ``mode``
    measure (its sign exact to ``tol``) and ``body_min[i]`` the body's least clearance to the edges (n, 6) [m]
    along the step (exact to ``tol`` below ``EXACT_BELOW_M``; ``sweep_min``), ``body_end[i]`` its value at the end.
    Where ``known[i]``, ``rule_end[i]`` and ``body_end[i]`` hold the last step's end values (this step's start)."""
    n = edges.shape[0]
    pad = 1.5 * reach_m(body) + 1.0   # edge rows near the body (an inner edge's rows lie closer than its stations)
    none = np.zeros((0, 3))
    pose0 = np.empty(3)
    pose1 = np.empty(3)
    for i in idx:
        pose0[0], pose0[1], pose0[2] = prev[i, 0], prev[i, 1], prev[i, 2]
        pose1[0], pose1[1], pose1[2] = x[i], y[i], psi[i]
        pad_i = pad + math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1])
        i0, i1 = _window(prev[i, 3], s[i], pad_i, ds, n, closed)
        least, last = sweep_min(MEASURE_BODY, pose0, pose1, body, edges, i0, i1, closed, none, tol, EXACT_BELOW_M,
                                body_end[i] if known[i] else math.nan)
        body_min[i] = least
        body_end[i] = last
        if mode != MEASURE_BODY:
            least, last = sweep_min(mode, pose0, pose1, body, edges, i0, i1, closed, none, tol, 0.0,
                                    rule_end[i] if known[i] else math.nan)
        rule_min[i] = least
        rule_end[i] = last


@kernel
def judge_cones(cones: np.ndarray, body: np.ndarray, idx: np.ndarray, prev: np.ndarray, x: np.ndarray,
                y: np.ndarray, psi: np.ndarray, tol: float, hit: np.ndarray) -> None:
    """``hit[i, k] = True`` where car i's body, moving over the last step from ``prev[i]`` (x, y [m], psi [rad])
    to (x[i], y[i], psi[i]), touched cone k (``cones`` (K, 3): x, y, radius [m]; a disc; exact to ``tol``). Only the
    cones within reach of the step are swept; ``hit`` (N, K) is only ever set to True."""
    reach = reach_m(body)
    pose0 = np.empty(3)
    pose1 = np.empty(3)
    one = np.empty((1, 3))
    none = np.zeros((1, 6))
    for i in idx:
        pose0[0], pose0[1], pose0[2] = prev[i, 0], prev[i, 1], prev[i, 2]
        pose1[0], pose1[1], pose1[2] = x[i], y[i], psi[i]
        near = reach + math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1])
        for k in range(cones.shape[0]):
            if hit[i, k] or math.hypot(cones[k, 0] - pose1[0], cones[k, 1] - pose1[1]) > near + cones[k, 2]:
                continue
            one[0, 0], one[0, 1], one[0, 2] = cones[k, 0], cones[k, 1], cones[k, 2]
            least, _ = sweep_min(MEASURE_CONES, pose0, pose1, body, none, 0, 0, False, one, tol, 0.0)
            if least < 0.0:
                hit[i, k] = True
