"""The coupled NMPC's preparation phase (compiled): single-shooting linearisation of the horizon and condensing into
the Gauss-Newton QP in both inputs, the same scheme as the steering NMPC's ``nmpc_kernels.prepare``.

Decision variables ``U = (c_0 .. c_{N-1}, d_0 .. d_{N-1})`` (2N: the steering commands [rad], then the demands),
stage parameters ``P = (kappa_0 .. kappa_{N-1}, v_ref,0 .. v_ref,N-1)`` (2N). Least-squares residuals (8N), with
``x_k`` the state after stage k (``nmpc_coupled_model``) and the last stage's state terms times ``terminal_scale``:

* per stage: ``w_ey e_y``, ``w_ephi e_phi``, ``w_r (r - v kappa_k)``, ``w_v (v - v_ref,k)``, ``w_t e_t``;
* per stage: ``w_move (c_k - c_{k-1})``, ``w_dmove (d_k - d_{k-1})`` (the first from the commands sent last) and
  ``w_d d_k``.

``weights`` holds the square roots of the weights in that order, then the terminal scale. The record
(``prep_offsets``) holds ``L^-T`` of ``H = J_U' J_U + eps I``, ``g0 = J_U' res``, ``Gx = J_U' J_x0``, ``Gp = J_U' J_P``
and the steering actuator rates ``(c_k - delta_k) / tau`` at every stage's start with their (exactly linear)
Jacobians in U (N, 2N) and in the initial steering angle (N,).
"""

from __future__ import annotations

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.nmpc_coupled_model import N_SENS, N_X, rk4_stage
from vtrack_gym.baselines.rti_kernels import condense, record_offsets

N_STAGE_RESIDUALS = 5
"""e_y, e_phi, yaw rate against v kappa, speed error, time error."""
N_WEIGHTS = 9
"""``weights``: sqrt of e_y, e_phi, yaw rate, speed, time, steering move, demand move, demand; terminal scale."""


@kernel
def prep_offsets(n: int) -> tuple[int, int, int, int, int, int, int, int]:
    """Offsets in the flat preparation record of an ``n``-stage horizon (``rti_kernels.record_offsets``, 2n
    variables): L^-T (2n, 2n), g0 (2n), Gx (2n, 7), Gp (2n, 2n), rate0 (n) [rad/s], rate Jacobian in U (n, 2n), in
    the initial steering angle (n); and its end."""
    return record_offsets(n, 2, N_X)


@kernel(inline=True)
def _chain(sens: np.ndarray, mat: np.ndarray, start: int, cols: int, col: np.ndarray) -> None:
    """``mat[:, start:start + cols] = A @ mat[:, start:start + cols]`` in place, A = ``sens[:, :7]``."""
    for j in range(start, start + cols):
        for i in range(N_X):
            col[i] = mat[i, j]
        for i in range(N_X):
            acc = 0.0
            for q in range(N_X):
                acc += sens[i, q] * col[q]
            mat[i, j] = acc


@kernel(inline=True)
def _stage_residuals(k: int, n: int, x: np.ndarray, params: np.ndarray, weights: np.ndarray, su: np.ndarray,
                     sx: np.ndarray, sp: np.ndarray, res: np.ndarray, ju: np.ndarray, jx: np.ndarray,
                     jp: np.ndarray) -> None:
    """Stage k's five state residuals and their Jacobians in U, x0 and P (module docstring)."""
    scale = weights[8] if k == n - 1 else 1.0
    kappa, v_ref = params[k], params[n + k]
    rows = (0, 1, 3, 5, 6)
    for r in range(N_STAGE_RESIDUALS):
        i, w, out = rows[r], weights[r] * scale, N_STAGE_RESIDUALS * k + r
        kv = kappa if r == 2 else 0.0   # the yaw-rate residual is r - v kappa: row 3 minus kappa x row 5
        value = x[i] - kv * x[5]
        if r == 3:
            value -= v_ref
        res[out] = w * value
        for j in range(k + 1):
            for c in (j, n + j):
                ju[out, c] = w * (su[i, c] - kv * su[5, c])
                jp[out, c] = w * (sp[i, c] - kv * sp[5, c])
        for j in range(N_X):
            jx[out, j] = w * (sx[i, j] - kv * sx[5, j])
    jp[N_STAGE_RESIDUALS * k + 2, k] -= weights[2] * scale * x[5]
    jp[N_STAGE_RESIDUALS * k + 3, n + k] -= weights[3] * scale


@kernel(inline=True)
def _input_residuals(k: int, n: int, plan: np.ndarray, u_prev: np.ndarray, weights: np.ndarray, res: np.ndarray,
                     ju: np.ndarray) -> None:
    """Stage k's command moves (steering, demand) and demand size, and their Jacobians in U."""
    base = N_STAGE_RESIDUALS * n
    for q in range(2):
        w, row, col = weights[5 + q], base + q * n + k, q * n + k
        res[row] = w * (plan[col] - (plan[col - 1] if k else u_prev[q]))
        ju[row, col] = w
        if k:
            ju[row, col - 1] = -w
    res[base + 2 * n + k] = weights[7] * plan[n + k]
    ju[base + 2 * n + k, n + k] = weights[7]


@kernel
def linearise(plan: np.ndarray, x0: np.ndarray, params: np.ndarray, u_prev: np.ndarray, weights: np.ndarray,
              mc: np.ndarray, lc: np.ndarray, stage_s: float, substeps: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Residuals (8N,) and their Jacobians in U (8N, 2N), x0 (8N, 7) and P (8N, 2N); the steering angle at every
    stage's start (N,) and its Jacobians in the steering commands (N, N) and in the initial angle (N,)."""
    n = plan.size // 2
    nr = 8 * n
    res, ju, jx, jp = np.zeros(nr), np.zeros((nr, 2 * n)), np.zeros((nr, N_X)), np.zeros((nr, 2 * n))
    delta, delta_u, delta_d = np.empty(n), np.zeros((n, n)), np.empty(n)
    su, sx, sp = np.zeros((N_X, 2 * n)), np.eye(N_X), np.zeros((N_X, 2 * n))
    x, xn, sens, col = x0.copy(), np.empty(N_X), np.empty((N_X, N_SENS)), np.empty(N_X)
    u, p = np.empty(2), np.empty(2)
    for k in range(n):
        delta[k], delta_d[k] = x[4], sx[4, 4]
        for j in range(k):
            delta_u[k, j] = su[4, j]
        u[0], u[1], p[0], p[1] = plan[k], plan[n + k], params[k], params[n + k]
        rk4_stage(x, u, p, mc, lc, stage_s, substeps, xn, sens)
        _chain(sens, su, 0, k, col)     # chain rule: d x_{k+1} = A_k d x_k (+ this stage's own inputs)
        _chain(sens, su, n, k, col)
        _chain(sens, sx, 0, N_X, col)
        _chain(sens, sp, 0, k, col)
        _chain(sens, sp, n, k, col)
        for i in range(N_X):
            su[i, k], su[i, n + k], sp[i, k], sp[i, n + k], x[i] = sens[i, 7], sens[i, 8], sens[i, 9], \
                sens[i, 10], xn[i]
        _stage_residuals(k, n, x, params, weights, su, sx, sp, res, ju, jx, jp)
        _input_residuals(k, n, plan, u_prev, weights, res, ju)
    return res, ju, jx, jp, delta, delta_u, delta_d


@kernel
def prepare(plan: np.ndarray, x0: np.ndarray, params: np.ndarray, u_prev: np.ndarray, weights: np.ndarray,
            mc: np.ndarray, lc: np.ndarray, stage_s: float, substeps: int, eps: float, out: np.ndarray) -> None:
    """The preparation phase: linearise at (plan, x0, params) and condense into the flat record ``out``
    (``prep_offsets``)."""
    n = plan.size // 2
    nv = 2 * n
    res, ju, jx, jp, delta, delta_u, delta_d = linearise(plan, x0, params, u_prev, weights, mc, lc, stage_s,
                                                         substeps)
    condense(res, ju, jx, jp, eps, 2, out)
    _, _, _, _, o_r, o_ru, o_rd, end = prep_offsets(n)
    lag = mc[10]
    out[o_r:o_ru] = (plan[:n] - delta) / lag
    rate_u = np.zeros((n, nv))
    for i in range(n):
        for j in range(i):
            rate_u[i, j] = -delta_u[i, j] / lag
        rate_u[i, i] = 1.0 / lag
    out[o_ru:o_rd] = rate_u.reshape(-1)
    out[o_rd:end] = -delta_d / lag
