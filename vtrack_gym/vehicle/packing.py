"""Pack ``VehicleParams`` into the flat float64 rows the compiled plant kernel reads."""

from __future__ import annotations

import numpy as np

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams


def static_wheel_loads_n(params: VehicleParams) -> tuple[float, float]:
    """Static load of ONE front and ONE rear wheel on flat ground [N]."""
    c = params.chassis
    weight = c.mass_kg * GRAVITY_MPS2
    return 0.5 * weight * c.cg_to_rear_axle_m / c.wheelbase_m, 0.5 * weight * c.cg_to_front_axle_m / c.wheelbase_m


def pack_params(params: VehicleParams) -> np.ndarray:
    """Return the kernel's parameter row (shape ``(N_PARAM,)``) for one vehicle.

    The Pacejka stiffness factor B of each wheel is chosen so that, at the static wheel load, the wheel's
    cornering stiffness is half the paper's axle value *independently of mu*: B0 = (C_axle / 2) /
    (C * D * mu * F_z0). Friction changes the peak force, not the small-slip slope.
    """
    c, t, r, s, p, b, lo = (params.chassis, params.tyres, params.roll, params.steering, params.powertrain,
                            params.brakes, params.low_speed)
    fz_f0, fz_r0 = static_wheel_loads_n(params)
    row = np.zeros(L.N_PARAM, dtype=np.float64)
    row[L.P_M] = c.mass_kg
    row[L.P_IZ] = c.yaw_inertia_kgm2
    row[L.P_A1] = c.cg_to_front_axle_m
    row[L.P_A2] = c.cg_to_rear_axle_m
    row[L.P_L] = c.wheelbase_m
    row[L.P_HCG] = params.total_cg_height_m
    row[L.P_TRACK] = c.track_width_m
    row[L.P_MS] = params.sprung_mass_kg
    row[L.P_HS] = c.cg_height_m - r.roll_centre_height_m
    row[L.P_HRC] = r.roll_centre_height_m
    row[L.P_IROLL] = r.roll_inertia_kgm2
    row[L.P_KROLL] = r.roll_stiffness_nmpr
    row[L.P_CROLL] = r.roll_damping_nmspr
    row[L.P_ROLL_SHARE_F] = r.front_roll_stiffness_share
    row[L.P_CF] = t.front_cornering_stiffness_npr
    row[L.P_CR] = t.rear_cornering_stiffness_npr
    row[L.P_MU] = t.friction_mu
    row[L.P_B0F] = 0.5 * t.front_cornering_stiffness_npr / (t.front_shape_c * t.front_peak_d * t.friction_mu * fz_f0)
    row[L.P_B0R] = 0.5 * t.rear_cornering_stiffness_npr / (t.rear_shape_c * t.rear_peak_d * t.friction_mu * fz_r0)
    row[L.P_SHAPE_CF] = t.front_shape_c
    row[L.P_SHAPE_CR] = t.rear_shape_c
    row[L.P_PEAK_DF] = t.front_peak_d
    row[L.P_PEAK_DR] = t.rear_peak_d
    row[L.P_LOAD_SENS] = t.load_sensitivity
    row[L.P_FROLL] = t.rolling_resistance_coeff
    row[L.P_DELTA_MAX] = s.max_road_wheel_angle_rad
    row[L.P_DELTA_RATE] = s.max_road_wheel_rate_radps
    row[L.P_TAU_STEER] = s.time_constant_s
    row[L.P_PMAX] = p.max_power_w
    row[L.P_FDRIVE_MAX] = p.max_drive_force_n
    row[L.P_DRIVE_SHARE_F] = p.front_drive_share
    row[L.P_DRAG_K] = 0.5 * p.air_density_kgpm3 * p.drag_area_m2
    row[L.P_BRAKE_GAIN] = b.pedal_gain
    row[L.P_PEDAL_MAX] = b.max_pedal_force_n
    row[L.P_BRAKE_SHARE_F] = b.front_brake_share
    row[L.P_VBLEND_LO] = lo.blend_start_mps
    row[L.P_VBLEND_HI] = lo.blend_end_mps
    row[L.P_TAU_KIN] = lo.relaxation_time_s
    row[L.P_TAU_LT] = lo.load_transfer_lag_s
    # Sprung mass carried by each axle (the whole car's static split minus that axle's two unsprung corners), at
    # the roll-centre height; the axle's unsprung mass at the wheel-centre height.
    (m_f, m_uf), (m_r, m_ur) = params.axle_masses_kg()
    row[L.P_LT_DIRECT_F] = (m_f - m_uf) * r.roll_centre_height_m + m_uf * r.unsprung_cg_height_m
    row[L.P_LT_DIRECT_R] = (m_r - m_ur) * r.roll_centre_height_m + m_ur * r.unsprung_cg_height_m
    row[L.P_RELAX] = t.relaxation_length_m
    return row


def pack_params_batch(params: VehicleParams | list[VehicleParams], n: int) -> np.ndarray:
    """Parameter matrix ``(n, N_PARAM)``: one shared ``VehicleParams`` or one per vehicle."""
    if isinstance(params, VehicleParams):
        return np.ascontiguousarray(np.broadcast_to(pack_params(params), (n, L.N_PARAM)).copy())
    if len(params) != n:
        raise ValueError(f"params: expected {n} VehicleParams, got {len(params)}")
    return np.ascontiguousarray(np.stack([pack_params(p) for p in params]))
