"""Constrained linear MPC on Rajamani's error model, solved with OSQP (peer; needs ``pip install osqp``).

Model: x = (e_y [m], e_y_dot [m/s], e_phi [rad], e_phi_dot [rad/s]) with
``x' = A4 x + B4 delta + E4 psi_ref_dot + F4 psi_ref_ddot`` (``linear_models.error_model``), all three inputs
ZOH-discretised at ``sample_time_s`` T_s (default 0.02 s). Prediction over N_p steps; N_c free moves
U = (u_0, ..., u_{N_c-1}) [rad], u_i = u_{N_c-1} afterwards (move blocking).

Disturbance preview (``use_preview``): psi_ref_dot = v kappa and psi_ref_ddot = v^2 kappa' at the middle of
each step, kappa and kappa' from ``linear_models.curvature_preview_operator`` (without preview: the current
curvature held, kappa' = 0).

Cost (condensed, dense QP in U only)::

    J = sum_{i=1..N_p} (x_i - x_ref,i)' Q (x_i - x_ref,i) + r_delta sum_j (u_j - u_ref,j)^2
        + r_rate sum_j (u_j - u_{j-1})^2,     u_{-1} = previous applied steering
    x_ref,i = (0, 0, e_phi,ss(kappa_i), 0),  u_ref,j = delta_ss(kappa_j)   (steady state on the previewed curve)

Constraints: |u_j| <= max_road_wheel_angle_rad and (``rate_limit``) |u_j - u_{j-1}| <= max_road_wheel_rate T_s.

Solver structure: ``P`` (N_c x N_c) and the map ``q = M_q [x; p; u_prev]`` (p = curvature preview vector) are
precomputed on a speed grid (as the other MPCs) and interpolated per entry. The constraint matrix
``A = [I; D]`` is constant (set up ONCE, never updated); each solve updates q, l, u, and P's values through
``update(Px=...)`` only when the model speed changes. The model speed is the speed rounded to a multiple of
``speed_update_tol_mps`` (0.05 m/s; P and q both use it, so they always belong to one model, and a row's QP
depends on its own speed only, not on which row was solved before). Warm start: the previous
solution of the same row, shifted by one move (kept in the policy state).

Batches are solved one row at a time with the same OSQP workspace (each row warm-started from its own state);
the cost is linear in N. The condensed QP is ill-conditioned at speed (cond(P) = 4e3 at 11 m/s, 6e4 at
45 m/s: Su' Q Su dominates), so ADMM at OSQP's default eps = 1e-3..1e-5 stops far from the optimum in the flat
directions. Measured on 60 random cold-started QPs, first-move error vs a 1e-10 reference: eps 1e-5 ->
1.5e-4 rad; eps 1e-7 (default here) -> 1.4e-6 rad (mean 274, max 800 iterations, ~140 us cold; warm-started
closed-loop solves need far fewer). OSQP's solution polishing would be exact but prints to stdout whenever no
constraint is active and sometimes fails (then the ADMM iterate is returned), so it is off. Every solve
starts from the same rho (``OSQP_RHO``; OSQP's adaptive rho would otherwise carry over from the previous row's
solve), so single and batched calls agree to ~1e-10 rad.
Sample time vs control period: as ``mpc.MPC``: a new QP every
round(T_s / T_c) env steps, the output held in between. If OSQP does not return a finite solution, the
previous steering is held (logged as a WARNING and counted in ``solver_failures``).

State per row (``state_size = 2 + 3 N_c``): applied u(k-1) [rad], env steps left before the next solve, the
last primal solution U (N_c) and its duals (2 N_c) (warm start: U shifted by one move, the duals as they are).
On the first call / episode start u(k-1) = the observation's road_wheel_angle.
"""

from __future__ import annotations

import functools
import inspect
import logging
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import Range, documented, ranged, validate
from vtrack_gym.baselines.base import Policy, SpeedSchedule, hold_steps
from vtrack_gym.baselines.linear_models import (
    curvature_preview_operator,
    error_model,
    sideslip_gain,
    understeer_gradient,
    zoh,
)
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

logger = logging.getLogger(__name__)

OSQP_INFINITY = 1e30
"""Bound used for absent constraints (OSQP's infinity)."""
SETUP_SPEED_MPS = 15.0
"""Speed [m/s] whose P is used at setup (OSQP computes its data scaling once, from the setup matrices)."""
OSQP_RHO = 0.1
"""ADMM step size every solve starts from (OSQP's default; its adaptive rho then tunes it within the solve)."""


@documented
@dataclass(frozen=True)
class OSQPMPCConfig:
    """Constrained MPC parameters.

    sample_time_s: T_s [s]. prediction_horizon N_p; control_horizon N_c (also <= N_p). q_e_y [1/m^2], q_e_y_dot
    [s^2/m^2], q_e_phi [1/rad^2], q_e_phi_dot [s^2/rad^2]: state weights. r_delta [1/rad^2]: weight on u - u_ref.
    r_rate [1/rad^2]: weight on each move. use_preview, rate_limit: see the module docstring. Schedule grid:
    min/max speed [m/s], n_speeds. speed_update_tol_mps [m/s]: model-speed quantum (P refresh). eps_abs, eps_rel,
    max_iter: OSQP settings.
    """

    sample_time_s: float = ranged(0.02, ge=0.001, le=0.2, unit="s")
    prediction_horizon: int = ranged(50, ge=1, le=60, integer=True)
    control_horizon: int = ranged(10, ge=1, le=50, integer=True)
    q_e_y: float = ranged(10.0, ge=0.0, le=1e6, unit="1/m^2")
    q_e_y_dot: float = ranged(0.0, ge=0.0, le=1e6, unit="s^2/m^2")
    q_e_phi: float = ranged(10.0, ge=0.0, le=1e6, unit="1/rad^2")
    q_e_phi_dot: float = ranged(0.0, ge=0.0, le=1e6, unit="s^2/rad^2")
    r_delta: float = ranged(1.0, ge=1e-6, le=1e6, unit="1/rad^2")
    r_rate: float = ranged(10.0, ge=0.0, le=1e6, unit="1/rad^2")
    use_preview: bool = True
    rate_limit: bool = True
    min_speed_mps: float = ranged(1.0, ge=0.5, le=80.0, unit="m/s")
    max_speed_mps: float = ranged(45.0, gt="min_speed_mps", le=80.0, unit="m/s")
    n_speeds: int = ranged(60, ge=2, le=100, integer=True)
    speed_update_tol_mps: float = ranged(0.05, ge=0.0, le=5.0, unit="m/s")
    eps_abs: float = ranged(1e-7, ge=1e-9, le=0.1)
    eps_rel: float = ranged(1e-7, ge=1e-9, le=0.1)
    max_iter: int = ranged(4000, ge=10, le=100000, integer=True)

    def __post_init__(self) -> None:
        validate(self)
        Range(ge=1, le="prediction_horizon", integer=True).check(self, "control_horizon")


OSQP_MPC_PRESETS: dict[str, OSQPMPCConfig] = {"default": OSQPMPCConfig()}


def _difference_matrix(n: int) -> np.ndarray:
    """D with (D U)_0 = u_0 and (D U)_j = u_j - u_{j-1}."""
    d = np.eye(n)
    d[np.arange(1, n), np.arange(n - 1)] = -1.0
    return d


@dataclass(frozen=True)
class CondensedQP:
    """Condensed QP at one speed: P (N_c, N_c) and q = M_q z with z = (x (4), p (P + 2), u_prev (1))."""

    p: np.ndarray
    mq: np.ndarray


def condensed_qp(design: DesignModel, v_x: float, config: OSQPMPCConfig, layout: ObservationLayout = OBS
                 ) -> CondensedQP:
    """The QP matrices of the module docstring at speed ``v_x`` [m/s] (P = Hessian of J, q = gradient at 0)."""
    npred, nc, ts = config.prediction_horizon, config.control_horizon, config.sample_time_s
    v = float(v_x)
    mdl = error_model(design, v)
    ad, bw = zoh(mdl.a, np.column_stack((mdl.b, mdl.e, mdl.f)), ts)
    bd, ed, fd = bw[:, 0], bw[:, 1], bw[:, 2]
    n_p = layout.n_preview + 2
    if config.use_preview:
        kap_mid, dkap_mid = curvature_preview_operator(layout, v, v * ts * (np.arange(npred) + 0.5))
        kap_end, _ = curvature_preview_operator(layout, v, v * ts * (np.arange(npred) + 1.0))
    else:
        kap_mid = np.zeros((npred, n_p))
        kap_mid[:, 0] = 1.0
        dkap_mid = np.zeros((npred, n_p))
        kap_end = kap_mid
    powers = [np.eye(4)]
    for _ in range(npred):
        powers.append(ad @ powers[-1])
    sx = np.vstack(powers[1:])                       # (4 N_p, 4): x_{i+1} = A^{i+1} x_0 + ...
    gb = np.array([pw @ bd for pw in powers[:npred]])  # (N_p, 4): A^j b
    ge = np.array([pw @ ed for pw in powers[:npred]])
    gf = np.array([pw @ fd for pw in powers[:npred]])
    te = np.zeros((4 * npred, npred))                # Toeplitz blocks: (i, m) = A^(i-m) e for m <= i
    tf = np.zeros((4 * npred, npred))
    tb = np.zeros((4 * npred, npred))
    for i in range(npred):
        rows = slice(4 * i, 4 * i + 4)
        te[rows, :i + 1] = ge[i::-1].T
        tf[rows, :i + 1] = gf[i::-1].T
        tb[rows, :i + 1] = gb[i::-1].T
    blocking = np.zeros((npred, nc))                 # u_m = U[min(m, N_c - 1)]
    blocking[np.arange(npred), np.minimum(np.arange(npred), nc - 1)] = 1.0
    su = tb @ blocking
    sp = te @ (v * kap_mid) + tf @ (v * v * dkap_mid)
    rp = np.zeros((4 * npred, n_p))
    rp[2::4] = -sideslip_gain(design, v) * kap_end
    up = (design.wheelbase_m + understeer_gradient(design) * v * v) * kap_mid[:nc]
    qdiag = np.tile([config.q_e_y, config.q_e_y_dot, config.q_e_phi, config.q_e_phi_dot], npred)
    suq = su.T * qdiag
    dmat = _difference_matrix(nc)
    hess = suq @ su + config.r_delta * np.eye(nc) + config.r_rate * dmat.T @ dmat
    mq = np.zeros((nc, 4 + n_p + 1))
    mq[:, :4] = suq @ sx
    mq[:, 4:4 + n_p] = suq @ (sp - rp) - config.r_delta * up
    mq[0, -1] = -config.r_rate
    return CondensedQP(2.0 * hess, 2.0 * mq)


@functools.lru_cache(maxsize=16)
def qp_table(design: DesignModel, config: OSQPMPCConfig, layout: ObservationLayout = OBS
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(speeds, P upper triangles in CSC order (S, N_c (N_c+1)/2), M_q (S, N_c * width))`` on the grid."""
    speeds = np.geomspace(config.min_speed_mps, config.max_speed_mps, config.n_speeds)
    cols, rows = _triu_csc_order(config.control_horizon)
    ps, mqs = [], []
    for v in speeds:
        qp = condensed_qp(design, float(v), config, layout)
        ps.append(qp.p[rows, cols])
        mqs.append(qp.mq.reshape(-1))
    out = (speeds, np.array(ps), np.array(mqs))
    for arr in out:
        arr.setflags(write=False)
    return out


def _triu_csc_order(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Column and row indices of the upper triangle of an n x n matrix in CSC (column-major) order."""
    cols = np.concatenate([np.full(j + 1, j) for j in range(n)])
    rows = np.concatenate([np.arange(j + 1) for j in range(n)])
    return cols, rows


class OSQPMPC(Policy):
    """Constrained MPC (angle and rate limits) solved by OSQP; see the module docstring."""

    name: ClassVar[str] = "mpc_osqp"
    PRESETS: ClassVar[dict[str, OSQPMPCConfig]] = OSQP_MPC_PRESETS
    config_type: ClassVar[type] = OSQPMPCConfig

    def __init__(self, design: DesignModel, config: OSQPMPCConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        cfg: OSQPMPCConfig = self.config
        self.n_hold = hold_steps(cfg.sample_time_s, self.control_period_s, "OSQPMPCConfig")
        nc = cfg.control_horizon
        self.state_size = 2 + 3 * nc
        speeds, p_tab, mq_tab = qp_table(design, cfg, layout)
        self._p_schedule = SpeedSchedule(speeds, p_tab)
        self._mq_schedule = SpeedSchedule(speeds, mq_tab.reshape(speeds.size, -1))
        self._rate = design.max_road_wheel_rate_radps * cfg.sample_time_s if cfg.rate_limit else OSQP_INFINITY
        self._lower = np.concatenate((np.full(nc, -self.max_steer_rad), np.full(nc, -self._rate)))
        self._upper = -self._lower
        self._nc = nc
        L = layout
        self._idx = (L.index("v_x"), L.index("e_y"), L.index("e_y_dot"), L.index("e_phi"), L.index("e_phi_dot"),
                     L.index("curvature"), L.index("curvature_rate"), L.index("road_wheel_angle"))
        self._pv = (layout.preview.start, layout.preview.stop)
        self._solver, self._solve = self._setup_solver()
        self._v_p = SETUP_SPEED_MPS

    def __deepcopy__(self, memo: dict[int, Any]) -> OSQPMPC:
        """A copy with a solver of its own, set up afresh (an OSQP workspace cannot be copied; every solve
        warm-starts from the policy's ``state`` and resets rho, so a fresh solver acts the same)."""
        import copy

        clone = self.__class__.__new__(self.__class__)
        memo[id(self)] = clone
        for key, value in vars(self).items():
            if key not in ("_solver", "_solve"):
                setattr(clone, key, copy.deepcopy(value, memo))
        clone._solver, clone._solve = clone._setup_solver()
        clone._v_p = SETUP_SPEED_MPS
        return clone

    # ------------------------------------------------------------------------------------------ solver
    def _setup_solver(self) -> tuple[Any, Any]:
        import osqp
        from scipy import sparse

        cfg: OSQPMPCConfig = self.config
        nc = self._nc
        _, rows = _triu_csc_order(nc)
        indptr = np.concatenate(([0], np.cumsum(np.arange(1, nc + 1))))
        p0 = sparse.csc_matrix((self._p_schedule.row(SETUP_SPEED_MPS), rows, indptr), shape=(nc, nc))
        a = sparse.csc_matrix(np.vstack((np.eye(nc), _difference_matrix(nc))))
        solver = osqp.OSQP()
        solver.setup(p0, np.zeros(nc), a, self._lower.copy(), self._upper.copy(), verbose=False,
                     eps_abs=cfg.eps_abs, eps_rel=cfg.eps_rel, max_iter=cfg.max_iter, polishing=False, rho=OSQP_RHO,
                     warm_starting=True)
        if "raise_error" in inspect.signature(solver.solve).parameters:
            return solver, functools.partial(solver.solve, raise_error=False)
        return solver, solver.solve

    def _qp_solve(self, v: float, z: np.ndarray, u_prev: float, warm_x: np.ndarray,
                  warm_y: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Primal and dual solution of the QP at speed ``v`` [m/s] for z = (x, p, u_prev); None if OSQP failed."""
        tol = self.config.speed_update_tol_mps
        v_model = min(max(round(v / tol) * tol if tol > 0.0 else v, self._p_schedule.v_min), self._p_schedule.v_max)
        if v_model != self._v_p:
            self._solver.update(Px=self._p_schedule.row(v_model))
            self._v_p = v_model
        q = self._mq_schedule.row(v_model).reshape(self._nc, -1) @ z
        lower, upper = self._lower.copy(), self._upper.copy()
        lower[self._nc] = u_prev - self._rate
        upper[self._nc] = u_prev + self._rate
        self._solver.update(q=q, l=lower, u=upper)
        self._solver.update_settings(rho=OSQP_RHO)  # every solve starts from the same rho: no history across rows
        self._solver.warm_start(x=warm_x, y=warm_y)
        res = self._solve()
        x, y = res.x, res.y
        if x is None or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            self.solver_failures += 1
            logger.warning("OSQP MPC: no finite solution (status %s); holding the previous steering",
                           getattr(res.info, "status", "?"))
            return None
        return x, y

    # ----------------------------------------------------------------------------------------- memory
    def _initial_state_batch(self, obs: np.ndarray) -> np.ndarray:
        st = np.zeros((obs.shape[0], self.state_size))
        u = np.clip(obs[:, self._idx[7]], -self.max_steer_rad, self.max_steer_rad)
        st[:, 0] = u
        st[:, 2:2 + self._nc] = u[:, None]
        return st

    # ------------------------------------------------------------------------------------------ control
    def _act_row(self, row: list[float], state: list[float]) -> tuple[float, list[float]]:
        """Road-wheel angle [rad] and new memory for one observation row (the law; ``_act_batch`` loops it)."""
        u_prev, count = state[0], state[1]
        if count >= 0.5:
            state[1] = count - 1.0
            return u_prev, state
        iv, iey, ieyd, iep, iepd, ik, ikr, _ = self._idx
        z = np.array([row[iey], row[ieyd], row[iep], row[iepd], row[ik], *row[self._pv[0]:self._pv[1]], row[ikr],
                      u_prev])
        nc = self._nc
        warm_x = np.array(state[3:2 + nc] + state[1 + nc:2 + nc])
        sol = self._qp_solve(max(row[iv], 0.0), z, u_prev, warm_x, np.array(state[2 + nc:]))
        if sol is None:
            return u_prev, [u_prev, self.n_hold - 1.0, *state[2:]]
        x, y = sol
        u = min(max(float(x[0]), -self.max_steer_rad), self.max_steer_rad)
        u = min(max(u, u_prev - self._rate), u_prev + self._rate)
        return u, [u, self.n_hold - 1.0, *x.tolist(), *y.tolist()]

    def _act_batch(self, obs: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        new = state.copy()
        out = np.empty(obs.shape[0])
        for n in range(obs.shape[0]):
            u, st = self._act_row(obs[n].tolist(), state[n].tolist())
            out[n] = u
            new[n] = st
        return out, new
