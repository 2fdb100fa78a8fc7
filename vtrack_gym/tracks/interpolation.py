"""Python entry to the compiled path interpolation (``tracks.kernels``) for arrays of any shape.

Quintic Hermite for X and Y (values, unit tangent, curvature normal), psi (psi, kappa, dkappa) and z (z, grade, z'');
cubic Hermite for kappa (kappa, dkappa) and grade (grade, z''); linear for dkappa and z''. It reproduces circular
arcs to ~1e-15 m, so projections are exact on arcs and straights. The arithmetic is the kernels' (the env's
compiled step runs the same code), imported on first use so that ``import vtrack_gym`` stays free of numba.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from vtrack_gym.tracks import table as tb


def _kernels() -> ModuleType:
    from vtrack_gym.tracks import kernels

    return kernels


def _flat(s: np.ndarray | float) -> tuple[np.ndarray, tuple[int, ...]]:
    """(contiguous float64 1-D copy of s, the shape of s)."""
    s = np.asarray(s, dtype=np.float64)
    return np.ascontiguousarray(s.reshape(-1)), s.shape


def wrap_s(s: np.ndarray | float, length: float, closed: bool) -> np.ndarray:
    """s wrapped into [0, length) for closed paths, clamped to [0, length] for open ones [m] (shape of s)."""
    flat, shape = _flat(s)
    out = np.empty_like(flat)
    _kernels().wrap_s_rows(flat, float(length), bool(closed), out)
    return out.reshape(shape)


def interp(table: np.ndarray, ds: float, length: float, closed: bool, s: np.ndarray | float) -> np.ndarray:
    """All columns at arc lengths s [m] (any shape) -> array of shape s.shape + (8,)."""
    flat, shape = _flat(s)
    out = np.empty((flat.size, tb.N_COLS))
    _kernels().interp_rows(np.ascontiguousarray(table, dtype=np.float64), float(ds), float(length), bool(closed),
                           flat, out)
    return out.reshape((*shape, tb.N_COLS))


def interp_linear(data: np.ndarray, ds: float, length: float, closed: bool, s: np.ndarray | float) -> np.ndarray:
    """Per-row ``data`` (n,) or (n, C) on the table's grid, linear between rows at arc lengths s [m] (wrapped /
    clamped like the table) -> shape s.shape (+ (C,))."""
    flat, shape = _flat(s)
    rows = np.ascontiguousarray(np.asarray(data, dtype=np.float64).reshape(len(data), -1))
    out = np.empty((flat.size, rows.shape[1]))
    _kernels().interp_linear_rows(rows, float(ds), float(length), bool(closed), flat, out)
    return out.reshape(shape if np.ndim(data) == 1 else (*shape, rows.shape[1]))


def project(table: np.ndarray, ds: float, length: float, closed: bool, x: np.ndarray, y: np.ndarray,
            s_guess: np.ndarray, window_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s* [m], e_y [m] left-positive, psi_ref [rad]) of points x, y (N,) [m]: ``kernels.project_point`` from the
    nearest sample within +- window_m [m] of s_guess (N,) [m] (global search where s_guess < 0)."""
    n = x.shape[0]
    s, e_y, psi = np.empty(n), np.empty(n), np.empty(n)
    _kernels().project_batch(np.ascontiguousarray(table, dtype=np.float64), float(ds), float(length), bool(closed),
                             np.ascontiguousarray(x, dtype=np.float64), np.ascontiguousarray(y, dtype=np.float64),
                             np.ascontiguousarray(s_guess, dtype=np.float64), float(window_m), s, e_y, psi)
    return s, e_y, psi


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Angle(s) wrapped to (-pi, pi] [rad], float64 of ``a``'s shape: ``kernels.wrap_angle`` (the env's e_phi
    wrap), so an angle already inside comes back unchanged."""
    flat = np.array(a, dtype=np.float64).reshape(-1)
    out = np.empty_like(flat)
    _kernels().wrap_angle_rows(flat, out)
    return out.reshape(np.shape(a))
