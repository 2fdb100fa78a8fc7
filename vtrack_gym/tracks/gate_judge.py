"""The ISO 3888 cone-gate criterion's use of the exact geometry judge (``tracks.judge``): anchored gates as rows,
and the body swept against each lane's cone lines.

An anchored gate (``Gate.anchor``: x0, y0 [m], psi0 [rad]; ``lane_length_m``; ``y_left_m`` / ``y_right_m`` the
cone lines' offsets from the anchor line) is a lane of fixed position: the body must stay between its cone lines
while any part of it is within the lane's length. In the gate's frame (u along the lane from its first cones, v to
the left) the body has left the lane exactly when its rectangle meets one of the two forbidden boxes
u in [0, L], v >= y_left (beyond the left cone line) or v <= y_right (beyond the right one). The clearance
(``tracks.judge.rect_gate``) is the signed distance between the rectangle and the nearer box. It is 1-Lipschitz
in the body's points, so between two control steps (pose linear in x, y, psi) the least value is found by the
judge's one branch and bound (``tracks.judge.sweep_min``, ``MEASURE_GATES``), exact to ``tol`` (1 mm for a
verdict; the planner checks its lines to 0.1 mm). The body row here is its rectangle alone (front, rear, half
width [m]; 3 entries).
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.tracks.judge import FAR_M, MEASURE_GATES, reach_m, rect_gate, sweep_min

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


rect_reach_m = reach_m
"""Farthest distance [m] of a corner of the rectangle ``body`` (front, rear, half width [m]; 3 entries) from the
CG: ``tracks.judge.reach_m``, which reads a 3-entry row in its own entries only."""


@kernel
def sweep_gate(pose0: np.ndarray, pose1: np.ndarray, body: np.ndarray, gate: np.ndarray, tol: float,
               floor: float) -> float:
    """Least clearance [m] to ``gate`` (a ``gate_table`` row) of a car moving from ``pose0`` to ``pose1`` (x, y
    [m], psi [rad]; pose linear in between), within ``tol`` [m] of the exact value wherever it lies below
    ``floor`` [m]: ``tracks.judge.sweep_min`` with the ``MEASURE_GATES`` clearance (``rect_gate``)."""
    rows = np.ascontiguousarray(gate).reshape((1, gate.shape[0]))
    return sweep_min(MEASURE_GATES, pose0, pose1, body, np.zeros((0, 6)), 0, 0, False, rows, tol, floor)[0]


@kernel
def judge_gates(gates: np.ndarray, body: np.ndarray, idx: np.ndarray, prev: np.ndarray, x: np.ndarray,
                y: np.ndarray, psi: np.ndarray, tol: float, hit: np.ndarray, least: np.ndarray) -> None:
    """For each car i in ``idx`` moving over the last step from ``prev[i]`` (x, y [m], psi [rad]) to
    (x[i], y[i], psi[i]): ``hit[i, g] = True`` where its body reached beyond a cone line of gate g (exact to
    ``tol``), ``least[i]`` lowered to its least clearance to any gate near it [m]. Gates farther than the body's
    reach plus the step are skipped."""
    reach = reach_m(body)
    pose0 = np.empty(3)
    pose1 = np.empty(3)
    none = np.zeros((0, 6))
    for i in idx:
        pose0[0], pose0[1], pose0[2] = prev[i, 0], prev[i, 1], prev[i, 2]
        pose1[0], pose1[1], pose1[2] = x[i], y[i], psi[i]
        near = reach + math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1])
        for g in range(gates.shape[0]):
            c0, s0 = math.cos(gates[g, 2]), math.sin(gates[g, 2])
            u = c0 * (pose1[0] - gates[g, 0]) + s0 * (pose1[1] - gates[g, 1])
            if u < -near or u > gates[g, 3] + near:
                continue
            f, _ = sweep_min(MEASURE_GATES, pose0, pose1, body, none, 0, 0, False, gates[g:g + 1], tol, 0.05)
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
    reach = reach_m(body)
    pose0 = np.empty(3)
    pose1 = np.empty(3)
    none = np.zeros((0, 6))
    for k in range(x.shape[0] - 1):
        pose0[0], pose0[1], pose0[2] = x[k], y[k], psi[k]
        pose1[0], pose1[1], pose1[2] = x[k + 1], y[k + 1], psi[k + 1]
        for g in range(gates.shape[0]):
            c0, s0 = math.cos(gates[g, 2]), math.sin(gates[g, 2])
            u = c0 * (x[k] - gates[g, 0]) + s0 * (y[k] - gates[g, 1])
            if u < -reach - 1.0 or u > gates[g, 3] + reach + 1.0:
                continue
            f, _ = sweep_min(MEASURE_GATES, pose0, pose1, body, none, 0, 0, False, gates[g:g + 1], tol, floor)
            least[g] = min(least[g], f)


__all__ = ["FAR_M", "N_GATE", "gate_table", "judge_gates", "path_gate_clearance_m", "rect_gate", "rect_reach_m",
           "sweep_gate"]
