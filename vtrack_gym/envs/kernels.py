"""Compiled env step: physics for every car, projection on its path, observation, termination, reward, signals.

One numba call per control period for all N cars (N = 1 for the single env), so the single and the vector
env run the same per-car code and give bit-identical results. Imported lazily by ``envs.sim``.

Every array the step reads or writes travels in one ``SimArrays`` bundle (a NamedTuple: fields are read by
name, so two arrays cannot be swapped silently). Track data of all paths in use are concatenated: ``tables``
(M, 14): the 8 columns of ``vtrack_gym.tracks.path``, then the squared reference speed v_ref^2 [m^2/s^2], the
drivable half widths left / right [m] of each row (``C_V2``, ``C_WL``, ``C_WR``; interpolated linearly, so v^2 is
linear in s between rows), the cumulative reference time t_ref(s_i) [s] of the speed table's time law
(``C_T``: ``tracks.time_law``, from which ``reference_time`` gives the exact t_ref(s) between rows) and cos psi,
sin psi of the row's heading (``C_COS``, ``C_SIN``: the projection reads them instead of computing them); ``tmeta``
(K, N_TM) holds per track k its first row, row count, spacing [m], length [m], closed flag (0/1), half width [m],
whether it has a speed profile (0/1), the release station [m] from which the speed loop is off (+inf on every track
but an ``EntryThenRelease`` one), the pedals' mode after it (0 coast, 1 hold the throttle) and the table's lap time
[s]; ``veh_track[i]`` is car i's track.

Longitudinal tracking errors (every control mode; ``info["speed_error_mps"]``, ``info["time_error_s"]``, and the
observation's last two fields in the longitudinal modes): e_v = v_x - v_ref(s*) [m/s] and
e_t = t - (t_ref(s0 + progress) - t_ref(s0)) [s], t the time since reset and s0 the car's station at reset
(positive: behind the reference).

Control modes (``cfg[CFG_CONTROL]``, ``envs.control``): 0 (steer) runs the PD-FLC speed loop exactly as before;
1 and 2 map the car's demand ``car[:, CAR_DEMAND]`` to throttle / brake (``envs.control.pedals``) and add the
reward's speed term.
Constant settings travel in one vector ``cfg``: the fields of ``StepConstants``, then of the observation layout,
then of the ``RewardConfig``, each offset (``CFG_*``, ``RW_*``) derived from the dataclass fields by name.
Per-car scalars sit in ``car`` (n, N_CAR) (``CAR_*`` columns); ``sig`` (n, len(SIGNAL_ROW)) is the row of ``info``
signals and reward terms (``envs.schema``); ``obs`` is written by ``write_scalar_fields`` (the scalars) and the
preview loops.
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass, fields
from typing import NamedTuple

import numpy as np

from vtrack_gym._jit import kernel, prange
from vtrack_gym.envs.config import EnvConfig, RewardConfig, Scenario
from vtrack_gym.envs.control import MODE_CODES
from vtrack_gym.envs.observation import N_SCALARS, SCALAR_BOUNDS, SCALAR_FIELDS, TRACKING_ERRORS, ObservationLayout
from vtrack_gym.envs.pdflc_kernel import pdflc_step
from vtrack_gym.envs.schema import REWARD_TERMS, SIGNAL_ROW
from vtrack_gym.tracks import table as track_table
from vtrack_gym.tracks.kernels import (
    PREVIEW_BLOCK,
    curvature_preview,
    height_columns,
    lateral_offset_cs,
    lerp_column,
    projection_row,
)
from vtrack_gym.tracks.kernels import interp_linear as _linear
from vtrack_gym.tracks.kernels import wrap_angle as _wrap
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.kernels import step_vehicle

# Column order of the track tables: declared by their owner, ``vtrack_gym.tracks.table``.
C_X, C_Y, C_PSI, C_KAPPA = track_table.COL_X, track_table.COL_Y, track_table.COL_PSI, track_table.COL_KAPPA
C_DKAPPA, C_Z, C_GRADE, C_ZPP = track_table.COL_DKAPPA, track_table.COL_Z, track_table.COL_GRADE, track_table.COL_ZPP
N_COLS = track_table.N_COLS
C_V2, C_WL, C_WR, C_T, C_COS, C_SIN = range(N_COLS, N_COLS + 6)   # the env's own columns after the path's
N_ENV_COLS = N_COLS + 6   # C_T: the reference's time law at the row, t_ref(s_i) [s] (tracks.time_law.row_times_s);
                          # C_COS, C_SIN: cos and sin of the row's heading (tracks.kernels.trig_columns), read by the
                          # projection and the row interpolation instead of computed (the same bits)

# Track metadata columns and per-car scalar columns.
TM_START, TM_N, TM_DS, TM_LEN, TM_CLOSED, TM_HALF_WIDTH, TM_PROFILE, TM_RELEASE_S, TM_RELEASE_HOLD = range(9)
TM_LAP_T = 9  # the reference's time to drive the whole table (one lap of a closed path) [s]
N_TM = 10   # TM_RELEASE_S: station [m] from which the PD-FLC is off (+inf: never); TM_RELEASE_HOLD: 1 = the
            # throttle stays at its last value there, 0 = throttle 0 (coast); the brake is 0 either way
CAR_S_PREV, CAR_PROGRESS, CAR_V_REF, CAR_PREV_ACTION, CAR_REWARD, CAR_MIN_FZ, CAR_FOLLOW, CAR_SCHEDULED = range(8)
CAR_DEMAND, CAR_S0, CAR_T0, CAR_STEPS, CAR_INV_VSET = range(8, 13)
N_CAR = 13  # CAR_DEMAND: the longitudinal demand in [-1, 1] of the longitudinal control modes; CAR_S0, CAR_T0: the
            # station [m] at reset and t_ref there [s]; CAR_STEPS: control steps since reset; CAR_INV_VSET: 1 / the
            # held set speed [s/m] of a car holding a per-episode set speed the table does not hold (0: the table's
            # time law; see ``reference_time``)
            # CAR_FOLLOW: 1 = the car follows its track's speed profile (CAR_V_REF updated from it every step);
            # CAR_SCHEDULED: 1 = this step's steering command changes within the period (SimArrays.cmds)


@dataclass(frozen=True)
class StepConstants:
    """The step's own constants (first part of ``cfg``; ``CFG_*`` offsets follow this field order)."""

    physics_dt_s: float
    n_substeps: int
    end_margin_m: float          # open paths: completed this far before the end [m]
    kink_aligned: bool           # PD-FLC surface interpolated along the Mamdani kinks
    max_steer_rad: float         # road-wheel angle of action 1 [rad]
    steering_ratio: float        # hand-wheel / road-wheel angle
    off_road_margin_m: float     # off_road once e_y passes a half width by more than this [m] (the criterion's)
    control_mode: int            # envs.control.MODE_CODES: 0 steer (PD-FLC), 1 steer_accel, 2 steer_rate_accel
    max_pedal_force_n: float     # brake pedal force of demand -1 [N]
    control_period_s: float      # [s]: time since reset = steps x this

    @classmethod
    def of(cls, scenario: Scenario, config: EnvConfig) -> StepConstants:
        """The constants of an env with this scenario and config."""
        return cls(config.physics_dt_s, config.n_substeps, scenario.track.end_margin_m,
                   config.speed_controller.method == "mamdani", config.vehicle.steering.max_road_wheel_angle_rad,
                   config.vehicle.steering.steering_ratio, scenario.success.off_road_margin_m(config.vehicle),
                   MODE_CODES[config.control], config.vehicle.brakes.max_pedal_force_n, config.control_period_s)


def _offsets(cls: type, start: int) -> dict[str, int]:
    """Field name -> position in ``cfg`` of a dataclass packed from ``start``."""
    return {f.name: start + k for k, f in enumerate(fields(cls))}


_STEP = _offsets(StepConstants, 0)
_LAYOUT = _offsets(ObservationLayout, len(_STEP))
CFG_REWARD = len(_STEP) + len(_LAYOUT)   # the RewardConfig fields start here (RW_* are relative to it)
_REWARD = _offsets(RewardConfig, 0)
N_RW = len(_REWARD)
N_CFG = CFG_REWARD + N_RW
CFG_DT = _STEP["physics_dt_s"]
CFG_NSUB = _STEP["n_substeps"]
CFG_END_MARGIN = _STEP["end_margin_m"]
CFG_KINKS = _STEP["kink_aligned"]
CFG_STEER_MAX = _STEP["max_steer_rad"]
CFG_STEER_RATIO = _STEP["steering_ratio"]
CFG_OFF_ROAD = _STEP["off_road_margin_m"]
CFG_CONTROL = _STEP["control_mode"]
CFG_PEDAL_MAX = _STEP["max_pedal_force_n"]
CFG_PERIOD = _STEP["control_period_s"]
CFG_NPREV = _LAYOUT["n_preview"]
CFG_PREV_DT = _LAYOUT["preview_dt_s"]
CFG_PREV_VMIN = _LAYOUT["preview_min_speed_mps"]
CFG_NSPEED = _LAYOUT["n_speed_preview"]
CFG_SPEED_DT = _LAYOUT["speed_preview_dt_s"]
CFG_TRACKING = _LAYOUT["tracking_errors"]
RW_ALIVE = _REWARD["alive"]
RW_WEY = _REWARD["w_ey"]
RW_EYSCALE = _REWARD["ey_scale_m"]
RW_WEPHI = _REWARD["w_ephi"]
RW_EPHISCALE = _REWARD["ephi_scale_rad"]
RW_WEFFORT = _REWARD["w_effort"]
RW_WRATE = _REWARD["w_rate"]
RW_RATESCALE = _REWARD["rate_scale"]
RW_FAIL = _REWARD["failure_penalty"]
RW_COMPLETE = _REWARD["completion_bonus"]
RW_WSPEED = _REWARD["w_speed"]
RW_SPEEDSCALE = _REWARD["speed_scale_mps"]


def pack_cfg(step: StepConstants, layout: ObservationLayout, reward: RewardConfig) -> np.ndarray:
    """The ``cfg`` vector (float64, ``N_CFG``) of these settings."""
    cfg = np.array([*astuple(step), *astuple(layout), *astuple(reward)], dtype=np.float64)
    assert cfg.shape == (N_CFG,)
    return cfg


class SimArrays(NamedTuple):
    """Every array of one batch of cars that the compiled step reads or writes (shapes for n cars)."""

    states: np.ndarray       # (n, N_STATE) plant state (vehicle.layout S_*)
    inputs: np.ndarray       # (n, N_INPUT) steering command [rad], throttle [0..1], brake [N]
    road: np.ndarray         # (n, N_ROAD) grade [rad], road vertical acceleration [m/s^2]
    params: np.ndarray       # (n, N_PARAM) packed vehicle parameters
    models: np.ndarray       # (n,) int64 model id
    outputs: np.ndarray      # (n, n_sub, N_OUTPUT) accelerations and wheel loads per physics step
    work: np.ndarray         # (n, WORKSPACE_SIZE) plant scratch
    tables: np.ndarray       # (M, N_ENV_COLS) concatenated track tables (path columns, C_V2, C_WL, C_WR, C_T)
    tmeta: np.ndarray        # (K, N_TM) track metadata (TM_*)
    veh_track: np.ndarray    # (n,) int64 track of each car
    car: np.ndarray          # (n, N_CAR) per-car scalars (CAR_*)
    cfg: np.ndarray          # (N_CFG,) constant settings (CFG_*, RW_*)
    obs: np.ndarray          # (n, layout.size) float32 observations
    err: np.ndarray          # (n, ERR_COLS) projection: s*, e_y, e_phi, kappa, s_dot, z, width l/r, e_v, e_t (E_*)
    term: np.ndarray         # (n,) int64 termination code (T_*)
    actions: np.ndarray      # (n,) normalised steering actions of this step
    sig: np.ndarray          # (n, len(SIGNAL_ROW)) info signals and reward terms (SIG_*)
    pd_mem: np.ndarray       # (n, 3) PD-FLC memory
    pd_gains: np.ndarray     # (n, 7) PD-FLC gains per car
    pd_surface: np.ndarray   # (r, r) PD-FLC control surface (shared)
    cmds: np.ndarray         # (n, n_sub) steering command [rad] per physics step (read when CAR_SCHEDULED is 1)
    scratch: np.ndarray      # (n, N_SCRATCH) per-car scratch of the curvature preview


N_SCRATCH = 2 * PREVIEW_BLOCK   # per-car scratch floats (SimArrays.scratch; tracks.kernels.curvature_preview)

# Termination codes (names in ``TERMINATION_NAMES`` of envs.sim).
T_NONE, T_COMPLETED, T_OFF_ROAD, T_SPIN_OUT, T_WHEEL_LIFT, T_INVALID = range(6)

SPIN_HEADING_RAD = 0.5 * math.pi   # |e_phi| beyond this: spun out / driving the wrong way
SPIN_SIDESLIP_RAD = 0.3            # |atan(v_y / v_x)| beyond this above 3 m/s, with the rear axle's sideslip
                                   # |atan((v_y - a2 r) / v_x)| beyond it too: spun out (a car rolling round a
                                   # 6 m radius has a CG sideslip of atan(a2 / R) = 0.31 rad without any sliding)
SIDESLIP_SCREEN = 0.3               # tan of an angle below SPIN_SIDESLIP_RAD: |v_y| / v_x under it is no spin
ERR_COLS = 10                      # s*, e_y, e_phi, kappa, s_dot, z, half width left, right at the projection,
E_S, E_EY, E_EPHI, E_KAPPA, E_SDOT, E_Z, E_WL, E_WR, E_EV, E_ET = range(ERR_COLS)  # speed and time error

# Signal-row columns (envs.schema.SIGNAL_ROW), derived by name.
N_SIG = len(SIGNAL_ROW)
SIG_X, SIG_Y, SIG_Z, SIG_PSI = (SIGNAL_ROW.index(n) for n in ("x_m", "y_m", "z_m", "psi_rad"))
SIG_EY, SIG_EPHI, SIG_V, SIG_VY, SIG_R = (SIGNAL_ROW.index(n) for n in (
    "e_y_m", "e_phi_rad", "v_mps", "v_y_mps", "yaw_rate_radps"))
SIG_DELTA, SIG_HAND, SIG_CMD, SIG_ROLL = (SIGNAL_ROW.index(n) for n in (
    "road_wheel_angle_rad", "hand_wheel_angle_rad", "steering_command_rad", "roll_rad"))
SIG_THROTTLE, SIG_BRAKE, SIG_AX, SIG_AY, SIG_AZ, SIG_MIN_FZ = (SIGNAL_ROW.index(n) for n in (
    "throttle", "brake_n", "a_x_mps2", "a_y_mps2", "a_z_mps2", "min_fz_n"))
SIG_STATION, SIG_PROGRESS, SIG_V_REF = (SIGNAL_ROW.index(n) for n in ("station_m", "progress_m", "target_speed_mps"))
SIG_EV, SIG_ET = (SIGNAL_ROW.index(n) for n in ("speed_error_mps", "time_error_s"))
SIG_REWARD = SIGNAL_ROW.index(REWARD_TERMS[0])   # the reward terms follow in REWARD_TERMS order
N_TERMS = len(REWARD_TERMS)

# The curvature preview follows the scalar fields (envs.observation).
O_PREVIEW = N_SCALARS
SCALAR_BOX = np.array([SCALAR_BOUNDS[name] for name in SCALAR_FIELDS], dtype=np.float64)
EV_BOUND, ET_BOUND = (f.bound for f in TRACKING_ERRORS)   # the tracking-error fields' box (saturated there)
"""Each scalar field's bound, in field order: ``write_scalar_fields`` saturates the field there (the box the
observation space promises)."""


@kernel(inline=True)
def write_scalar_fields(obs_row: np.ndarray, e_y: float, e_phi: float, v_x: float, v_y: float, yaw_rate: float,
                        road_wheel_angle: float, target_speed: float, kappa: float, dkappa: float, s_dot: float,
                        a_x: float) -> None:
    """Compute and write the scalar fields of one observation row from the car's errors e_y [m], e_phi [rad],
    body speeds [m/s], yaw rate [rad/s], road-wheel angle [rad], target speed [m/s], the path's curvature [1/m] and
    its rate [1/m^2] at the projection, the projection's speed s_dot [m/s] and the longitudinal acceleration a_x
    [m/s^2].

    The one writer of the scalar fields, used by the env step and by the highway-env adapter: one entry per row of
    ``envs.observation.SCALARS``, in its order (``tests/test_observation_fields.py`` checks each against its
    formula); the curvature preview follows at ``O_PREVIEW``. Each value is saturated at its field's bound
    (``SCALAR_BOX``), so the row stays inside the observation box (e.g. ``yaw_acc_ref`` on a path whose curvature
    rate is high at speed); NaN is left as it is.
    """
    yaw_rate_ref = kappa * s_dot
    values = (
        e_y,                                                     # e_y
        e_phi,                                                   # e_phi
        v_x * math.sin(e_phi) + v_y * math.cos(e_phi),           # e_y_dot
        yaw_rate - yaw_rate_ref,                                 # e_phi_dot
        v_x,                                                     # v_x
        v_y,                                                     # v_y
        yaw_rate,                                                # yaw_rate
        road_wheel_angle,                                        # road_wheel_angle
        target_speed,                                            # target_speed
        yaw_rate_ref,                                            # yaw_rate_ref
        dkappa * s_dot * s_dot + kappa * a_x,                    # yaw_acc_ref
        kappa,                                                   # curvature
        dkappa,                                                  # curvature_rate
    )
    for j in range(N_SCALARS):
        bound = SCALAR_BOX[j]
        v = values[j]
        obs_row[j] = -bound if v < -bound else (bound if v > bound else v)


@kernel(inline=True)
def observe_one(i: int, a: SimArrays, a_x: float, window_m: float, first: bool) -> None:
    """Project car ``i`` on its path and write its observation row, road inputs and error row."""
    state, car, cfg = a.states[i], a.car, a.cfg
    k = a.veh_track[i]
    start = int(a.tmeta[k, TM_START])
    table = a.tables[start:start + int(a.tmeta[k, TM_N])]
    ds = a.tmeta[k, TM_DS]
    length = a.tmeta[k, TM_LEN]
    closed = a.tmeta[k, TM_CLOSED] != 0.0
    n_preview = int(cfg[CFG_NPREV])
    preview_dt = cfg[CFG_PREV_DT]
    preview_vmin = cfg[CFG_PREV_VMIN]
    x = state[L.S_X]
    y = state[L.S_Y]
    psi = state[L.S_PSI]
    vx = state[L.S_VX]
    vy = state[L.S_VY]
    r = state[L.S_R]

    follow = a.tmeta[k, TM_PROFILE] != 0.0 and car[i, CAR_FOLLOW] != 0.0
    s_guess = -1.0 if first else car[i, CAR_S_PREV]
    s, j, t, x_r, y_r, psi_r, kappa, cos_r, sin_r = projection_row(table, ds, length, closed, x, y, s_guess,
                                                                   window_m, C_COS)
    if first:
        car[i, CAR_PROGRESS] = 0.0
        car[i, CAR_STEPS] = 0.0
        car[i, CAR_S0] = s
        car[i, CAR_T0] = reference_time(table, ds, length, closed, a.tmeta[k, TM_LAP_T], s)
    else:
        step_s = s - car[i, CAR_S_PREV]
        if closed:
            if step_s > 0.5 * length:
                step_s -= length
            elif step_s < -0.5 * length:
                step_s += length
        car[i, CAR_PROGRESS] += step_s
    car[i, CAR_S_PREV] = s

    # the rest of the path's row at s (tracks.kernels.interp_row's formulas)
    dkappa, z_r, grade, zpp = height_columns(table, j, t, ds)
    w_left = lerp_column(table, j, t, C_WL)
    w_right = lerp_column(table, j, t, C_WR)
    if follow:
        car[i, CAR_V_REF] = math.sqrt(lerp_column(table, j, t, C_V2))
    e_y = lateral_offset_cs(x, y, x_r, y_r, cos_r, sin_r)
    e_phi = _wrap(psi - psi_r)
    sin_e = math.sin(e_phi)
    cos_e = math.cos(e_phi)
    denom = 1.0 - kappa * e_y
    if denom < 0.1:
        denom = 0.1
    s_dot = (vx * cos_e - vy * sin_e) / denom

    obs = a.obs
    write_scalar_fields(obs[i], e_y, e_phi, vx, vy, r, state[L.S_DELTA], car[i, CAR_V_REF], kappa, dkappa, s_dot,
                        a_x)
    v_prev = vx if vx > preview_vmin else preview_vmin
    # the curvature alone (nothing computed and thrown away), located in vectorised blocks
    curvature_preview(table, ds, length, closed, s, v_prev, preview_dt, obs[i, O_PREVIEW:O_PREVIEW + n_preview],
                      a.scratch[i])
    o_speed = O_PREVIEW + n_preview
    speed_dt = cfg[CFG_SPEED_DT]
    for j in range(int(cfg[CFG_NSPEED])):
        if follow:
            obs[i, o_speed + j] = math.sqrt(_linear(table, ds, length, closed, s + v_prev * (j + 1) * speed_dt, C_V2))
        else:
            obs[i, o_speed + j] = car[i, CAR_V_REF]
    e_v = vx - car[i, CAR_V_REF]
    e_t = time_error(i, a, table, ds, length, closed)
    if cfg[CFG_TRACKING] != 0.0:   # the longitudinal modes' fields, at the very end (saturated at their bounds)
        o_track = o_speed + int(cfg[CFG_NSPEED])
        obs[i, o_track] = -EV_BOUND if e_v < -EV_BOUND else (EV_BOUND if e_v > EV_BOUND else e_v)
        obs[i, o_track + 1] = -ET_BOUND if e_t < -ET_BOUND else (ET_BOUND if e_t > ET_BOUND else e_t)

    # Road inputs for the next control period: grade and vertical acceleration v^2 z''(s) at the projection.
    a.road[i, L.R_GRADE] = math.atan(grade)
    a.road[i, L.R_AZ] = vx * vx * zpp

    err = a.err
    err[i, E_S] = s
    err[i, E_EY] = e_y
    err[i, E_EPHI] = e_phi
    err[i, E_KAPPA] = kappa
    err[i, E_SDOT] = s_dot
    err[i, E_Z] = z_r
    err[i, E_WL] = w_left
    err[i, E_WR] = w_right
    err[i, E_EV] = e_v
    err[i, E_ET] = e_t


@kernel(inline=True)
def reference_time(table: np.ndarray, ds: float, length: float, closed: bool, lap_s: float, s: float) -> float:
    """The reference's time law t_ref(s) [s] at station ``s`` [m] from the table's ``C_T`` and ``C_V2`` columns:
    ``tracks.time_law.TimeLaw.time_at`` (exact for v^2 linear between rows; laps counted on a closed path, s
    clamped to [0, L] on an open one)."""
    if closed:
        laps = math.floor(s / length)
        s_in = s - laps * length
    else:
        laps = 0.0
        s_in = min(max(s, 0.0), length)
    j = min(max(int(s_in / ds), 0), table.shape[0] - 2)   # s_in >= 0: truncation is the floor
    v0sq = table[j, C_V2]
    into = s_in - j * ds
    v_s = math.sqrt(v0sq + (into / ds) * (table[j + 1, C_V2] - v0sq))
    return table[j, C_T] + 2.0 * into / (math.sqrt(v0sq) + v_s) + laps * lap_s


@kernel(inline=True)
def time_error(i: int, a: SimArrays, table: np.ndarray, ds: float, length: float, closed: bool) -> float:
    """Car ``i``'s time error e_t = t - (t_ref(s0 + progress) - t_ref(s0)) [s] (positive: behind the reference),
    t = steps x control period, s0 its station at reset; a car holding a per-episode set speed the table does not
    hold (a reset option, a randomised set speed) has t_ref(s) = s / v_set (``CAR_INV_VSET``)."""
    car = a.car
    t = car[i, CAR_STEPS] * a.cfg[CFG_PERIOD]
    inv = car[i, CAR_INV_VSET]
    if inv > 0.0:
        return t - car[i, CAR_PROGRESS] * inv
    k = a.veh_track[i]
    lap_s = a.tmeta[k, TM_LAP_T]
    return t - (reference_time(table, ds, length, closed, lap_s, car[i, CAR_S0] + car[i, CAR_PROGRESS])
                - car[i, CAR_T0])


@kernel(inline=True)
def termination_one(i: int, a: SimArrays) -> int:
    """Termination code of car ``i`` after a step (``T_NONE`` if it goes on); stores its min wheel load."""
    state, outputs, err, car, tmeta = a.states[i], a.outputs[i], a.err, a.car, a.tmeta
    for j in range(state.shape[0]):
        if not math.isfinite(state[j]):
            return T_INVALID
    min_fz = math.inf
    for j in range(outputs.shape[0]):
        for w in range(L.O_FZFL, L.O_FZRR + 1):
            if outputs[j, w] < min_fz:
                min_fz = outputs[j, w]
    car[i, CAR_MIN_FZ] = min_fz
    if min_fz <= 0.0:
        return T_WHEEL_LIFT
    k = a.veh_track[i]
    vx = state[L.S_VX]
    if abs(err[i, E_EPHI]) > SPIN_HEADING_RAD:
        return T_SPIN_OUT
    # |v_y| <= 0.3 v_x gives |atan2(v_y, v_x)| <= atan(0.3) = 0.29 < SPIN_SIDESLIP_RAD: no atan2 needed (the same
    # verdict, the usual case)
    if vx > 3.0 and abs(state[L.S_VY]) > SIDESLIP_SCREEN * vx and \
            abs(math.atan2(state[L.S_VY], vx)) > SPIN_SIDESLIP_RAD and \
            abs(math.atan2(state[L.S_VY] - a.params[i, L.P_A2] * state[L.S_R], vx)) > SPIN_SIDESLIP_RAD:
        return T_SPIN_OUT
    margin = a.cfg[CFG_OFF_ROAD]
    if err[i, E_EY] > err[i, E_WL] + margin or -err[i, E_EY] > err[i, E_WR] + margin:  # per-station, each side
        return T_OFF_ROAD
    if tmeta[k, TM_CLOSED] != 0.0:
        if car[i, CAR_PROGRESS] >= tmeta[k, TM_LEN]:
            return T_COMPLETED
    elif err[i, E_S] >= tmeta[k, TM_LEN] - a.cfg[CFG_END_MARGIN]:
        return T_COMPLETED
    return T_NONE


@kernel(inline=True)
def reward_one(code: int, e_y: float, e_phi: float, action: float, prev_action: float, rw: np.ndarray,
               terms: np.ndarray, longitudinal: bool, e_v: float) -> float:
    """Reward of one car for one step; its seven terms (``REWARD_TERMS`` order) go to ``terms``. The speed term
    (``longitudinal`` control modes only) is 0 and not added in the steer mode, whose sum stays the six terms'."""
    # Bounded, cusped penalties q = |x| / (|x| + scale) in [0, 1): a slope at every error (centimetres count, and
    # so do metres), and every step's reward stays >= alive - w_ey - w_ephi - w_effort - w_rate.
    ey, ephi = abs(e_y), abs(e_phi)
    terms[0] = rw[RW_ALIVE]
    terms[1] = -rw[RW_WEY] * ey / (ey + rw[RW_EYSCALE])
    terms[2] = -rw[RW_WEPHI] * ephi / (ephi + rw[RW_EPHISCALE])
    terms[3] = -rw[RW_WEFFORT] * action * action
    da = (action - prev_action) / rw[RW_RATESCALE]
    da2 = da * da
    terms[4] = -rw[RW_WRATE] * (da2 if da2 < 1.0 else 1.0)
    if code == T_COMPLETED:
        terms[5] = rw[RW_COMPLETE]
    elif code != T_NONE:
        terms[5] = rw[RW_FAIL]
    else:
        terms[5] = 0.0
    total = terms[0] + terms[1] + terms[2] + terms[3] + terms[4] + terms[5]
    if not longitudinal:
        terms[6] = 0.0
        return total
    ev = abs(e_v)
    terms[6] = -rw[RW_WSPEED] * ev / (ev + rw[RW_SPEEDSCALE])
    return total + terms[6]


@kernel(inline=True)
def write_signals(i: int, a: SimArrays) -> None:
    """Car ``i``'s row of ``info`` signals (``envs.schema.ROW_SIGNALS``; the reward terms are written apart)."""
    st, sig, car = a.states[i], a.sig[i], a.car
    last = a.outputs[i, a.outputs.shape[1] - 1]
    sig[SIG_X] = st[L.S_X]
    sig[SIG_Y] = st[L.S_Y]
    sig[SIG_Z] = a.err[i, E_Z]
    sig[SIG_PSI] = st[L.S_PSI]
    sig[SIG_EY] = a.err[i, E_EY]
    sig[SIG_EPHI] = a.err[i, E_EPHI]
    sig[SIG_V] = st[L.S_VX]
    sig[SIG_VY] = st[L.S_VY]
    sig[SIG_R] = st[L.S_R]
    sig[SIG_DELTA] = st[L.S_DELTA]
    sig[SIG_HAND] = st[L.S_DELTA] * a.cfg[CFG_STEER_RATIO]
    sig[SIG_CMD] = a.inputs[i, L.U_DELTA]
    sig[SIG_ROLL] = st[L.S_ROLL]
    sig[SIG_THROTTLE] = a.inputs[i, L.U_THROTTLE]
    sig[SIG_BRAKE] = a.inputs[i, L.U_BRAKE]
    sig[SIG_AX] = last[L.O_AX]
    sig[SIG_AY] = last[L.O_AY]
    sig[SIG_AZ] = last[L.O_AZ]
    sig[SIG_MIN_FZ] = car[i, CAR_MIN_FZ]
    sig[SIG_STATION] = a.err[i, E_S]
    sig[SIG_PROGRESS] = car[i, CAR_PROGRESS]
    sig[SIG_V_REF] = car[i, CAR_V_REF]
    sig[SIG_EV] = a.err[i, E_EV]
    sig[SIG_ET] = a.err[i, E_ET]


@kernel(refcount=False)
def is_released(i: int, a: SimArrays) -> bool:
    """Whether car ``i`` has passed its track's release station (the speed loop is off there)."""
    return a.car[i, CAR_S_PREV] >= a.tmeta[a.veh_track[i], TM_RELEASE_S]


@kernel(refcount=False)
def set_pedals(i: int, a: SimArrays) -> None:
    """Throttle and brake of car ``i`` for this period: the longitudinal demand, the release rule or the PD-FLC."""
    cfg, car, inputs = a.cfg, a.car, a.inputs
    if cfg[CFG_CONTROL] != 0.0:
        demand = car[i, CAR_DEMAND]
        if demand >= 0.0:
            inputs[i, L.U_THROTTLE] = demand
            inputs[i, L.U_BRAKE] = 0.0
        else:
            inputs[i, L.U_THROTTLE] = 0.0
            inputs[i, L.U_BRAKE] = -demand * cfg[CFG_PEDAL_MAX]
    elif is_released(i, a):
        if a.tmeta[a.veh_track[i], TM_RELEASE_HOLD] == 0.0:
            inputs[i, L.U_THROTTLE] = 0.0
        inputs[i, L.U_BRAKE] = 0.0
    else:
        throttle, brake = pdflc_step(a.states[i, L.S_VX], car[i, CAR_V_REF], a.pd_mem[i], a.pd_gains[i],
                                     a.pd_surface, cfg[CFG_KINKS] != 0.0)
        inputs[i, L.U_THROTTLE] = throttle
        inputs[i, L.U_BRAKE] = brake


@kernel(refcount=False)
def step_car(i: int, a: SimArrays) -> None:
    """One control period of car ``i``: speed loop, physics, projection, observation, termination, reward."""
    cfg, car, states, inputs, outputs = a.cfg, a.car, a.states, a.inputs, a.outputs
    dt = cfg[CFG_DT]
    n_sub = int(cfg[CFG_NSUB])
    released = is_released(i, a)   # never on a track whose release station is +inf
    longitudinal = cfg[CFG_CONTROL] != 0.0
    set_pedals(i, a)
    if car[i, CAR_SCHEDULED] != 0.0:  # a late command takes over within the period (envs.latency)
        for j in range(n_sub):
            inputs[i, L.U_DELTA] = a.cmds[i, j]
            step_vehicle(states[i], inputs[i], a.road[i], a.params[i], a.models[i], dt, 1, outputs[i, j:j + 1],
                         a.work[i])
    else:
        step_vehicle(states[i], inputs[i], a.road[i], a.params[i], a.models[i], dt, n_sub, outputs[i], a.work[i])
    if released:  # no set point: the target speed shown is the car's own speed
        car[i, CAR_V_REF] = states[i, L.S_VX]
    car[i, CAR_STEPS] += 1.0
    travel = abs(states[i, L.S_VX]) * dt * n_sub
    window = 5.0 + 3.0 * travel
    a_x = outputs[i, n_sub - 1, L.O_AX]
    observe_one(i, a, a_x, window, False)
    code = termination_one(i, a)
    a.term[i] = code
    action = a.actions[i]
    car[i, CAR_REWARD] = reward_one(code, a.err[i, E_EY], a.err[i, E_EPHI], action, car[i, CAR_PREV_ACTION],
                                    cfg[CFG_REWARD:CFG_REWARD + N_RW], a.sig[i, SIG_REWARD:SIG_REWARD + N_TERMS],
                                    longitudinal, a.err[i, E_EV])
    car[i, CAR_PREV_ACTION] = action
    write_signals(i, a)


@kernel(refcount=False)
def step_serial(a: SimArrays) -> None:
    """One control period for every car, single-threaded."""
    for i in range(a.states.shape[0]):
        step_car(i, a)


@kernel(parallel=True, refcount=False)
def step_parallel(a: SimArrays) -> None:
    """One control period for every car, cars spread over threads (same per-car code)."""
    for i in prange(a.states.shape[0]):
        step_car(i, a)


@kernel(refcount=False)
def observe_indices(idx: np.ndarray, a: SimArrays) -> None:
    """Fresh observation (global projection search, progress reset) and signal row (reward terms 0) for the
    cars in ``idx`` (a_x = 0)."""
    for i in idx:
        observe_one(i, a, 0.0, 0.0, True)
        a.sig[i, SIG_REWARD:SIG_REWARD + N_TERMS] = 0.0
        write_signals(i, a)
