"""Compiled prediction model of the real-time NMPC: the model of ``nmpc_model``, its exact Jacobians, and the
preparation phase (linearisation and condensing) of a real-time iteration.

The model is the one ``nmpc_model``'s docstring states (Frenet single-track, Pacejka axle tyres, first-order
steering actuator), here written out with its analytic partial derivatives ``df/d(x, u, v, kappa)``. A stage of
``stage_s`` [s] is ``substeps`` classic RK4 steps; its Jacobians are the exact derivatives of that discrete map
(the chain rule through every RK4 evaluation, what automatic differentiation of the same map gives).

Model constants ``mc`` (``model_constants``): m [kg], I_z [kg m^2], a1, a2 [m], front and rear peak force
mu D_i F_z,i [N], shape C_i and stiffness B_i [1/rad] per axle, actuator lag tau [s].

``prepare`` builds, around a linearisation point (plan ``U``, predicted initial state ``x0``, stage speeds ``v``
and curvatures ``kappa``), everything the feedback phase needs to solve the Gauss-Newton QP for any measured
state and stage parameters near that point (the initial value and the parameters embedded to first order):
``H = J_U' J_U + eps I`` and its inverse Cholesky factor, ``g0 = J_U' res``, ``Gx = J_U' J_x``, ``Gp = J_U' J_p``,
and the actuator rates with their (exactly linear) dependence on ``U`` and on the initial steering angle.
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.rti_kernels import condense, inverse_cholesky_t, record_offsets, rk4_sensitivities

__all__ = ["N_SENS", "N_STATES", "advance", "derivative_and_jacobian", "inverse_cholesky_t", "model_constants",
           "prep_offsets", "prep_size", "prepare", "rk4_stage"]

N_STATES = 5
"""e_y, e_phi, v_y, r, delta."""
N_SENS = 8
"""Sensitivity columns of a stage: d/dx_start (5), d/du, d/dv, d/dkappa."""


def model_constants(design: object, shape: object, lag_s: float) -> np.ndarray:
    """``mc`` of the module docstring from a ``DesignModel``, a ``nmpc_model.TyreShape`` and the lag [s]."""
    from vtrack_gym.vehicle.params import GRAVITY_MPS2

    m, mu = design.mass_kg, design.friction_mu
    fzf = m * GRAVITY_MPS2 * design.cg_to_rear_axle_m / design.wheelbase_m
    fzr = m * GRAVITY_MPS2 * design.cg_to_front_axle_m / design.wheelbase_m
    peak_f, peak_r = mu * shape.front_d * fzf, mu * shape.rear_d * fzr
    return np.array([m, design.yaw_inertia_kgm2, design.cg_to_front_axle_m, design.cg_to_rear_axle_m,
                     peak_f, shape.front_c, design.front_cornering_stiffness_npr / (shape.front_c * peak_f),
                     peak_r, shape.rear_c, design.rear_cornering_stiffness_npr / (shape.rear_c * peak_r), lag_s])


@kernel(inline=True)
def derivative_and_jacobian(x: np.ndarray, u: float, v: float, kappa: float, mc: np.ndarray, f: np.ndarray,
                            jac: np.ndarray) -> None:
    """x' into ``f`` (5,) and ``d x' / d(x, u, v, kappa)`` into ``jac`` (5, 8)."""
    m, iz, a1, a2 = mc[0], mc[1], mc[2], mc[3]
    e_y, e_phi, v_y, r, delta = x[0], x[1], x[2], x[3], x[4]
    qf, qr = (v_y + a1 * r) / v, (v_y - a2 * r) / v
    df, dr = 1.0 / (1.0 + qf * qf), 1.0 / (1.0 + qr * qr)
    alpha_f, alpha_r = delta - math.atan(qf), -math.atan(qr)
    zf, zr = mc[6] * alpha_f, mc[9] * alpha_r
    af, ar = mc[5] * math.atan(zf), mc[8] * math.atan(zr)
    fyf, fyr = mc[4] * math.sin(af), mc[7] * math.sin(ar)
    dfyf = mc[4] * math.cos(af) * mc[5] * mc[6] / (1.0 + zf * zf)
    dfyr = mc[7] * math.cos(ar) * mc[8] * mc[9] / (1.0 + zr * zr)
    cd, sd, cp, sp = math.cos(delta), math.sin(delta), math.cos(e_phi), math.sin(e_phi)
    den = 1.0 - kappa * e_y
    num = v * cp - v_y * sp
    s_dot = num / den
    f[0] = v * sp + v_y * cp
    f[1] = r - kappa * s_dot
    f[2] = (fyf * cd + fyr) / m - v * r
    f[3] = (a1 * fyf * cd - a2 * fyr) / iz
    f[4] = (u - delta) / mc[10]
    jac[:, :] = 0.0
    # slip angles: d alpha / d(v_y, r, v); alpha_f also d/d delta = 1
    af_vy, af_r, af_v = -df / v, -a1 * df / v, qf * df / v
    ar_vy, ar_r, ar_v = -dr / v, a2 * dr / v, qr * dr / v
    jac[0, 1] = v * cp - v_y * sp
    jac[0, 2] = cp
    jac[0, 6] = sp
    ds_ey, ds_ephi, ds_vy = num * kappa / (den * den), (-v * sp - v_y * cp) / den, -sp / den
    jac[1, 0] = -kappa * ds_ey
    jac[1, 1] = -kappa * ds_ephi
    jac[1, 2] = -kappa * ds_vy
    jac[1, 3] = 1.0
    jac[1, 6] = -kappa * cp / den
    jac[1, 7] = -s_dot - kappa * num * e_y / (den * den)
    ff = dfyf * cd  # d(F_yf cos delta) / d alpha_f
    jac[2, 2] = (ff * af_vy + dfyr * ar_vy) / m
    jac[2, 3] = (ff * af_r + dfyr * ar_r) / m - v
    jac[2, 4] = (ff - fyf * sd) / m
    jac[2, 6] = (ff * af_v + dfyr * ar_v) / m - r
    jac[3, 2] = (a1 * ff * af_vy - a2 * dfyr * ar_vy) / iz
    jac[3, 3] = (a1 * ff * af_r - a2 * dfyr * ar_r) / iz
    jac[3, 4] = a1 * (ff - fyf * sd) / iz
    jac[3, 6] = (a1 * ff * af_v - a2 * dfyr * ar_v) / iz
    jac[4, 4] = -1.0 / mc[10]
    jac[4, 5] = 1.0 / mc[10]


@kernel
def rk4_stage(x: np.ndarray, u: float, v: float, kappa: float, mc: np.ndarray, stage_s: float, substeps: int,
              x_out: np.ndarray, sens: np.ndarray) -> None:
    """The state after one stage into ``x_out`` (5,) and its sensitivities d/d(x_start, u, v, kappa) into
    ``sens`` (5, 8) (exact derivatives of the RK4 map)."""
    _rk4_stage(x, u, v, kappa, mc, stage_s, substeps, x_out, sens, np.empty((4, N_STATES)),
               np.empty((N_STATES, N_SENS)), np.empty((4, N_STATES, N_SENS)), np.empty(N_STATES),
               np.empty((N_STATES, N_SENS)))


@kernel(inline=True)
def _jac_times(jac: np.ndarray, dy: np.ndarray, out: np.ndarray) -> None:
    """``out = jac[:, :5] @ dy + [0 | jac[:, 5:]]`` for the model's Jacobian (its structural zeros skipped)."""
    for j in range(N_SENS):
        d0, d1, d2, d3, d4 = dy[0, j], dy[1, j], dy[2, j], dy[3, j], dy[4, j]
        out[0, j] = jac[0, 1] * d1 + jac[0, 2] * d2
        out[1, j] = jac[1, 0] * d0 + jac[1, 1] * d1 + jac[1, 2] * d2 + jac[1, 3] * d3
        out[2, j] = jac[2, 2] * d2 + jac[2, 3] * d3 + jac[2, 4] * d4
        out[3, j] = jac[3, 2] * d2 + jac[3, 3] * d3 + jac[3, 4] * d4
        out[4, j] = jac[4, 4] * d4
    for i in range(N_STATES):
        for j in range(N_STATES, N_SENS):
            out[i, j] += jac[i, j]


@kernel(inline=True)
def _lateral_rates(y: np.ndarray, u: float, p: tuple[float, float], mc: np.ndarray, f: np.ndarray,
                   jac: np.ndarray) -> None:
    """``derivative_and_jacobian`` in ``rti_kernels.rk4_sensitivities``' form (p = (v, kappa))."""
    derivative_and_jacobian(y, u, p[0], p[1], mc, f, jac)


@kernel(inline=True)
def _rk4_stage(x: np.ndarray, u: float, v: float, kappa: float, mc: np.ndarray, stage_s: float, substeps: int,
               x_out: np.ndarray, sens: np.ndarray, f: np.ndarray, jac: np.ndarray, dk: np.ndarray, y: np.ndarray,
               dy: np.ndarray) -> None:
    """``rk4_stage`` with its work arrays given (f (4, 5), jac (5, 8), dk (4, 5, 8), y (5,), dy (5, 8))."""
    rk4_sensitivities(_lateral_rates, _jac_times, x, u, (v, kappa), mc, stage_s, substeps, x_out, sens, f, jac, dk,
                      y, dy)


@kernel
def advance(x: np.ndarray, u: float, v: float, kappa: float, mc: np.ndarray, duration_s: float,
            substeps: int) -> np.ndarray:
    """The state after ``duration_s`` [s] with the command and parameters held (RK4, ``substeps`` steps)."""
    out = np.empty(N_STATES)
    sens = np.empty((N_STATES, N_SENS))
    rk4_stage(x, u, v, kappa, mc, duration_s, substeps, out, sens)
    return out


@kernel
def prep_size(n: int) -> int:
    """Length of the flat preparation record of an ``n``-stage horizon (``prep_offsets``)."""
    return record_offsets(n, 1, N_STATES)[-1]


@kernel
def prep_offsets(n: int) -> tuple[int, int, int, int, int, int, int, int]:
    """Offsets in the flat preparation record (``rti_kernels.record_offsets``, one input): inverse Cholesky factor
    L^-T (n, n), g0 (n), Gx (n, 5), Gp (n, 2n), rate0 (n) [rad/s], rate Jacobian in U (n, n), in the initial
    steering angle (n); and its end."""
    return record_offsets(n, 1, N_STATES)


@kernel(inline=True)
def _chain(sens: np.ndarray, mat: np.ndarray, start: int, cols: int) -> None:
    """``mat[:, start:start + cols] = A @ mat[:, start:start + cols]`` in place, A = ``sens[:, :5]``."""
    for j in range(start, start + cols):
        m0, m1, m2, m3, m4 = mat[0, j], mat[1, j], mat[2, j], mat[3, j], mat[4, j]
        for i in range(N_STATES):
            mat[i, j] = sens[i, 0] * m0 + sens[i, 1] * m1 + sens[i, 2] * m2 + sens[i, 3] * m3 + sens[i, 4] * m4


@kernel
def _linearise(plan: np.ndarray, x0: np.ndarray, speeds: np.ndarray, kappa: np.ndarray, u_prev: float,
               weights: np.ndarray, mc: np.ndarray, stage_s: float, substeps: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Single-shooting least-squares data at the plan: residuals (4N,) and their Jacobians in U (4N, N), x0 (4N, 5)
    and the parameters (v, kappa) (4N, 2N), the steering angle at every stage's start (N,) and its Jacobians in U
    (N, N) and in the initial steering angle (N,). Residual order and weights: ``nmpc_model.linearise_horizon``
    (``weights``: sqrt weights of e_y, e_phi, yaw rate, moves, and the terminal scale)."""
    n = plan.size
    res = np.zeros(4 * n)
    ju, jx, jp = np.zeros((4 * n, n)), np.zeros((4 * n, N_STATES)), np.zeros((4 * n, 2 * n))
    delta, delta_u, delta_d = np.empty(n), np.zeros((n, n)), np.empty(n)
    su, sx, sp = np.zeros((N_STATES, n)), np.eye(N_STATES), np.zeros((N_STATES, 2 * n))
    x, xn, sens = x0.copy(), np.empty(N_STATES), np.empty((N_STATES, N_SENS))
    f, jac, dk = np.empty((4, N_STATES)), np.empty((N_STATES, N_SENS)), np.empty((4, N_STATES, N_SENS))
    y, dy = np.empty(N_STATES), np.empty((N_STATES, N_SENS))
    rows = (0, 1, 3)
    for k in range(n):
        delta[k], delta_d[k] = x[4], sx[4, 4]
        for j in range(k):
            delta_u[k, j] = su[4, j]
        _rk4_stage(x, plan[k], speeds[k], kappa[k], mc, stage_s, substeps, xn, sens, f, jac, dk, y, dy)
        _chain(sens, su, 0, k)          # chain rule: d x_{k+1} = A_k d x_k (+ this stage's own inputs)
        _chain(sens, sx, 0, N_STATES)
        _chain(sens, sp, 0, k)
        _chain(sens, sp, n, k)
        for i in range(N_STATES):
            su[i, k], sp[i, k], sp[i, n + k], x[i] = sens[i, 5], sens[i, 6], sens[i, 7], xn[i]
        scale = weights[4] if k == n - 1 else 1.0
        for r in range(3):
            w = weights[r] * scale
            i = rows[r]
            res[3 * k + r] = w * (x[i] - speeds[k] * kappa[k] if r == 2 else x[i])
            for j in range(k + 1):
                ju[3 * k + r, j] = w * su[i, j]
                jp[3 * k + r, j] = w * sp[i, j]
                jp[3 * k + r, n + j] = w * sp[i, n + j]
            for j in range(N_STATES):
                jx[3 * k + r, j] = w * sx[i, j]
        jp[3 * k + 2, k] -= weights[2] * scale * kappa[k]
        jp[3 * k + 2, n + k] -= weights[2] * scale * speeds[k]
        res[3 * n + k] = weights[3] * (plan[k] - (plan[k - 1] if k else u_prev))
        ju[3 * n + k, k] = weights[3]
        if k:
            ju[3 * n + k, k - 1] = -weights[3]
    return res, ju, jx, jp, delta, delta_u, delta_d


@kernel
def prepare(plan: np.ndarray, x0: np.ndarray, speeds: np.ndarray, kappa: np.ndarray, u_prev: float,
            weights: np.ndarray, mc: np.ndarray, stage_s: float, substeps: int, eps: float, out: np.ndarray) -> None:
    """The preparation phase: linearise at (plan, x0, speeds, kappa) and condense into the flat record ``out``
    (``prep_offsets``)."""
    n = plan.size
    res, ju, jx, jp, delta, delta_u, delta_d = _linearise(plan, x0, speeds, kappa, u_prev, weights, mc, stage_s,
                                                          substeps)
    condense(res, ju, jx, jp, eps, 1, out)
    _, _, _, _, o_r, o_ru, o_rd, end = prep_offsets(n)
    lag = mc[10]
    out[o_r:o_ru] = (plan - delta) / lag
    rate_u = -delta_u / lag
    for i in range(n):
        rate_u[i, i] += 1.0 / lag
    out[o_ru:o_rd] = rate_u.reshape(-1)
    out[o_rd:end] = -delta_d / lag
