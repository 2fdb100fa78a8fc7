"""The coupled NMPC's real-time iteration: the shared engine (``rti_engine``) with the coupled model's two inputs.

The measured state x0 = (e_y, e_phi, v_y, r, delta, v_x, time_error); the stage parameters P = (curvatures,
reference speeds) from the observation (``stage_parameters``); the plan holds N steering commands, then N
longitudinal demands. The feedback QP has boxes on the steering commands and the demands and two-sided rate
constraints on the steering; the preparation linearises and condenses with ``nmpc_coupled_kernels.prepare``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.nmpc_coupled_kernels import prepare
from vtrack_gym.baselines.nmpc_coupled_model import N_X, advance, longitudinal_constants
from vtrack_gym.baselines.rti_engine import Prepared, RealTimeEngine

STATE_NAMES = ("e_y", "e_phi", "v_y", "yaw_rate", "road_wheel_angle", "v_x", "time_error")
"""Observation fields of the measured state x0, in the model's order."""


@kernel
def stage_parameters(row: np.ndarray, idx: np.ndarray, lay: np.ndarray, stage: np.ndarray, out: np.ndarray) -> None:
    """Stage curvatures [1/m] and reference speeds [m/s] of one observation row into ``out`` (2N): the stations
    are those of a speed approaching the target from v_x with time constant ``stage[2]`` [s] (floored at
    ``stage[1]`` [m/s]), mid-stage; curvature and speed are the previews' linear interpolation there (held beyond
    the last sample). ``idx``: v_x, target speed, curvature, preview start and length, speed preview start and
    length; ``lay``: preview dt [s], speed preview dt [s], preview min speed [m/s]; ``stage``: stage length [s],
    speed floor [m/s], time constant [s]."""
    n = out.size // 2
    v_x, v0, t_stage = row[idx[0]], row[idx[1]], stage[0]
    v_look = max(v_x, lay[2])
    n_sp, n_p = idx[6], idx[4]
    sp_nodes, sp_values = np.empty(n_sp + 1), np.empty(n_sp + 1)
    sp_nodes[0], sp_values[0] = 0.0, v0
    for j in range(n_sp):
        sp_nodes[j + 1], sp_values[j + 1] = v_look * ((j + 1) * lay[1]), row[idx[5] + j]
    nodes, values = np.empty(n_p + 1), np.empty(n_p + 1)
    nodes[0], values[0] = 0.0, row[idx[2]]
    for j in range(n_p):
        nodes[j + 1], values[j + 1] = v_look * ((j + 1) * lay[0]), row[idx[3] + j]
    travelled = 0.0
    for k in range(n):
        v_ref = np.interp(travelled, sp_nodes, sp_values) if n_sp else v0
        v = max(v_ref + (v_x - v_ref) * math.exp(-((k + 0.5) * t_stage) / stage[2]), stage[1])
        mid = travelled + 0.5 * v * t_stage
        out[k] = np.interp(mid, nodes, values)
        out[n + k] = np.interp(mid, sp_nodes, sp_values) if n_sp else v0
        travelled += v * t_stage


class CoupledIteration(RealTimeEngine):
    """The compiled RTI of a ``CoupledNMPCConfig`` (``rti_engine``'s engine, the coupled model); one instance per
    policy.

    State row (``state_size`` = 3 + 4N + 7): steering command [rad] and demand sent, 1 once a decision was made,
    the plan (N steering commands, N demands), the measured x0 (7) and the stage parameters P (2N) it used.
    """

    N_INPUTS = 2
    STATE_NAMES = STATE_NAMES

    def __init__(self, design: Any, vehicle: Any, config: Any, layout: Any, control_period_s: float) -> None:
        super().__init__(design, config, layout, control_period_s)
        self._lc = longitudinal_constants(vehicle, config.min_speed_mps, config.min_ref_speed_mps)
        self._weights = np.array([*(math.sqrt(w) for w in (
            config.weight_e_y, config.weight_e_phi, config.weight_yaw_rate, config.weight_speed, config.weight_time,
            config.weight_move, config.weight_demand_move, config.weight_demand)), config.terminal_scale])
        self._limit = np.concatenate((np.full(self.n, self._max_steer), np.ones(self.n)))
        self._warm_up()

    def _stage_parameters(self, obs_row: np.ndarray) -> np.ndarray:
        """(curvatures (N) [1/m], reference speeds (N) [m/s]) of one observation row."""
        params = np.empty(2 * self.n)
        stage_parameters(obs_row, self._idx, self._lay, self._stage, params)
        return params

    def _advance(self, x0: np.ndarray, row: np.ndarray, params: np.ndarray) -> np.ndarray:
        """x0 one control period on with the commands sent and the first stage's parameters."""
        return advance(x0, row[:2].copy(), np.array([params[0], params[self.n]]), self._mc, self._lc, self.period,
                       self.config.rk4_substeps)

    def _condense(self, point: np.ndarray, row: np.ndarray) -> np.ndarray:
        """The record (``nmpc_coupled_kernels.prep_offsets``) at ``point``, the moves from the commands sent."""
        nv, cfg = 2 * self.n, self.config
        record = np.empty(self._offsets[-1])
        prepare(point[:nv], point[nv:nv + N_X], point[nv + N_X:], row[:2].copy(), self._weights, self._mc, self._lc,
                cfg.stage_time_s, cfg.rk4_substeps, cfg.regularisation, record)
        return record

    def _qp_data(self, prep: Prepared, x0: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        """Gradient, steering-rate bounds and increment bounds of the feedback QP at the measured (x0, P)."""
        nv = 2 * self.n
        _, o_g, o_gx, o_gp, o_r, o_ru, o_rd, end = self._offsets
        rec, point = prep.record, prep.point
        dx, dp = x0 - point[nv:nv + N_X], params - point[nv + N_X:]
        g = rec[o_g:o_gx] + rec[o_gx:o_gp].reshape(nv, N_X) @ dx + rec[o_gp:o_r].reshape(nv, nv) @ dp
        shift = rec[o_r:o_ru] + rec[o_rd:end] * dx[4]
        return g, -self._max_rate - shift, self._max_rate - shift, -self._limit - point[:nv], \
            self._limit - point[:nv]

    def _clip(self, plan: np.ndarray) -> np.ndarray:
        """The steering commands within the car's limit [rad], the demands within [-1, 1]."""
        n = self.n
        plan[:n] = np.clip(plan[:n], -self._max_steer, self._max_steer)
        plan[n:] = np.clip(plan[n:], -1.0, 1.0)
        return plan
