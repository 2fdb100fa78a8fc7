"""Interpolation between table rows and projection steps (numpy twin of ``kernels.interp_row``).

Quintic Hermite for X and Y (values, unit tangent, curvature normal), psi (psi, kappa, dkappa) and z (z, grade, z'');
cubic Hermite for kappa (kappa, dkappa) and grade (grade, z''); linear for dkappa and z''. It reproduces circular
arcs to ~1e-15 m, so projections are exact on arcs and straights. numpy only; the numba versions used by the env
live in ``kernels`` (imported lazily, never by this module).
"""

from __future__ import annotations

import numpy as np

from vtrack_gym.tracks import table as tb


def hermite5(p0: np.ndarray, d0: np.ndarray, c0: np.ndarray, p1: np.ndarray, d1: np.ndarray, c1: np.ndarray,
              t: np.ndarray, h: float) -> np.ndarray:
    """Quintic Hermite through values p, first derivatives d and second derivatives c at t = 0 and t = 1."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    h0 = 1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5
    h1 = t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5
    h2 = 0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5)
    h3 = 0.5 * (t3 - 2.0 * t4 + t5)
    h4 = -4.0 * t3 + 7.0 * t4 - 3.0 * t5
    h5 = 10.0 * t3 - 15.0 * t4 + 6.0 * t5
    return h0 * p0 + h1 * h * d0 + h2 * h * h * c0 + h3 * h * h * c1 + h4 * h * d1 + h5 * p1


def hermite3(p0: np.ndarray, d0: np.ndarray, p1: np.ndarray, d1: np.ndarray, t: np.ndarray, h: float) -> np.ndarray:
    """Cubic Hermite through values p and derivatives d at t = 0 and t = 1."""
    t2 = t * t
    t3 = t2 * t
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * p0 + (t3 - 2.0 * t2 + t) * h * d0 + (-2.0 * t3 + 3.0 * t2) * p1
            + (t3 - t2) * h * d1)


def wrap_s(s: np.ndarray, length: float, closed: bool) -> np.ndarray:
    """s wrapped into [0, length) for closed paths, clamped to [0, length] for open ones [m]."""
    if closed:
        w = s - np.floor(s / length) * length
        return np.where((w >= length) | (w < 0.0), 0.0, w)
    return np.clip(s, 0.0, length)


def interp(table: np.ndarray, ds: float, length: float, closed: bool, s: np.ndarray) -> np.ndarray:
    """All columns at arc lengths s (any shape) -> array of shape s.shape + (8,)."""
    s = np.asarray(s, dtype=float)
    sw = wrap_s(s, length, closed)
    n = table.shape[0]
    i = np.minimum((sw / ds).astype(np.int64), n - 2)
    t = (sw - i * ds) / ds
    # columns of the rows before (a) and after (b) each s
    ax, ay, apsi, ak, adk, az, ag, azpp = np.moveaxis(table[i], -1, 0)
    bx, by, bpsi, bk, bdk, bz, bg, bzpp = np.moveaxis(table[i + 1], -1, 0)
    out = np.empty((*s.shape, tb.N_COLS))
    ca, sa = np.cos(apsi), np.sin(apsi)
    cb, sb = np.cos(bpsi), np.sin(bpsi)
    out[..., tb.COL_X] = hermite5(ax, ca, -ak * sa, bx, cb, -bk * sb, t, ds)
    out[..., tb.COL_Y] = hermite5(ay, sa, ak * ca, by, sb, bk * cb, t, ds)
    out[..., tb.COL_PSI] = hermite5(apsi, ak, adk, bpsi, bk, bdk, t, ds)
    out[..., tb.COL_KAPPA] = hermite3(ak, adk, bk, bdk, t, ds)
    out[..., tb.COL_DKAPPA] = adk + t * (bdk - adk)
    out[..., tb.COL_Z] = hermite5(az, ag, azpp, bz, bg, bzpp, t, ds)
    out[..., tb.COL_GRADE] = hermite3(ag, azpp, bg, bzpp, t, ds)
    out[..., tb.COL_ZPP] = azpp + t * (bzpp - azpp)
    return out



def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angle(s) wrapped to (-pi, pi] [rad]."""
    w = np.mod(np.asarray(a, dtype=float) + np.pi, 2.0 * np.pi)
    w = np.where(w <= 0.0, w + 2.0 * np.pi, w)
    return w - np.pi


def arc_step(x: np.ndarray, y: np.ndarray, row: np.ndarray, step_max: float) -> np.ndarray:
    """Arc-length step from the reference point in ``row`` to the projection of (x, y) onto its osculating circle."""
    psi = row[..., tb.COL_PSI]
    kap = row[..., tb.COL_KAPPA]
    c, s = np.cos(psi), np.sin(psi)
    px = x - row[..., tb.COL_X]
    py = y - row[..., tb.COL_Y]
    along = px * c + py * s
    lateral = -px * s + py * c
    small = np.abs(kap) < 1e-12
    safe = np.where(small, 1.0, kap)
    arc = np.arctan2(safe * along, 1.0 - safe * lateral) / safe
    return np.clip(np.where(small, along, arc), -step_max, step_max)

