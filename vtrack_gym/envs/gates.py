"""Compiled cone-gate check: which gates a car's body outline left (``criteria.ConeGates`` calls it every step).

A gate row (``GATE_COLS`` columns, built by ``gate_rows`` from ``tracks.Gate`` objects): s_start, s_end, y_left,
y_right [m], anchored (1.0 / 0.0), anchor x, y [m], psi [rad], lane length [m]. An anchored gate is a fixed
rectangle; the others are checked in the path's Frenet frame, like ``tracks.gate_violations`` on a whole trajectory.
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.tracks.kernels import interp_row, project_point
from vtrack_gym.tracks.table import COL_PSI, COL_X, COL_Y

GATE_COLS = 9
"""Columns of a gate row for ``body_outside_gates``: s_start, s_end, y_left, y_right [m], anchored (1.0 / 0.0),
anchor x, y [m], psi [rad], lane length [m] (``tracks.Gate``; the anchor columns are 0 without an anchor)."""


@kernel
def body_outside_gates(table: np.ndarray, ds: float, length: float, closed: bool, gates: np.ndarray, x: np.ndarray,
                       y: np.ndarray, psi: np.ndarray, s_guess: np.ndarray, lon: np.ndarray, lat: np.ndarray,
                       reach: float, out: np.ndarray, row: np.ndarray) -> None:
    """``out[i, g] = True`` where a body-outline point of car i (CG x, y [m], heading psi [rad]; point offsets ``lon``,
    ``lat`` (P,) [m] in the body frame) lies in gate g's lane section outside its lane. ``gates`` (G, GATE_COLS):
    a gate without an anchor is checked in the path's Frenet frame (s range, e_y bounds; the projection starts near
    ``s_guess`` [m], the car's station), an anchored gate against its fixed rectangle (like
    ``tracks.gate_violations``). A gate already marked in ``out`` is not checked again, nor a Frenet gate whose
    station range is more than ``reach`` [m] (the body length) from the car's station."""
    for i in range(x.shape[0]):
        frenet = False
        anchored = False
        for g in range(gates.shape[0]):
            if out[i, g]:
                continue
            if gates[g, 4] > 0.5:
                anchored = True
            elif gates[g, 0] - reach <= s_guess[i] <= gates[g, 1] + reach:
                frenet = True
        if not (frenet or anchored):
            continue
        c = math.cos(psi[i])
        sn = math.sin(psi[i])
        for j in range(lon.shape[0]):
            cx = x[i] + c * lon[j] - sn * lat[j]
            cy = y[i] + sn * lon[j] + c * lat[j]
            s = 0.0
            e_y = 0.0
            if frenet:
                s = project_point(table, ds, length, closed, cx, cy, s_guess[i], 10.0)
                interp_row(table, ds, length, closed, s, row)
                e_y = -(cx - row[COL_X]) * math.sin(row[COL_PSI]) + (cy - row[COL_Y]) * math.cos(row[COL_PSI])
            for g in range(gates.shape[0]):
                if out[i, g]:
                    continue
                if gates[g, 4] > 0.5:
                    ca = math.cos(gates[g, 7])
                    sa = math.sin(gates[g, 7])
                    along = (cx - gates[g, 5]) * ca + (cy - gates[g, 6]) * sa
                    off = -(cx - gates[g, 5]) * sa + (cy - gates[g, 6]) * ca
                    if 0.0 <= along <= gates[g, 8] and (off > gates[g, 2] or off < gates[g, 3]):
                        out[i, g] = True
                elif frenet and gates[g, 0] <= s <= gates[g, 1] and (e_y > gates[g, 2] or e_y < gates[g, 3]):
                    out[i, g] = True


def gate_rows(gates: tuple) -> np.ndarray:
    """The (G, GATE_COLS) array of ``tracks.Gate`` objects for ``body_outside_gates``."""
    out = np.zeros((len(gates), GATE_COLS))
    for g, gate in enumerate(gates):
        out[g, :4] = (gate.s_start_m, gate.s_end_m, gate.y_left_m, gate.y_right_m)
        if gate.anchor is not None:
            out[g, 4] = 1.0
            out[g, 5:8] = gate.anchor
            out[g, 8] = gate.lane_length_m
    return out
