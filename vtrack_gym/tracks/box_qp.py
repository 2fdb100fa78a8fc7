"""A convex quadratic programme with box bounds, sparse: minimise 1/2 x^T H x + f^T x subject to lo <= x <= hi.

Solved by a primal-dual interior-point method with Mehrotra's predictor-corrector (Nocedal & Wright, Numerical
Optimization, 2nd ed., sections 16.6 and 14.2, specialised to bounds): slacks s_lo = x - lo, s_hi = hi - x and
their multipliers z_lo, z_hi > 0; each iteration factorises the reduced Newton matrix H + Z_lo / S_lo + Z_hi / S_hi
once and solves it twice (predictor and corrector). The iteration count hardly grows with the size (20 to 40 for a
racing line). The factorisation is a banded Cholesky (LAPACK through ``scipy.linalg.solveh_banded``) when H, with
its variables reordered by ``interleaved_order`` (which turns a cyclic band, a closed track's, into a plain one of
twice the width), has at most ``MAX_BAND`` sub-diagonals: O(n) a step, so n = 7,000 variables solve in tens of
milliseconds; else a sparse LU (SuperLU through ``scipy.sparse.linalg``). Used by ``tracks.raceline``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

TO_BOUNDARY = 0.995        # fraction of the step to the boundary of the positive orthant taken
MAX_BAND = 16              # a reordered H with at most this many sub-diagonals is factorised as a band


@dataclass(frozen=True)
class BoxQPResult:
    """Solution ``x`` of :func:`solve_box_qp`, its objective, the interior-point iterations used, the final
    residual (the larger of the dual residual relative to 1 + |f| and the largest complementarity product s z) and
    whether it met the tolerance."""

    x: np.ndarray
    objective: float
    iterations: int
    residual: float
    converged: bool


def interleaved_order(n: int) -> np.ndarray:
    """The order 0, n - 1, 1, n - 2, 2, ...: neighbours i, i + 1 (and n - 1, 0) end at most 2 places apart, so a
    cyclic band of width b becomes a band of width 2 b."""
    order = np.empty(n, dtype=np.int64)
    order[0::2] = np.arange((n + 1) // 2)
    order[1::2] = n - 1 - np.arange(n // 2)
    return order


class _Factor:
    """Solves (H + diag(d)) y = b for a fixed sparse H and any d >= 0: a banded Cholesky of H reordered, or a
    sparse LU."""

    def __init__(self, h: object) -> None:
        from scipy.sparse import csr_matrix

        h = csr_matrix(h)
        self.order = interleaved_order(h.shape[0])
        hp = h[self.order][:, self.order].tocoo()
        below = hp.row - hp.col
        self.band = int(below.max(initial=0))
        self.h = h
        if self.band <= MAX_BAND:
            self.ab = np.zeros((self.band + 1, h.shape[0]))
            keep = below >= 0
            self.ab[below[keep], hp.col[keep]] = hp.data[keep]

    def solver(self, d: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """``solve(b)`` for H + diag(d)."""
        if self.band > MAX_BAND:
            from scipy.sparse import csc_matrix, diags
            from scipy.sparse.linalg import splu

            return splu(csc_matrix(self.h + diags(d))).solve
        from scipy.linalg import cho_solve_banded, cholesky_banded

        ab = self.ab.copy()
        ab[0] += d[self.order]
        factor = cholesky_banded(ab, lower=True, check_finite=False)
        inverse = np.argsort(self.order)

        def solve(b: np.ndarray) -> np.ndarray:
            return cho_solve_banded((factor, True), b[self.order], check_finite=False)[inverse]

        return solve


def _direction(solve: Callable[[np.ndarray], np.ndarray], state: tuple[np.ndarray, ...], c_lo: np.ndarray,
               c_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newton step (dx, dz_lo, dz_hi) towards complementarity targets s z = c (elementwise), from the state
    (dual residual, s_lo, s_hi, z_lo, z_hi) with ``solve`` the reduced matrix's solver."""
    r_d, s_lo, s_hi, z_lo, z_hi = state
    dx = solve(-r_d + c_lo / s_lo - z_lo - c_hi / s_hi + z_hi)
    return dx, (c_lo - s_lo * z_lo - z_lo * dx) / s_lo, (c_hi - s_hi * z_hi + z_hi * dx) / s_hi


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """a . b without BLAS (whose threads, on a loaded machine, make a dot of 10^4 numbers take milliseconds)."""
    return float(np.einsum("i,i->", a, b))


def _max_step(v: np.ndarray, dv: np.ndarray) -> float:
    """Largest step in (0, 1] keeping v + step dv >= 0 (v > 0)."""
    neg = dv < 0.0
    return min(1.0, float(np.min(-v[neg] / dv[neg]))) if np.any(neg) else 1.0


def solve_box_qp(h: object, f: np.ndarray, lo: np.ndarray, hi: np.ndarray, *, tol: float = 1e-10,
                 max_iterations: int = 100) -> BoxQPResult:
    """Minimise 1/2 x^T H x + f^T x subject to lo < x < hi (H symmetric positive definite, a scipy sparse matrix;
    lo < hi elementwise). Converged when the dual residual |H x + f - z_lo + z_hi| (relative to 1 + max |f|) and
    every complementarity product s z are below ``tol``."""
    from scipy.sparse import csr_matrix

    h = csr_matrix(h)
    factor = _Factor(h)
    f, lo, hi = (np.asarray(a, dtype=float) for a in (f, lo, hi))
    if np.any(lo >= hi):
        k = int(np.flatnonzero(lo >= hi)[0])
        raise ValueError(f"box bounds must have lo < hi (variable {k}: lo {lo[k]}, hi {hi[k]})")
    x = 0.5 * (lo + hi)
    scale = 1.0 + float(np.max(np.abs(f), initial=0.0))
    z_lo = np.full(x.size, scale)
    z_hi = np.full(x.size, scale)
    residual = np.inf
    for it in range(1, max_iterations + 1):
        s_lo, s_hi = x - lo, hi - x
        r_d = h @ x + f - z_lo + z_hi
        mu = (_dot(s_lo, z_lo) + _dot(s_hi, z_hi)) / (2 * x.size)
        residual = max(float(np.max(np.abs(r_d))) / scale, float(np.max(s_lo * z_lo)), float(np.max(s_hi * z_hi)))
        if residual <= tol:
            return BoxQPResult(x, 0.5 * _dot(x, h @ x) + _dot(f, x), it - 1, residual, True)
        solve = factor.solver(z_lo / s_lo + z_hi / s_hi)
        state = (r_d, s_lo, s_hi, z_lo, z_hi)
        dx, dz_lo, dz_hi = _direction(solve, state, np.zeros(x.size), np.zeros(x.size))
        a_p = min(_max_step(s_lo, dx), _max_step(s_hi, -dx))
        a_d = min(_max_step(z_lo, dz_lo), _max_step(z_hi, dz_hi))
        mu_aff = (_dot(s_lo + a_p * dx, z_lo + a_d * dz_lo) + _dot(s_hi - a_p * dx, z_hi + a_d * dz_hi)) / (2 * x.size)
        sigma = (mu_aff / mu) ** 3
        dx, dz_lo, dz_hi = _direction(solve, state, sigma * mu - dx * dz_lo, sigma * mu + dx * dz_hi)
        step = TO_BOUNDARY * min(_max_step(s_lo, dx), _max_step(s_hi, -dx), _max_step(z_lo, dz_lo),
                                 _max_step(z_hi, dz_hi))  # one step for x and z: H couples them in r_d
        x = x + step * dx
        z_lo = z_lo + step * dz_lo
        z_hi = z_hi + step * dz_hi
    return BoxQPResult(x, 0.5 * _dot(x, h @ x) + _dot(f, x), max_iterations, residual, residual <= tol)


__all__ = ["BoxQPResult", "solve_box_qp"]
