"""The nonlinear MPC's prediction model, built with CasADi (``pip install "vtrack_gym[nmpc]"``).

Single-track model in path (Frenet) coordinates with Pacejka lateral axle tyres and the steering actuator,
state ``x = (e_y [m], e_phi [rad], v_y [m/s], r [rad/s], delta [rad])``, input the commanded road-wheel angle
``u`` [rad], stage parameters the speed ``v`` [m/s] (the speed the env's PD-FLC is expected to hold) and the path
curvature ``kappa`` [1/m] at the stage's predicted station::

    alpha_f = delta - atan((v_y + a1 r) / v),         alpha_r = -atan((v_y - a2 r) / v)
    F_y,i   = mu D_i F_z,i sin(C_i atan(B_i alpha_i)),  B_i = C_alpha,i / (C_i D_i mu F_z,i)   (slope = C_alpha,i)
    v_y'    = (F_yf cos delta + F_yr) / m - v r,         r' = (a1 F_yf cos delta - a2 F_yr) / I_z
    s'      = (v cos e_phi - v_y sin e_phi) / (1 - kappa e_y)
    e_y'    = v sin e_phi + v_y cos e_phi,               e_phi' = r - kappa s'
    delta'  = (u - delta) / tau                           (actuator lag; its rate limit is a QP constraint)

F_z,i is the static axle load (m g a2 / l front, m g a1 / l rear); C_alpha,i, mu, m, I_z, a1, a2 come from the
env's ``DesignModel``, the shape factors C_i, D_i from the config. Integration: classic RK4 with
``rk4_substeps`` sub-steps per stage of ``stage_time_s``.

``horizon_functions`` builds two CasADi functions over the horizon (the stage map accumulated from the measured
state, and every stage's Jacobians mapped over the predicted trajectory); ``linearise_horizon`` condenses them
(single shooting: sensitivities of every state to every command by the chain rule, in numpy) into the
least-squares residuals of the stage costs, their Jacobian, and the actuator rates ``(u_k - delta_k) / tau`` with
their Jacobian. A Gauss-Newton QP built from them is the real-time iteration of ``vtrack_gym.baselines.nmpc``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym.baselines.casadi_import import import_casadi
from vtrack_gym.vehicle.params import GRAVITY_MPS2, DesignModel

N_STATES = 5
"""e_y, e_phi, v_y, r, delta."""


@dataclass(frozen=True)
class TyreShape:
    """Pacejka shape of the axle tyres: C (shape factor) and D (peak factor; peak force = mu D F_z) per axle."""

    front_c: float
    front_d: float
    rear_c: float
    rear_d: float


@dataclass(frozen=True)
class HorizonWeights:
    """Square roots of the least-squares weights of ``condensed_problem`` (units: 1/unit of the residual)."""

    e_y: float
    e_phi: float
    yaw_rate: float
    move: float
    terminal_scale: float


def _tyre_force(ca: Any, alpha: Any, c_alpha: float, fz: float, mu: float, c: float, d: float) -> Any:
    """Pacejka axle force [N] with slope ``c_alpha`` [N/rad] at zero slip and peak ``mu d fz`` [N]."""
    b = c_alpha / (c * d * mu * fz)
    return mu * d * fz * ca.sin(c * ca.atan(b * alpha))


def state_derivative(ca: Any, design: DesignModel, shape: TyreShape, lag_s: float, x: Any, u: Any, v: Any,
                     kappa: Any) -> Any:
    """x' of the module docstring (CasADi expressions; ``v`` [m/s] > 0)."""
    m, iz = design.mass_kg, design.yaw_inertia_kgm2
    a1, a2, mu = design.cg_to_front_axle_m, design.cg_to_rear_axle_m, design.friction_mu
    fzf = m * GRAVITY_MPS2 * a2 / design.wheelbase_m
    fzr = m * GRAVITY_MPS2 * a1 / design.wheelbase_m
    e_y, e_phi, v_y, r, delta = x[0], x[1], x[2], x[3], x[4]
    alpha_f = delta - ca.atan((v_y + a1 * r) / v)
    alpha_r = -ca.atan((v_y - a2 * r) / v)
    fyf = _tyre_force(ca, alpha_f, design.front_cornering_stiffness_npr, fzf, mu, shape.front_c, shape.front_d)
    fyr = _tyre_force(ca, alpha_r, design.rear_cornering_stiffness_npr, fzr, mu, shape.rear_c, shape.rear_d)
    s_dot = (v * ca.cos(e_phi) - v_y * ca.sin(e_phi)) / (1.0 - kappa * e_y)
    return ca.vertcat(v * ca.sin(e_phi) + v_y * ca.cos(e_phi),
                      r - kappa * s_dot,
                      (fyf * ca.cos(delta) + fyr) / m - v * r,
                      (a1 * fyf * ca.cos(delta) - a2 * fyr) / iz,
                      (u - delta) / lag_s)


def rk4_stage(ca: Any, f: Any, x: Any, u: Any, v: Any, kappa: Any, stage_s: float, substeps: int) -> Any:
    """State after one stage of ``stage_s`` [s] (``substeps`` classic RK4 steps, input and parameters held)."""
    h = stage_s / substeps
    for _ in range(substeps):
        k1 = f(x, u, v, kappa)
        k2 = f(x + 0.5 * h * k1, u, v, kappa)
        k3 = f(x + 0.5 * h * k2, u, v, kappa)
        k4 = f(x + h * k3, u, v, kappa)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


@dataclass(frozen=True)
class HorizonFunctions:
    """CasADi functions over the horizon: ``simulate(x0, U, V, K) -> X`` (5, N), the states after every stage,
    and ``linearise(X_start, U, V, K) -> (A (5, 5N), B (5, N))``, every stage's Jacobians at its start state."""

    simulate: Any
    linearise: Any
    compiled: bool = False
    """Whether the stage functions run as compiled C (``nmpc_codegen``), else on CasADi's virtual machine."""


def c_compiler_available() -> bool:
    """Whether CasADi's functions can be compiled to machine code here (``nmpc_codegen.c_compiler``)."""
    from vtrack_gym.baselines.nmpc_codegen import c_compiler

    return c_compiler() is not None


@functools.lru_cache(maxsize=8)
def horizon_functions(design: DesignModel, shape: TyreShape, lag_s: float, stage_s: float, substeps: int,
                      horizon: int, compiled: bool) -> HorizonFunctions:
    """The stage map (RK4, the module docstring's model) accumulated and mapped over ``horizon`` stages.

    ``compiled``: the stage functions are generated as C and compiled once into the user's cache directory
    (``nmpc_codegen.compiled_functions``, keyed by the generated source; about 1 s the first time, loaded after;
    evaluation about 5x faster than CasADi's virtual machine, which is kept where no compiler is found).
    """
    ca = import_casadi()
    xs, us, vs, ks = ca.SX.sym("x", N_STATES), ca.SX.sym("u"), ca.SX.sym("v"), ca.SX.sym("kappa")
    f = ca.Function("f", [xs, us, vs, ks], [state_derivative(ca, design, shape, lag_s, xs, us, vs, ks)])
    x_next = rk4_stage(ca, f, xs, us, vs, ks, stage_s, substeps)
    stage = ca.Function("vtrack_stage", [xs, us, vs, ks], [x_next])
    stage_jac = ca.Function("vtrack_stage_jac", [xs, us, vs, ks],
                            [ca.jacobian(x_next, xs), ca.jacobian(x_next, us)])
    loaded = None
    if compiled:
        from vtrack_gym.baselines.nmpc_codegen import compiled_functions

        loaded = compiled_functions([stage, stage_jac])
    if loaded is not None:
        stage, stage_jac = loaded
    return HorizonFunctions(stage.mapaccum("simulate", horizon), stage_jac.map(horizon, "serial"), loaded is not None)


@dataclass(frozen=True)
class Linearisation:
    """Least-squares residuals ``res`` (4N,) and their Jacobian ``jac`` (4N, N) in U, actuator rates ``rate`` (N,)
    [rad/s] with Jacobian ``rate_jac`` (N, N), and the predicted states ``states`` (5, N + 1) from x0."""

    res: np.ndarray
    jac: np.ndarray
    rate: np.ndarray
    rate_jac: np.ndarray
    states: np.ndarray


def linearise_horizon(fns: HorizonFunctions, weights: HorizonWeights, lag_s: float, plan: np.ndarray,
                      x0: np.ndarray, speeds: np.ndarray, kappa: np.ndarray, u_prev: float) -> Linearisation:
    """Single-shooting Gauss-Newton data of the plan ``plan`` [rad] (N,) from the measured state ``x0``.

    Residuals per stage k = 1..N: ``w_ey e_y,k``, ``w_ephi e_phi,k``, ``w_r (r_k - v_k kappa_k)`` (the last stage's
    three scaled by ``terminal_scale``) and ``w_move (u_k - u_{k-1})`` (u_0's move from ``u_prev``); rates:
    ``(u_k - delta_k) / tau`` at the start of every stage.
    """
    n = plan.size
    row = plan.reshape(1, n)
    vrow, krow = speeds.reshape(1, n), kappa.reshape(1, n)
    after = np.asarray(fns.simulate(x0, row, vrow, krow))
    states = np.hstack((x0.reshape(-1, 1), after))
    a_all, b_all = (np.asarray(m) for m in fns.linearise(states[:, :-1], row, vrow, krow))
    sens = np.zeros((N_STATES, n))          # d x_k / d U, starting with x_0 (fixed)
    start_delta_jac = np.zeros((n, n))       # d delta_k / d U at the start of each stage
    stage_jac = np.zeros((n, N_STATES, n))   # d x_{k+1} / d U
    for k in range(n):
        start_delta_jac[k] = sens[4]
        sens = a_all[:, N_STATES * k:N_STATES * (k + 1)] @ sens
        sens[:, k] += b_all[:, k]
        stage_jac[k] = sens
    scale = np.ones(n)
    scale[-1] = weights.terminal_scale
    w = np.array([weights.e_y, weights.e_phi, weights.yaw_rate])[None, :] * scale[:, None]   # (N, 3)
    track = np.stack((after[0], after[1], after[3] - speeds * kappa), axis=1) * w
    track_jac = stage_jac[:, [0, 1, 3], :] * w[:, :, None]
    moves = np.diff(np.concatenate(([u_prev], plan)))
    move_jac = weights.move * (np.eye(n) - np.eye(n, k=-1))
    res = np.concatenate((track.reshape(-1), weights.move * moves))
    jac = np.vstack((track_jac.reshape(3 * n, n), move_jac))
    rate = (plan - states[4, :-1]) / lag_s
    rate_jac = (np.eye(n) - start_delta_jac) / lag_s
    return Linearisation(res, jac, rate, rate_jac, states)
