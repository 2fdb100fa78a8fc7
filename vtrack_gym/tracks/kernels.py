"""numba kernels on a path table: interpolation and projection for the env's compiled step (N cars at once).

Arguments are plain arrays/scalars: ``table`` (n, 8) float64 with the column order of ``vtrack_gym.tracks.path``
(COL_X .. COL_ZPP), ``ds`` sample spacing [m], ``length`` = (n - 1) ds [m], ``closed`` (bool; s wraps modulo
length, else it is clamped to [0, length]). Same algorithms as the numpy methods of ``Path`` (tested to agree).

Interpolation: quintic Hermite for X, Y (value, unit tangent, curvature normal), psi (psi, kappa, dkappa) and z
(z, grade, z''); cubic Hermite for kappa (kappa, dkappa) and grade (grade, z''); linear for dkappa and z''. Heading
is interpolated as the unwrapped table angle. Arcs are reproduced to ~1e-15 m, so X/Y at the projection are
consistent with it.

This is the only module of the package that imports numba.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

C_X, C_Y, C_PSI, C_KAPPA, C_DKAPPA, C_Z, C_GRADE, C_ZPP = range(8)
TOL_M = 1e-10          # refinement stops when s moves less than this [m]
MAX_ITER = 12


@njit(cache=True)
def wrap_s(s: float, length: float, closed: bool) -> float:
    """Arc length wrapped into [0, length) (closed) or clamped to [0, length] (open) [m]."""
    if closed:
        w = s - math.floor(s / length) * length
        if w >= length or w < 0.0:
            w = 0.0
        return w
    if s < 0.0:
        return 0.0
    if s > length:
        return length
    return s


@njit(cache=True)
def _h5(p0: float, d0: float, c0: float, p1: float, d1: float, c1: float, t: float, h: float) -> float:
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    return ((1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5) * p0 + (t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5) * h * d0
            + 0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5) * h * h * c0 + 0.5 * (t3 - 2.0 * t4 + t5) * h * h * c1
            + (-4.0 * t3 + 7.0 * t4 - 3.0 * t5) * h * d1 + (10.0 * t3 - 15.0 * t4 + 6.0 * t5) * p1)


@njit(cache=True)
def _h3(p0: float, d0: float, p1: float, d1: float, t: float, h: float) -> float:
    t2 = t * t
    t3 = t2 * t
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * p0 + (t3 - 2.0 * t2 + t) * h * d0 + (-2.0 * t3 + 3.0 * t2) * p1
            + (t3 - t2) * h * d1)


@njit(cache=True)
def _locate(n: int, ds: float, length: float, closed: bool, s: float) -> tuple[int, float]:
    sw = wrap_s(s, length, closed)
    i = int(sw / ds)
    if i > n - 2:
        i = n - 2
    return i, (sw - i * ds) / ds


@njit(cache=True)
def _geom(table: np.ndarray, ds: float, length: float, closed: bool, s: float) -> tuple[float, float, float, float]:
    """(X [m], Y [m], psi [rad], kappa [1/m]) at s."""
    i, t = _locate(table.shape[0], ds, length, closed, s)
    a = table[i]
    b = table[i + 1]
    ca, sa = math.cos(a[C_PSI]), math.sin(a[C_PSI])
    cb, sb = math.cos(b[C_PSI]), math.sin(b[C_PSI])
    ka, kb = a[C_KAPPA], b[C_KAPPA]
    x = _h5(a[C_X], ca, -ka * sa, b[C_X], cb, -kb * sb, t, ds)
    y = _h5(a[C_Y], sa, ka * ca, b[C_Y], sb, kb * cb, t, ds)
    psi = _h5(a[C_PSI], ka, a[C_DKAPPA], b[C_PSI], kb, b[C_DKAPPA], t, ds)
    kap = _h3(ka, a[C_DKAPPA], kb, b[C_DKAPPA], t, ds)
    return x, y, psi, kap


@njit(cache=True)
def interp_row(table: np.ndarray, ds: float, length: float, closed: bool, s: float, out_row: np.ndarray) -> None:
    """Write all 8 columns at arc length s [m] into out_row (wrapped for closed, clamped for open paths)."""
    i, t = _locate(table.shape[0], ds, length, closed, s)
    a = table[i]
    b = table[i + 1]
    ca, sa = math.cos(a[C_PSI]), math.sin(a[C_PSI])
    cb, sb = math.cos(b[C_PSI]), math.sin(b[C_PSI])
    ka, kb = a[C_KAPPA], b[C_KAPPA]
    out_row[C_X] = _h5(a[C_X], ca, -ka * sa, b[C_X], cb, -kb * sb, t, ds)
    out_row[C_Y] = _h5(a[C_Y], sa, ka * ca, b[C_Y], sb, kb * cb, t, ds)
    out_row[C_PSI] = _h5(a[C_PSI], ka, a[C_DKAPPA], b[C_PSI], kb, b[C_DKAPPA], t, ds)
    out_row[C_KAPPA] = _h3(ka, a[C_DKAPPA], kb, b[C_DKAPPA], t, ds)
    out_row[C_DKAPPA] = a[C_DKAPPA] + t * (b[C_DKAPPA] - a[C_DKAPPA])
    out_row[C_Z] = _h5(a[C_Z], a[C_GRADE], a[C_ZPP], b[C_Z], b[C_GRADE], b[C_ZPP], t, ds)
    out_row[C_GRADE] = _h3(a[C_GRADE], a[C_ZPP], b[C_GRADE], b[C_ZPP], t, ds)
    out_row[C_ZPP] = a[C_ZPP] + t * (b[C_ZPP] - a[C_ZPP])


@njit(cache=True)
def _nearest_sample(table: np.ndarray, ds: float, closed: bool, x: float, y: float, s_guess: float,
                    window_m: float) -> int:
    """Index of the nearest sample within +- window_m of s_guess (all samples if s_guess < 0)."""
    n = table.shape[0]
    period = n - 1
    half = math.ceil(window_m / ds)
    if half < 1:
        half = 1
    best = 0
    best_d2 = np.inf
    if s_guess < 0.0 or (closed and 2 * half + 1 >= period):
        last = period if closed else n
        for j in range(last):
            d2 = (table[j, C_X] - x) ** 2 + (table[j, C_Y] - y) ** 2
            if d2 < best_d2:
                best_d2 = d2
                best = j
        return best
    length = period * ds
    centre = round(wrap_s(s_guess, length, closed) / ds)
    for k in range(-half, half + 1):
        j = centre + k
        if closed:
            j = j % period
        elif j < 0 or j > n - 1:
            continue
        d2 = (table[j, C_X] - x) ** 2 + (table[j, C_Y] - y) ** 2
        if d2 < best_d2:
            best_d2 = d2
            best = j
    return best


@njit(cache=True)
def project_point(table: np.ndarray, ds: float, length: float, closed: bool, x: float, y: float, s_guess: float,
                  window_m: float) -> float:
    """Arc length s* [m] of the closest path point to (x, y) [m].

    Coarse search over the samples within +- window_m [m] of s_guess [m] (warm start; global if s_guess < 0),
    then refinement: project (x, y) exactly onto the osculating circle at the current s and move there, until s
    moves less than 1e-10 m (exact on arcs and straights, a few steps on clothoids). Wrapped for closed paths,
    clamped to [0, length] for open ones.
    """
    s = _nearest_sample(table, ds, closed, x, y, s_guess, window_m) * ds
    step_max = max(4.0 * ds, 2.0)
    for _ in range(MAX_ITER):
        xr, yr, psi, kap = _geom(table, ds, length, closed, s)
        c = math.cos(psi)
        sn = math.sin(psi)
        px = x - xr
        py = y - yr
        along = px * c + py * sn
        lateral = -px * sn + py * c
        if abs(kap) < 1e-12:
            delta = along
        else:
            delta = math.atan2(kap * along, 1.0 - kap * lateral) / kap
        if delta > step_max:
            delta = step_max
        elif delta < -step_max:
            delta = -step_max
        s_new = wrap_s(s + delta, length, closed)
        moved = abs(s_new - s)
        if closed and moved > 0.5 * length:
            moved = length - moved
        s = s_new
        if moved < TOL_M:
            break
    return s


@njit(cache=True)
def lateral_error(table: np.ndarray, ds: float, length: float, closed: bool, x: float, y: float,
                  s: float) -> tuple[float, float]:
    """(e_y [m] left-positive, psi_ref [rad]) of (x, y) [m] relative to the path point at s [m]."""
    xr, yr, psi, _ = _geom(table, ds, length, closed, s)
    return -(x - xr) * math.sin(psi) + (y - yr) * math.cos(psi), psi


@njit(cache=True)
def project_batch(table: np.ndarray, ds: float, length: float, closed: bool, x: np.ndarray, y: np.ndarray,
                  s_guess: np.ndarray, window_m: float, s_out: np.ndarray, e_y_out: np.ndarray,
                  psi_ref_out: np.ndarray) -> None:
    """Project N points (x[i], y[i]) [m]: s* [m], e_y [m] (left-positive) and psi_ref [rad] into the outputs."""
    for i in range(x.shape[0]):
        s = project_point(table, ds, length, closed, x[i], y[i], s_guess[i], window_m)
        e_y, psi = lateral_error(table, ds, length, closed, x[i], y[i], s)
        s_out[i] = s
        e_y_out[i] = e_y
        psi_ref_out[i] = psi
