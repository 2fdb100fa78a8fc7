"""Linear design models of the paper for the model-based baselines (paper-math sections 1.2, 2.2, 3.2, 3.3, 4.2).

All models use the ``DesignModel`` (axle cornering stiffnesses C_af, C_ar [N/rad]) at a constant longitudinal
speed ``v_x`` [m/s] (> 0; controllers clamp it first). Angles in rad, lengths in m, time in s.

* ``lateral_matrices``: eq. (5) in (v_y [m/s], r [rad/s]), input delta [rad] (paper-math 2.2).
* ``error_model``: Rajamani's error model in x_e = (e_y, e_y_dot, e_phi, e_phi_dot) with inputs delta,
  psi_ref_dot [rad/s] and psi_ref_ddot [rad/s^2] (3.2).
* ``paper_model``: the corrected 8-state eq. (9), x_m = (y, v_y, phi, r, e_y, e_y_dot, e_phi, e_phi_dot),
  ``-v_x`` moved from column 5 to column 4 in rows 2 and 6 (3.3 FIX).
* ``zoh``: exact zero-order-hold discretisation through ``expm`` of the augmented matrix (4.2).
* Steady-state helpers (1.2): ``understeer_gradient``, ``steady_state_steer``, ``steady_state_sideslip``.
* ``curvature_preview_operator``: the linear map from the observation's curvature samples to curvature and its
  arc-length derivative at look-ahead distances (the disturbance preview of the MPCs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vtrack_gym.envs.observation import ObservationLayout
from vtrack_gym.vehicle.linear import (  # re-exported: one implementation of the design model
    lateral_matrices,
    sideslip_gain,
    steady_state_sideslip,
    steady_state_steer,
    understeer_gradient,
)
from vtrack_gym.vehicle.params import DesignModel

__all__ = [
    "ErrorModel", "curvature_preview_operator", "error_model", "lateral_matrices", "paper_model", "sideslip_gain",
    "steady_state_sideslip", "steady_state_steer", "understeer_gradient", "zoh",
]


def _constants(design: DesignModel) -> tuple[float, float, float, float, float, float]:
    """``(m [kg], I_z [kg m^2], a1 [m], a2 [m], C_af [N/rad], C_ar [N/rad])``."""
    return (design.mass_kg, design.yaw_inertia_kgm2, design.cg_to_front_axle_m, design.cg_to_rear_axle_m,
            design.front_cornering_stiffness_npr, design.rear_cornering_stiffness_npr)


def _check_speed(v_x: float) -> float:
    v = float(v_x)
    if not v > 0.0 or not np.isfinite(v):
        raise ValueError(f"v_x must be a finite speed > 0 m/s for the linear models (got {v_x})")
    return v


@dataclass(frozen=True)
class ErrorModel:
    """Rajamani error model ``x_e' = A x_e + B delta + E psi_ref_dot + F psi_ref_ddot`` (paper-math 3.2).

    x_e = (e_y [m], e_y_dot [m/s], e_phi [rad], e_phi_dot [rad/s]); delta [rad]; psi_ref_dot [rad/s];
    psi_ref_ddot [rad/s^2].
    """

    a: np.ndarray
    b: np.ndarray
    e: np.ndarray
    f: np.ndarray


def error_model(design: DesignModel, v_x: float) -> ErrorModel:
    """A4, B4, E4, F4 of paper-math 3.2 at ``v_x`` [m/s] (axle cornering stiffnesses)."""
    v = _check_speed(v_x)
    m, iz, a1, a2, cf, cr = _constants(design)
    h = a1 * cf - a2 * cr
    a = np.array([[0.0, 1.0, 0.0, 0.0],
                  [0.0, -(cf + cr) / (m * v), (cf + cr) / m, (-a1 * cf + a2 * cr) / (m * v)],
                  [0.0, 0.0, 0.0, 1.0],
                  [0.0, -h / (iz * v), h / iz, -(a1 * a1 * cf + a2 * a2 * cr) / (iz * v)]])
    b = np.array([0.0, cf / m, 0.0, a1 * cf / iz])
    e = np.array([0.0, (-a1 * cf + a2 * cr) / (m * v) - v, 0.0, -(a1 * a1 * cf + a2 * a2 * cr) / (iz * v)])
    f = np.array([0.0, 0.0, 0.0, -1.0])
    return ErrorModel(a, b, e, f)


def paper_model(design: DesignModel, v_x: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Corrected eq. (9): ``(A9 (8x8), B9 (8,), D9 (8,))`` at ``v_x`` [m/s] (paper-math 3.3).

    State (y [m], v_y [m/s], phi [rad], r [rad/s], e_y [m], e_y_dot [m/s], e_phi [rad], e_phi_dot [rad/s]),
    input delta [rad], disturbance d = psi_ref_ddot [rad/s^2].
    """
    v = _check_speed(v_x)
    m, iz, a1, a2, cf, cr = _constants(design)
    k11 = -(cf + cr) / (m * v)
    k12 = (-a1 * cf + a2 * cr) / (m * v)
    k21 = (-a1 * cf + a2 * cr) / (iz * v)
    k22 = -(a1 * a1 * cf + a2 * a2 * cr) / (iz * v)
    a = np.zeros((8, 8))
    a[0, 1] = 1.0
    a[1, 1], a[1, 3] = k11, k12 - v
    a[2, 3] = 1.0
    a[3, 1], a[3, 3] = k21, k22
    a[4, 5] = 1.0
    a[5, 1], a[5, 3], a[5, 7] = k11, k12 - v, v
    a[6, 7] = 1.0
    a[7, 1], a[7, 3] = k21, k22
    g1, g2 = cf / m, a1 * cf / iz
    b = np.array([0.0, g1, 0.0, g2, 0.0, g1, 0.0, g2])
    d = np.zeros(8)
    d[7] = -1.0
    return a, b, d


def zoh(a: np.ndarray, b: np.ndarray, sample_time_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order hold: ``expm([[A, B], [0, 0]] T)`` -> ``(A_d, B_d)``; ``b`` may be (n,) or (n, k)."""
    from scipy.linalg import expm

    if not sample_time_s > 0.0:
        raise ValueError(f"sample_time_s must be > 0 s (got {sample_time_s})")
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    vector = b.ndim == 1
    b2 = b.reshape(a.shape[0], -1)
    n, k = b2.shape
    big = np.zeros((n + k, n + k))
    big[:n, :n] = a
    big[:n, n:] = b2
    e = expm(big * sample_time_s)
    bd = e[:n, n:]
    return e[:n, :n], (bd[:, 0] if vector else bd)


def curvature_preview_operator(layout: ObservationLayout, v_x: float,
                               distances_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linear maps from the preview vector to kappa [1/m] and d kappa/ds [1/m^2] at look-ahead ``distances_m``.

    The preview vector is ``p = (kappa(0), kappa(d_1), ..., kappa(d_P), kappa'(0))``: the observation's
    ``curvature``, its ``P`` preview samples at ``d_k = max(v_x, preview_min_speed) k preview_dt`` and its
    ``curvature_rate``. Returns ``(K, Kp)``, both of shape (len(distances_m), P + 2), with
    ``kappa(q) = K @ p`` and ``kappa'(q) = Kp @ p``:

    * kappa: piecewise linear through the samples, held at kappa(d_P) beyond the last sample;
    * kappa': nodal derivatives (``kappa'(0)`` from the observation, central differences at the inner samples,
      a backward difference at the last one), linearly interpolated; zero beyond the last sample.
    """
    p = layout.n_preview
    nodes = np.concatenate(([0.0], np.asarray(layout.preview_distances(v_x), dtype=np.float64)))
    # nodal derivatives G (P+1, P+2) in terms of p
    g = np.zeros((p + 1, p + 2))
    g[0, p + 1] = 1.0
    for k in range(1, p):
        h = nodes[k + 1] - nodes[k - 1]
        g[k, k + 1] += 1.0 / h
        g[k, k - 1] -= 1.0 / h
    h = nodes[p] - nodes[p - 1]
    g[p, p] += 1.0 / h
    g[p, p - 1] -= 1.0 / h
    q = np.asarray(distances_m, dtype=np.float64).reshape(-1)
    if np.any(q < 0.0):
        raise ValueError("look-ahead distances must be >= 0 m")
    w = np.zeros((q.size, p + 1))
    inside = q <= nodes[-1]
    j = np.clip(np.searchsorted(nodes, q, side="right") - 1, 0, p - 1)
    theta = np.clip((q - nodes[j]) / (nodes[j + 1] - nodes[j]), 0.0, 1.0)
    rows = np.arange(q.size)
    w[rows, j] = 1.0 - theta
    w[rows, j + 1] = theta
    kappa = np.zeros((q.size, p + 2))
    kappa[:, : p + 1] = w
    kappa[~inside, :] = 0.0
    kappa[~inside, p] = 1.0
    dkappa = w @ g
    dkappa[~inside, :] = 0.0
    return kappa, dkappa
