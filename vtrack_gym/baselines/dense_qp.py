"""A small dense convex QP solver (compiled): Goldfarb and Idnani's dual active-set method.

Solves ``min 1/2 x'Hx + g'x`` subject to ``lo <= A x <= hi`` and ``lb <= x <= ub`` for a positive definite ``H``
given by its inverse Cholesky factor ``L^-T`` (``H = L L'``; the real-time NMPC computes it in its preparation
phase, so a solve costs no factorisation). The method starts from the unconstrained minimum and adds the most
violated constraint at a time, dropping active ones whose multipliers would turn negative, so every iterate is
dual feasible and the last one is the exact optimum (up to rounding): what a textbook active-set solver such as
qpOASES returns for the same problem. Each row of ``A`` and each bound is two one-sided constraints.

Reference: D. Goldfarb, A. Idnani, "A numerically stable dual method for solving strictly convex quadratic
programs", Mathematical Programming 27 (1983) 1-33. The factorisation ``J = L^-T Q``, ``J' N = [R; 0]`` of the
active normals ``N`` is updated by Givens rotations.
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel

QP_SOLVED, QP_INFEASIBLE, QP_MAX_ITERATIONS = 0, 1, 2
"""``solve_qp`` status codes."""
FEASIBILITY_TOL = 1e-12
"""A constraint counts as satisfied when violated by at most this much (scaled by its bound's size, at least 1)."""


@kernel(inline=True)
def _normal(p: int, a: np.ndarray, out: np.ndarray) -> None:
    """The normal of one-sided constraint ``p`` (``n_x`` = x.size): 2i / 2i+1 = row i of A from below / above,
    then 2(m + j) / 2(m + j) + 1 = x_j from below / above (``normal' x >= bound``)."""
    m = a.shape[0]
    row, upper = p // 2, p % 2 == 1
    sign = -1.0 if upper else 1.0
    if row < m:
        for j in range(out.size):
            out[j] = sign * a[row, j]
    else:
        out[:] = 0.0
        out[row - m] = sign


@kernel(inline=True)
def _slack(p: int, x: np.ndarray, a: np.ndarray, lo: np.ndarray, hi: np.ndarray, lb: np.ndarray,
           ub: np.ndarray) -> float:
    """``normal' x - bound`` of one-sided constraint ``p`` (>= 0: satisfied)."""
    m = a.shape[0]
    row = p // 2
    if row < m:
        ax = 0.0
        for j in range(x.size):
            ax += a[row, j] * x[j]
        return ax - lo[row] if p % 2 == 0 else hi[row] - ax
    return x[row - m] - lb[row - m] if p % 2 == 0 else ub[row - m] - x[row - m]


@kernel(inline=True)
def _rotate_columns(jmat: np.ndarray, i: int, k: int, c: float, s: float) -> None:
    """Columns i, k of ``jmat`` <- (c J_i + s J_k, -s J_i + c J_k)."""
    for r in range(jmat.shape[0]):
        ji, jk = jmat[r, i], jmat[r, k]
        jmat[r, i] = c * ji + s * jk
        jmat[r, k] = -s * ji + c * jk


@kernel
def _add_constraint(jmat: np.ndarray, rmat: np.ndarray, d: np.ndarray, q: int) -> None:
    """Rotate ``d[q:]`` onto ``d[q]`` (the same rotations on J's columns) and append column ``d[:q + 1]`` to R."""
    n = d.size
    for j in range(n - 1, q, -1):
        a, b = d[j - 1], d[j]
        if b == 0.0:
            continue
        rho = math.hypot(a, b)
        c, s = a / rho, b / rho
        d[j - 1], d[j] = rho, 0.0
        _rotate_columns(jmat, j - 1, j, c, s)
    for i in range(q + 1):
        rmat[i, q] = d[i]


@kernel
def _drop_constraint(jmat: np.ndarray, rmat: np.ndarray, active: np.ndarray, u: np.ndarray, k: int, q: int) -> None:
    """Remove active constraint ``k`` of ``q``: delete R's column k and restore its triangle by Givens rotations
    (rows of R, columns of J)."""
    for j in range(k, q - 1):
        active[j], u[j] = active[j + 1], u[j + 1]
        for i in range(j + 2):
            rmat[i, j] = rmat[i, j + 1]
    for j in range(k, q - 1):
        a, b = rmat[j, j], rmat[j + 1, j]
        if b != 0.0:
            rho = math.hypot(a, b)
            c, s = a / rho, b / rho
            for col in range(j, q - 1):
                rj, rk = rmat[j, col], rmat[j + 1, col]
                rmat[j, col], rmat[j + 1, col] = c * rj + s * rk, -s * rj + c * rk
            _rotate_columns(jmat, j, j + 1, c, s)
        rmat[j + 1, j] = 0.0
    for i in range(q):
        rmat[i, q - 1] = 0.0


@kernel
def solve_qp(inv_chol_t: np.ndarray, g: np.ndarray, a: np.ndarray, lo: np.ndarray, hi: np.ndarray,
             lb: np.ndarray, ub: np.ndarray, x: np.ndarray, max_iterations: int) -> tuple[int, int, int]:
    """Solve the module docstring's QP into ``x``; returns (status, iterations, active constraints).

    ``inv_chol_t``: L^-T (n, n) with H = L L'. ``a`` (m, n) with ``lo``, ``hi`` (m,); ``lb``, ``ub`` (n,).
    ``iterations`` counts added and dropped constraints. ``x`` holds the last iterate when not solved.
    """
    n, m = g.size, a.shape[0]
    n_con = 2 * (m + n)
    jmat = inv_chol_t.copy()
    rmat = np.zeros((n, n))
    active = np.empty(n, dtype=np.int64)
    is_active = np.zeros(n_con, dtype=np.bool_)
    u = np.zeros(n + 1)
    d, z, r, normal = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    # unconstrained minimum: x = -H^-1 g = -J J' g
    d[:] = jmat.T @ g
    x[:] = -(jmat @ d)
    q, iterations = 0, 0
    while True:
        best, p = 0.0, -1
        for row in range(m + n):
            if row < m:
                ax = 0.0
                for j in range(n):
                    ax += a[row, j] * x[j]
                low, high = ax - lo[row], hi[row] - ax
                scale_lo, scale_hi = max(1.0, abs(lo[row])), max(1.0, abs(hi[row]))
            else:
                low, high = x[row - m] - lb[row - m], ub[row - m] - x[row - m]
                scale_lo, scale_hi = max(1.0, abs(lb[row - m])), max(1.0, abs(ub[row - m]))
            if not is_active[2 * row] and low / scale_lo < best:
                best, p = low / scale_lo, 2 * row
            if not is_active[2 * row + 1] and high / scale_hi < best:
                best, p = high / scale_hi, 2 * row + 1
        if p < 0 or best >= -FEASIBILITY_TOL:
            return QP_SOLVED, iterations, q
        _normal(p, a, normal)
        slack_p = _slack(p, x, a, lo, hi, lb, ub)
        u_new = 0.0
        while True:
            iterations += 1
            if iterations > max_iterations:
                return QP_MAX_ITERATIONS, iterations, q
            d[:] = jmat.T @ normal
            z[:] = 0.0
            for j in range(q, n):
                for i in range(n):
                    z[i] += jmat[i, j] * d[j]
            for i in range(q - 1, -1, -1):     # r = R^-1 d[:q]
                acc = d[i]
                for j in range(i + 1, q):
                    acc -= rmat[i, j] * r[j]
                r[i] = acc / rmat[i, i]
            t1, k = np.inf, -1
            for j in range(q):
                if r[j] > 0.0 and u[j] / r[j] < t1:
                    t1, k = u[j] / r[j], j
            zn = 0.0
            for i in range(n):
                zn += z[i] * normal[i]
            t2 = -slack_p / zn if zn > 1e-14 * max(1.0, abs(slack_p)) else np.inf
            t = min(t1, t2)
            if t == np.inf:
                return QP_INFEASIBLE, iterations, q
            for j in range(q):
                u[j] -= t * r[j]
            u_new += t
            if t2 < np.inf:
                for i in range(n):
                    x[i] += t * z[i]
            if t2 <= t1:   # full step: p joins the active set
                _add_constraint(jmat, rmat, d, q)
                active[q], u[q], is_active[p] = p, u_new, True
                q += 1
                break
            is_active[active[k]] = False   # partial step: the blocking constraint leaves
            _drop_constraint(jmat, rmat, active, u, k, q)
            q -= 1
            slack_p = _slack(p, x, a, lo, hi, lb, ub)
