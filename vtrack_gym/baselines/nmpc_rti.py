"""The steering NMPC's real-time iteration, compiled: the shared engine (``rti_engine``) with the steering model.

The measured state x0 = (e_y, e_phi, v_y, r, delta); the stage parameters P = (speeds [m/s], curvatures [1/m])
from the observation (``stage_parameters``, the same law as the CasADi NMPC); one input, the road-wheel command,
whose box and actuator-rate bounds are the car's (the rate bounds shift exactly with the measured steering angle:
the actuator is linear). The preparation linearises and condenses with ``nmpc_kernels.prepare``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.nmpc_kernels import N_STATES, advance, prep_offsets, prep_size, prepare
from vtrack_gym.baselines.nmpc_model import TyreShape
from vtrack_gym.baselines.rti_engine import STAT_NAMES, Prepared, RealTimeEngine
from vtrack_gym.baselines.rti_kernels import shifted

__all__ = ["STAT_NAMES", "RealTimeIteration", "TyreShape", "qp_data", "shifted", "stage_parameters"]


@kernel
def stage_parameters(row: np.ndarray, idx: np.ndarray, lay: np.ndarray, stage: np.ndarray, speeds: np.ndarray,
                     kappa: np.ndarray) -> None:
    """Stage speeds [m/s] and curvatures [1/m] of one observation row into ``speeds``, ``kappa`` (the law of
    ``NMPC.stage_parameters``). ``idx``: v_x, target speed, curvature, preview start and length, speed preview
    start and length; ``lay``: preview dt [s], speed preview dt [s], preview min speed [m/s]; ``stage``: stage
    length [s], model speed floor [m/s], speed time constant [s]."""
    n = speeds.size
    v_x, v0, t_stage, v_min = row[idx[0]], row[idx[1]], stage[0], stage[1]
    v_look = max(v_x, lay[2])
    n_sp = idx[6]
    nodes, values = np.empty(n_sp + 1), np.empty(n_sp + 1)
    nodes[0], values[0] = 0.0, v0
    for j in range(n_sp):
        nodes[j + 1], values[j + 1] = v_look * ((j + 1) * lay[1]), row[idx[5] + j]
    step, travelled, mid = max(v_x, v_min) * t_stage, 0.0, 0.0
    for k in range(n):
        travelled += step
        v_ref = np.interp(travelled, nodes, values) if n_sp else v0
        v = v_ref + (v_x - v_ref) * math.exp(-((k + 0.5) * t_stage) / stage[2])
        speeds[k] = max(v, v_min)
    n_p = idx[4]
    nodes, values = np.empty(n_p + 1), np.empty(n_p + 1)
    nodes[0], values[0] = 0.0, row[idx[2]]
    for j in range(n_p):
        nodes[j + 1], values[j + 1] = v_look * ((j + 1) * lay[0]), row[idx[3] + j]
    for k in range(n):
        mid += speeds[k] * t_stage
        kappa[k] = np.interp(mid - 0.5 * speeds[k] * t_stage, nodes, values)


@kernel
def qp_data(prep: np.ndarray, x0: np.ndarray, p: np.ndarray, point: np.ndarray, max_steer: float,
            max_rate: float, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> None:
    """The feedback QP's data from the prepared record: gradient ``g``, rate bounds ``lo``/``hi`` [rad/s] and
    command-step bounds ``lb``/``ub`` [rad]. ``point``: the linearisation point (plan (n), x0 (5), p (2n))."""
    n = g.size
    _, o_g, o_gx, o_gp, o_r, _, o_rd, _ = prep_offsets(n)
    dx = x0 - point[n:n + N_STATES]
    dp = p - point[n + N_STATES:]
    for i in range(n):
        acc = prep[o_g + i]
        for j in range(N_STATES):
            acc += prep[o_gx + i * N_STATES + j] * dx[j]
        for j in range(2 * n):
            acc += prep[o_gp + i * 2 * n + j] * dp[j]
        g[i] = acc
        shift = prep[o_r + i] + prep[o_rd + i] * dx[4]
        lo[i], hi[i] = -max_rate - shift, max_rate - shift
        lb[i], ub[i] = -max_steer - point[i], max_steer - point[i]


class RealTimeIteration(RealTimeEngine):
    """The compiled RTI of an ``NMPCConfig`` (``rti_engine``'s engine, the steering model); one instance per policy.

    State row (``state_size`` = 2 + 3N + 5): the command sent [rad], 1 when a decision was made (0: none yet),
    the plan U (N) [rad], the measured state x0 (5) and stage speeds (N) [m/s] and curvatures (N) [1/m] it used.
    """

    N_INPUTS = 1
    STATE_NAMES = ("e_y", "e_phi", "v_y", "yaw_rate", "road_wheel_angle")

    def __init__(self, design: Any, config: Any, layout: Any, control_period_s: float) -> None:
        super().__init__(design, config, layout, control_period_s)
        self._weights = np.array([math.sqrt(config.weight_e_y), math.sqrt(config.weight_e_phi),
                                  math.sqrt(config.weight_yaw_rate), math.sqrt(config.weight_move),
                                  config.terminal_scale])
        self._warm_up()

    def _stage_parameters(self, obs_row: np.ndarray) -> np.ndarray:
        """(speeds (N) [m/s], curvatures (N) [1/m]) of one observation row."""
        speeds, kappa = np.empty(self.n), np.empty(self.n)
        stage_parameters(obs_row, self._idx, self._lay, self._stage, speeds, kappa)
        return np.concatenate((speeds, kappa))

    def _advance(self, x0: np.ndarray, row: np.ndarray, params: np.ndarray) -> np.ndarray:
        """x0 one control period on with the command sent and the first stage's speed and curvature."""
        return advance(x0, float(row[0]), float(params[0]), float(params[self.n]), self._mc, self.period,
                       self.config.rk4_substeps)

    def _condense(self, point: np.ndarray, row: np.ndarray) -> np.ndarray:
        """The record (``nmpc_kernels.prep_offsets``) at ``point``, the move cost from the command sent."""
        n, cfg = self.n, self.config
        record = np.empty(prep_size(n))
        prepare(point[:n], point[n:n + N_STATES], point[n + N_STATES:2 * n + N_STATES], point[2 * n + N_STATES:],
                float(row[0]), self._weights, self._mc, cfg.stage_time_s, cfg.rk4_substeps, cfg.regularisation,
                record)
        return record

    def _qp_data(self, prep: Prepared, x0: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        """Gradient, rate bounds and command-step bounds (``qp_data``)."""
        g, lo, hi, lb, ub = (np.empty(self.n) for _ in range(5))
        qp_data(prep.record, x0, params, prep.point, self._max_steer, self._max_rate, g, lo, hi, lb, ub)
        return g, lo, hi, lb, ub

    def _clip(self, plan: np.ndarray) -> np.ndarray:
        """The commands within the car's steering limit [rad]."""
        return np.clip(plan, -self._max_steer, self._max_steer)
