"""The paper's linear single-track design model (eq. 5, paper-math section 2.2) and its analytic steady states.

State (v_y [m/s], r [rad/s]), input delta [rad], v_x [m/s] a parameter:

    v_y' = -(C_af + C_ar)/(m v_x) v_y + [(-a1 C_af + a2 C_ar)/(m v_x) - v_x] r + C_af/m delta
    r'   = (-a1 C_af + a2 C_ar)/(I_z v_x) v_y - (a1^2 C_af + a2^2 C_ar)/(I_z v_x) r + a1 C_af/I_z delta
"""

from __future__ import annotations

import numpy as np

from vtrack_gym.vehicle.params import DesignModel


def lateral_matrices(design: DesignModel, v_x: float) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of eq. (5)'s lateral/yaw rows at speed ``v_x`` [m/s] (> 0)."""
    if not v_x > 0.0:
        raise ValueError(f"v_x must be > 0 m/s for the linear model (got {v_x})")
    m, iz = design.mass_kg, design.yaw_inertia_kgm2
    a1, a2 = design.cg_to_front_axle_m, design.cg_to_rear_axle_m
    cf, cr = design.front_cornering_stiffness_npr, design.rear_cornering_stiffness_npr
    a = np.array([
        [-(cf + cr) / (m * v_x), (-a1 * cf + a2 * cr) / (m * v_x) - v_x],
        [(-a1 * cf + a2 * cr) / (iz * v_x), -(a1**2 * cf + a2**2 * cr) / (iz * v_x)],
    ])
    b = np.array([cf / m, a1 * cf / iz])
    return a, b


def understeer_gradient(design: DesignModel) -> float:
    """K_us = m (a2 C_ar - a1 C_af) / (l C_af C_ar) [rad/(m/s^2)]."""
    cf, cr = design.front_cornering_stiffness_npr, design.rear_cornering_stiffness_npr
    return design.mass_kg * (design.cg_to_rear_axle_m * cr - design.cg_to_front_axle_m * cf) / (
        design.wheelbase_m * cf * cr)


def steady_state_steer(design: DesignModel, v_x: float, curvature: float) -> float:
    """Steady-state road-wheel angle delta_ss = kappa (l + K_us v^2) [rad] on curvature ``kappa`` [1/m]."""
    return curvature * (design.wheelbase_m + understeer_gradient(design) * v_x**2)


def sideslip_gain(design: DesignModel, v_x: float) -> float:
    """beta_ss / kappa = (C_ar a2 l - m a1 v^2) / (C_ar l) [m]: steady sideslip per unit curvature."""
    cr, l = design.rear_cornering_stiffness_npr, design.wheelbase_m
    return (cr * design.cg_to_rear_axle_m * l - design.mass_kg * design.cg_to_front_axle_m * v_x * v_x) / (cr * l)


def steady_state_sideslip(design: DesignModel, v_x: float, curvature: float) -> float:
    """Steady-state sideslip beta_ss = v_y / v_x = kappa (C_ar a2 l - m a1 v^2) / (C_ar l) [rad]."""
    return curvature * sideslip_gain(design, v_x)


def steady_state_response(design: DesignModel, v_x: float, delta: float) -> tuple[float, float]:
    """Steady (v_y [m/s], r [rad/s]) for a constant road-wheel angle ``delta`` [rad]: -A^-1 B delta."""
    a, b = lateral_matrices(design, v_x)
    vy, r = -np.linalg.solve(a, b * delta)
    return float(vy), float(r)
