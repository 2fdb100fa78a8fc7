"""Index layouts of the plant's state, input, road and parameter arrays (no numba, cheap to import).

State row of one vehicle (float64, ``N_STATE`` entries):

=====  ==========  =======  ===================================================================
index  name        unit     meaning
=====  ==========  =======  ===================================================================
0      x           m        global X of the CG
1      y           m        global Y of the CG
2      psi         rad      yaw angle, counter-clockwise from +X (unwrapped)
3      v_x         m/s      longitudinal body-frame speed
4      v_y         m/s      lateral body-frame speed, left-positive
5      r           rad/s    yaw rate
6      roll        rad      sprung-mass roll angle, positive = right side down (left turn)
7      roll_rate   rad/s    roll rate
8      delta       rad      front road-wheel angle (steering actuator output), left-positive
9      a_x_lag     m/s^2    a_x through the load-transfer lag (used for longitudinal load transfer)
10     a_y_lag     m/s^2    a_y through the load-transfer lag (roll-centre part of lateral transfer)
11     alpha_f_lag rad      front slip angle through the tyre relaxation lag (0 and unused when it is off)
12     alpha_r_lag rad      rear slip angle through the tyre relaxation lag (0 and unused when it is off)
=====  ==========  =======  ===================================================================

Per-vehicle inputs (held constant over one control period): ``delta_cmd`` [rad], ``throttle`` [0..1],
``brake`` [N pedal force]. Per-vehicle road inputs (sampled once per control period at the vehicle's
projection): ``grade`` [rad, positive uphill], ``a_z_road`` [m/s^2] (= v^2 d2z/ds2, the vertical acceleration
imposed by the road's vertical curvature).
"""

from __future__ import annotations

STATE_NAMES: tuple[str, ...] = (
    "x", "y", "psi", "v_x", "v_y", "r", "roll", "roll_rate", "delta", "a_x_lag", "a_y_lag", "alpha_f_lag",
    "alpha_r_lag",
)
S_X, S_Y, S_PSI, S_VX, S_VY, S_R, S_ROLL, S_ROLL_RATE, S_DELTA, S_AXL, S_AYL, S_ALF, S_ALR = range(13)
N_STATE = len(STATE_NAMES)

INPUT_NAMES: tuple[str, ...] = ("delta_cmd", "throttle", "brake")
U_DELTA, U_THROTTLE, U_BRAKE = range(3)
N_INPUT = len(INPUT_NAMES)

ROAD_NAMES: tuple[str, ...] = ("grade", "a_z_road")
R_GRADE, R_AZ = range(2)
N_ROAD = len(ROAD_NAMES)

# Per-substep outputs recorded by the kernel (at the start of every physics step).
OUTPUT_NAMES: tuple[str, ...] = ("a_x", "a_y", "a_z", "fz_fl", "fz_fr", "fz_rl", "fz_rr")
O_AX, O_AY, O_AZ, O_FZFL, O_FZFR, O_FZRL, O_FZRR = range(7)
N_OUTPUT = len(OUTPUT_NAMES)

MODEL_NONLINEAR = 0
MODEL_LINEAR = 1
MODEL_IDS: dict[str, int] = {"nonlinear": MODEL_NONLINEAR, "linear": MODEL_LINEAR}

# Packed parameter vector (derived quantities the kernel needs, one row per vehicle). ``h_cg`` is the whole car's
# CG height; ``h_s`` the sprung CG above the roll axis; ``lt_direct_f/r`` [kg m] the lateral load-transfer moment
# per unit a_y that bypasses the roll springs on each axle: m_s,axle h_rc + m_u,axle h_u.
PARAM_NAMES: tuple[str, ...] = (
    "m", "iz", "a1", "a2", "l", "h_cg", "track", "m_s", "h_s", "h_rc", "i_roll", "k_roll", "c_roll",
    "roll_share_f", "c_f", "c_r", "mu", "b0_f", "b0_r", "shape_c_f", "shape_c_r", "peak_d_f", "peak_d_r",
    "load_sens", "f_roll", "delta_max", "delta_rate_max", "tau_steer", "p_max", "f_drive_max",
    "drive_share_f", "drag_k", "brake_gain", "pedal_max", "brake_share_f", "v_blend_lo", "v_blend_hi",
    "tau_kin", "tau_lt", "lt_direct_f", "lt_direct_r", "relax_len",
)
(P_M, P_IZ, P_A1, P_A2, P_L, P_HCG, P_TRACK, P_MS, P_HS, P_HRC, P_IROLL, P_KROLL, P_CROLL,
 P_ROLL_SHARE_F, P_CF, P_CR, P_MU, P_B0F, P_B0R, P_SHAPE_CF, P_SHAPE_CR, P_PEAK_DF, P_PEAK_DR,
 P_LOAD_SENS, P_FROLL, P_DELTA_MAX, P_DELTA_RATE, P_TAU_STEER, P_PMAX, P_FDRIVE_MAX,
 P_DRIVE_SHARE_F, P_DRAG_K, P_BRAKE_GAIN, P_PEDAL_MAX, P_BRAKE_SHARE_F, P_VBLEND_LO, P_VBLEND_HI,
 P_TAU_KIN, P_TAU_LT, P_LT_DIRECT_F, P_LT_DIRECT_R, P_RELAX) = range(len(PARAM_NAMES))
N_PARAM = len(PARAM_NAMES)
