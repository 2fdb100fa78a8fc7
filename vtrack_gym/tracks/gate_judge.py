"""The exact judge of anchored cone gates (ISO 3888 lanes): the body rectangle against each lane's cone lines.

An anchored gate (``Gate.anchor``: x0, y0 [m], psi0 [rad]; ``lane_length_m``; ``y_left_m`` / ``y_right_m`` the
cone lines' offsets from the anchor line) is a lane of fixed position: the body must stay between its cone lines
while any part of it is within the lane's length. In the gate's frame (u along the lane from its first cones, v to
the left) the body has left the lane exactly when its rectangle meets one of the two forbidden boxes
u in [0, L], v >= y_left (beyond the left cone line) or v <= y_right (beyond the right one). The clearance
(``rect_gate``) is the signed distance between the rectangle and the nearer box: the Euclidean gap between the two
convex polygons when apart (the least vertex-to-polygon distance: the gap between convex polygons is attained at a
vertex of one of them), minus the penetration depth when they overlap (the separating-axis value over the four
edge normals, exact for convex polygons). It is 1-Lipschitz in the body's points, so between two control steps
(pose linear in x, y, psi, as ``tracks.judge.sweep_min``) the least value is found by the same branch and bound,
exact to ``tol`` (1 mm for a verdict; the planner checks its lines to 0.1 mm).
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel

FAR_M = 1.0e3
"""Depth of a forbidden box beyond its cone line [m] (a body never reaches that far past a lane)."""
N_GATE = 6
"""Entries of a gate row (``gate_table``): anchor x, y [m], heading [rad], length [m], left and right cone-line
offsets [m]."""


def gate_table(gates: tuple) -> np.ndarray:
    """The (G, N_GATE) rows of anchored ``gates`` (``tracks.path.Gate``); ValueError naming a gate without an
    anchor (a gate that moves with the centre line has no fixed cone lines to judge exactly)."""
    out = np.empty((len(gates), N_GATE))
    for k, g in enumerate(gates):
        if g.anchor is None:
            raise ValueError(f"gate {g.name or k!r} has no anchor: the exact gate judge needs gates at fixed "
                             "positions (Gate.anchor)")
        out[k] = (g.anchor[0], g.anchor[1], g.anchor[2], g.lane_length_m, g.y_left_m, g.y_right_m)
    return out


@kernel
def rect_reach_m(body: np.ndarray) -> float:
    """Farthest distance [m] of a corner of the rectangle ``body`` (front, rear, half width [m]; 3 entries) from
    the CG. Reads those three entries only (``tracks.judge.reach_m`` also reads the wheel points of its 11-entry
    row: on this row it read beyond the array, and the gate verdicts depended on the memory behind it)."""
    return math.hypot(max(body[0], -body[1]), body[2])


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
    """Clearance [m] of a car's rectangle at (x, y, psi) to the cone lines of one anchored gate (a row of
    ``gate_table``): + the gap to the nearer forbidden box, - how far the body reaches into it."""
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
def _at(t: float, pose0: np.ndarray, pose1: np.ndarray, body: np.ndarray, gate: np.ndarray) -> float:
    dpsi = pose1[2] - pose0[2]
    dpsi -= 2.0 * math.pi * math.floor(dpsi / (2.0 * math.pi) + 0.5)
    return rect_gate(pose0[0] + t * (pose1[0] - pose0[0]), pose0[1] + t * (pose1[1] - pose0[1]),
                     pose0[2] + t * dpsi, body[0], body[1], body[2], gate)


@kernel
def sweep_gate(pose0: np.ndarray, pose1: np.ndarray, body: np.ndarray, gate: np.ndarray, tol: float,
               floor: float) -> float:
    """Least clearance [m] to ``gate`` of a car moving from ``pose0`` to ``pose1`` (x, y [m], psi [rad]; pose
    linear in between), within ``tol`` [m] of the exact value wherever it lies below ``floor`` [m] (branch and
    bound on the 1-Lipschitz clearance, as ``tracks.judge.sweep_min``)."""
    dpsi = pose1[2] - pose0[2]
    dpsi -= 2.0 * math.pi * math.floor(dpsi / (2.0 * math.pi) + 0.5)
    lip = math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1]) + abs(dpsi) * rect_reach_m(body)
    f0 = _at(0.0, pose0, pose1, body, gate)
    f1 = _at(1.0, pose0, pose1, body, gate)
    best = min(f0, f1)
    stack = np.empty((64, 4))
    stack[0, 0], stack[0, 1], stack[0, 2], stack[0, 3] = 0.0, 1.0, f0, f1
    top = 1
    evals = 2
    while top > 0 and evals < 4096:
        top -= 1
        a, b, fa, fb = stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3]
        if 0.5 * (fa + fb - lip * (b - a)) >= min(best, floor) - tol or top >= 62:
            continue
        m = 0.5 * (a + b)
        fm = _at(m, pose0, pose1, body, gate)
        evals += 1
        best = min(best, fm)
        stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3] = m, b, fm, fb
        stack[top + 1, 0], stack[top + 1, 1], stack[top + 1, 2], stack[top + 1, 3] = a, m, fa, fm
        top += 2
    return best


@kernel
def judge_gates(gates: np.ndarray, body: np.ndarray, idx: np.ndarray, prev: np.ndarray, x: np.ndarray,
                y: np.ndarray, psi: np.ndarray, tol: float, hit: np.ndarray, least: np.ndarray) -> None:
    """For each car i in ``idx`` moving over the last step from ``prev[i]`` (x, y [m], psi [rad]) to
    (x[i], y[i], psi[i]): ``hit[i, g] = True`` where its body reached beyond a cone line of gate g (exact to
    ``tol``), ``least[i]`` lowered to its least clearance to any gate near it [m]. Gates farther than the body's
    reach plus the step are skipped."""
    reach = rect_reach_m(body)
    pose0 = np.empty(3)
    pose1 = np.empty(3)
    for i in idx:
        pose0[0], pose0[1], pose0[2] = prev[i, 0], prev[i, 1], prev[i, 2]
        pose1[0], pose1[1], pose1[2] = x[i], y[i], psi[i]
        near = reach + math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1])
        for g in range(gates.shape[0]):
            c0, s0 = math.cos(gates[g, 2]), math.sin(gates[g, 2])
            u = c0 * (pose1[0] - gates[g, 0]) + s0 * (pose1[1] - gates[g, 1])
            if u < -near or u > gates[g, 3] + near:
                continue
            f = sweep_gate(pose0, pose1, body, gates[g], tol, 0.05)
            least[i] = min(least[i], f)
            if f < 0.0:
                hit[i, g] = True


def path_gate_clearance_m(path: object, body: np.ndarray, tol: float = 1e-4, step_m: float = 0.01,
                          pose: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                          floor_m: float = 0.2) -> np.ndarray:
    """Least clearance [m] to each anchored gate of ``path`` (G,) of a car whose CG follows the path exactly,
    heading along it (a perfect follower), swept between poses ``step_m`` [m] of arc length apart (the path's
    interpolation), exact to ``tol`` [m] below ``floor_m`` [m]. ``pose``: the follower's (x, y, psi) arrays
    instead."""
    gates = gate_table(path.gates)  # type: ignore[attr-defined]
    if pose is None:
        s = np.linspace(0.0, path.length_m, max(2, math.ceil(path.length_m / step_m) + 1))  # type: ignore[attr-defined]
        row = path.sample(s)  # type: ignore[attr-defined]
        pose = (row.x, row.y, row.psi)
    x, y, psi = (np.ascontiguousarray(a, dtype=float) for a in pose)
    least = np.full(gates.shape[0], math.inf)
    _path_sweep(gates, np.ascontiguousarray(body, dtype=float), x, y, psi, tol, float(floor_m), least)
    return least


@kernel
def _path_sweep(gates: np.ndarray, body: np.ndarray, x: np.ndarray, y: np.ndarray, psi: np.ndarray, tol: float,
                floor: float, least: np.ndarray) -> None:
    reach = rect_reach_m(body)
    pose0 = np.empty(3)
    pose1 = np.empty(3)
    for k in range(x.shape[0] - 1):
        pose0[0], pose0[1], pose0[2] = x[k], y[k], psi[k]
        pose1[0], pose1[1], pose1[2] = x[k + 1], y[k + 1], psi[k + 1]
        for g in range(gates.shape[0]):
            c0, s0 = math.cos(gates[g, 2]), math.sin(gates[g, 2])
            u = c0 * (x[k] - gates[g, 0]) + s0 * (y[k] - gates[g, 1])
            if u < -reach - 1.0 or u > gates[g, 3] + reach + 1.0:
                continue
            least[g] = min(least[g], sweep_gate(pose0, pose1, body, gates[g], tol, floor))


__all__ = ["FAR_M", "N_GATE", "gate_table", "judge_gates", "path_gate_clearance_m", "rect_gate", "rect_reach_m",
           "sweep_gate"]
