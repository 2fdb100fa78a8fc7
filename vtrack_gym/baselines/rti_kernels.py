"""Compiled pieces every real-time NMPC model shares (``nmpc_kernels``: steering; ``nmpc_coupled_kernels``:
steering and demand): a stage's RK4 map with its exact sensitivities, the condensing of the linearised horizon,
the preparation record's layout, and the shift of stage values by one control period.

``rk4_sensitivities`` takes the model as two compiled functions (numba specialises it per pair, and inlines it):

* ``derivative(y, u, p, consts, f, jac)``: x' at ``y`` into ``f`` (n_x,) and d x' / d(x, u, p) into ``jac``
  (n_x, n_sens), with the inputs ``u`` and stage parameters ``p`` held over the stage (any types the model takes;
  ``consts`` its constants and work arrays);
* ``jac_times(jac, dy, out)``: ``out = jac[:, :n_x] @ dy + [0 | jac[:, n_x:]]`` (n_x, n_sens), in the order of
  operations the model chooses (a model with known structural zeros skips them).

The stage's sensitivities are the exact derivatives of the discrete map (the chain rule through every RK4
evaluation, what automatic differentiation of the same map gives).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vtrack_gym._jit import kernel


@kernel(inline=True)
def rk4_sensitivities(derivative: Any, jac_times: Any, x: np.ndarray, u: Any, p: Any, consts: Any, stage_s: float,
                      substeps: int, x_out: np.ndarray, sens: np.ndarray, f: np.ndarray, jac: np.ndarray,
                      dk: np.ndarray, y: np.ndarray, dy: np.ndarray) -> None:
    """The state after one stage of ``stage_s`` [s] (``substeps`` RK4 steps) into ``x_out`` (n_x,) and its
    sensitivities d/d(x_start, u, p) into ``sens`` (n_x, n_sens); work arrays f (4, n_x), jac (n_x, n_sens),
    dk (4, n_x, n_sens), y (n_x,), dy (n_x, n_sens)."""
    n_x, n_sens = sens.shape
    h = stage_s / substeps
    x_out[:] = x
    sens[:, :] = 0.0
    for i in range(n_x):
        sens[i, i] = 1.0
    for _ in range(substeps):
        for stage in range(4):
            c = 0.0 if stage == 0 else (h if stage == 3 else 0.5 * h)
            for i in range(n_x):
                y[i] = x_out[i] + (c * f[stage - 1, i] if stage else 0.0)
                for j in range(n_sens):
                    dy[i, j] = sens[i, j] + (c * dk[stage - 1, i, j] if stage else 0.0)
            derivative(y, u, p, consts, f[stage], jac)
            jac_times(jac, dy, dk[stage])
        w = h / 6.0
        for i in range(n_x):
            x_out[i] += w * (f[0, i] + 2.0 * f[1, i] + 2.0 * f[2, i] + f[3, i])
            for j in range(n_sens):
                sens[i, j] += w * (dk[0, i, j] + 2.0 * dk[1, i, j] + 2.0 * dk[2, i, j] + dk[3, i, j])


@kernel
def record_offsets(n: int, n_inputs: int, n_x: int) -> tuple[int, int, int, int, int, int, int, int]:
    """Offsets in the flat preparation record of an ``n``-stage horizon with ``n_inputs`` inputs a stage
    (nv = n_inputs n variables) and ``n_x`` states: inverse Cholesky factor L^-T (nv, nv), g0 (nv), Gx (nv, n_x),
    Gp (nv, 2n), steering rate0 (n) [rad/s], its Jacobian in U (n, nv) and in the initial steering angle (n); and
    the record's end."""
    nv = n_inputs * n
    o_g = nv * nv
    o_gx = o_g + nv
    o_gp = o_gx + nv * n_x
    o_r = o_gp + nv * 2 * n
    o_ru = o_r + n
    o_rd = o_ru + n * nv
    return 0, o_g, o_gx, o_gp, o_r, o_ru, o_rd, o_rd + n


@kernel
def inverse_cholesky_t(hess: np.ndarray, out: np.ndarray) -> None:
    """``out = L^-T`` (upper triangular) with ``hess = L L'`` (Cholesky; ``hess`` is overwritten by L)."""
    n = hess.shape[0]
    for j in range(n):
        d = hess[j, j]
        for k in range(j):
            d -= hess[j, k] * hess[j, k]
        if d <= 0.0:
            raise np.linalg.LinAlgError("the Gauss-Newton Hessian is not positive definite")
        d = math.sqrt(d)
        hess[j, j] = d
        for i in range(j + 1, n):
            acc = hess[i, j]
            for k in range(j):
                acc -= hess[i, k] * hess[j, k]
            hess[i, j] = acc / d
    out[:, :] = 0.0
    for c in range(n):   # column c of L^-1 by forward substitution, stored as row c of L^-T
        out[c, c] = 1.0 / hess[c, c]
        for i in range(c + 1, n):
            acc = 0.0
            for k in range(c, i):
                acc -= hess[i, k] * out[c, k]
            out[c, i] = acc / hess[i, i]


@kernel(inline=True)
def condense(res: np.ndarray, ju: np.ndarray, jx: np.ndarray, jp: np.ndarray, eps: float, n_inputs: int,
             out: np.ndarray) -> None:
    """The Gauss-Newton QP's part of the record ``out`` (``record_offsets``; n_x = ``jx``'s columns, n = ``jp``'s
    columns / 2): L^-T of ``H = J_U' J_U + eps I``, ``g0 = J_U' res``, ``Gx = J_U' J_x0`` and ``Gp = J_U' J_P``."""
    nv = ju.shape[1]
    jut = np.ascontiguousarray(ju.T)
    hess = jut @ ju
    for i in range(nv):
        hess[i, i] += eps
    o_j, o_g, o_gx, o_gp, o_r, _, _, _ = record_offsets(jp.shape[1] // 2, n_inputs, jx.shape[1])
    inverse_cholesky_t(hess, out[o_j:o_g].reshape(nv, nv))
    out[o_g:o_gx] = jut @ res
    out[o_gx:o_gp] = (jut @ jx).reshape(-1)
    out[o_gp:o_r] = (jut @ jp).reshape(-1)


@kernel
def shifted(values: np.ndarray, stage_s: float, period_s: float) -> np.ndarray:
    """Stage values moved one control period forward in time (linear in time, the last value held)."""
    n = values.size
    t = np.arange(n) * stage_s
    return np.interp(t + period_s, t, values)
