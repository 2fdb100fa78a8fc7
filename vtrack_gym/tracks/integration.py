"""Heading and position from a curvature profile (Gauss-Legendre quadrature) and the elevation columns."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np

GAUSS_ORDER = 8
_CHUNK = 16384

Profile1D = Callable[[np.ndarray], np.ndarray]


@runtime_checkable
class ElevationLike(Protocol):
    """Elevation profile with analytic derivatives: z(s) [m], grade dz/ds [-], d2z/ds2 [1/m]."""

    def z(self, s: np.ndarray) -> np.ndarray: ...

    def grade(self, s: np.ndarray) -> np.ndarray: ...

    def zpp(self, s: np.ndarray) -> np.ndarray: ...


def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes in (0, 1) and weights summing to 1."""
    x, w = np.polynomial.legendre.leggauss(order)
    return 0.5 * (x + 1.0), 0.5 * w


def integrate_curvature(kappa: Callable[[np.ndarray], np.ndarray], s_grid: np.ndarray, knots: np.ndarray,
                         psi0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heading and position increments on s_grid [m] from kappa(s) [1/m].

    Every grid interval is split at the profile knots; inside, heading is the nested Gauss-Legendre integral of
    kappa and position the Gauss-Legendre integral of (cos psi, sin psi). Exact to round-off for piecewise
    polynomial kappa of degree <= 15 between knots (arcs are exact circles, straights exact lines).
    Returns (psi [rad], dX [m], dY [m]) with dX, dY relative to the start.
    """
    inner = knots[(knots > s_grid[0]) & (knots < s_grid[-1])]
    b = np.union1d(s_grid, inner)
    xi, om = gauss_legendre(GAUSS_ORDER)
    n_int = b.size - 1
    dpsi = np.empty(n_int)
    dx = np.empty(n_int)
    dy = np.empty(n_int)
    psi_local = []
    for lo in range(0, n_int, _CHUNK):
        hi = min(lo + _CHUNK, n_int)
        a = b[lo:hi]
        w = b[lo + 1:hi + 1] - a
        dpsi[lo:hi] = w * (kappa(a[:, None] + w[:, None] * xi[None, :]) @ om)
        v = a[:, None, None] + w[:, None, None] * xi[None, :, None] * xi[None, None, :]
        psi_local.append(w[:, None] * xi[None, :] * (kappa(v) @ om))
    psi_b = psi0 + np.concatenate(([0.0], np.cumsum(dpsi)))
    for k, lo in enumerate(range(0, n_int, _CHUNK)):
        hi = min(lo + _CHUNK, n_int)
        w = b[lo + 1:hi + 1] - b[lo:hi]
        psi_u = psi_b[lo:hi, None] + psi_local[k]
        dx[lo:hi] = w * (np.cos(psi_u) @ om)
        dy[lo:hi] = w * (np.sin(psi_u) @ om)
    x_b = np.concatenate(([0.0], np.cumsum(dx)))
    y_b = np.concatenate(([0.0], np.cumsum(dy)))
    idx = np.searchsorted(b, s_grid)
    return psi_b[idx], x_b[idx], y_b[idx]


def derivative_fd(fn: Callable[[np.ndarray], np.ndarray], s: np.ndarray, h: float) -> np.ndarray:
    """Fourth-order central finite difference of fn at s (fn must accept s +- 2h)."""
    return (-fn(s + 2.0 * h) + 8.0 * fn(s + h) - 8.0 * fn(s - h) + fn(s - 2.0 * h)) / (12.0 * h)


def elevation_columns(elevation: Any, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(z [m], grade [-], z'' [1/m]) at s from None, an ElevationLike or a plain callable z(s)."""
    if elevation is None:
        zero = np.zeros_like(s)
        return zero, zero.copy(), zero.copy()
    if isinstance(elevation, ElevationLike):
        return (np.asarray(elevation.z(s), dtype=float), np.asarray(elevation.grade(s), dtype=float),
                np.asarray(elevation.zpp(s), dtype=float))
    if callable(elevation):
        z = np.asarray(elevation(s), dtype=float)
        grade = derivative_fd(elevation, s, 0.05)
        zpp = (elevation(s + 0.1) - 2.0 * z + elevation(s - 0.1)) / 0.01
        return z, np.asarray(grade, dtype=float), np.asarray(zpp, dtype=float)
    raise ValueError(f"elevation must be None, an ElevationLike or a callable z(s) (got {type(elevation).__name__})")

