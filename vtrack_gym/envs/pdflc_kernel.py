"""Compiled PD-FLC step for the env's inner speed loop (numba; imported lazily by the env kernel).

Same controller as ``pdflc.PDFLC`` (same precomputed surface, same kink-aligned triangle interpolation, same
filtered derivative), one car at a time so it runs inside the env's single compiled step. The numpy class
stays the reference; ``tests/test_pdflc_kernel.py`` checks that both agree to 1e-12.

Per-car memory ``mem`` (3,): previous speed error e_v [m/s], filtered derivative de_v [m/s^2], fresh flag
(1 = first call after a reset: derivative 0).
Gains vector ``gains`` (7,): G1, G2, G3, G4, filter pole exp(-dt/tau_f), dt [s], e_v scale (1 or 3.6).
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.envs.pdflc import PDFLCConfig

M_E_PREV, M_DE, M_FRESH = range(3)
K_G1, K_G2, K_G3, K_G4, K_POLE, K_DT, K_ESCALE = range(7)


def pdflc_gains(config: PDFLCConfig, dt_s: float) -> np.ndarray:
    """Gains vector of the kernel for ``config`` at control period ``dt_s`` [s]."""
    pole = math.exp(-dt_s / config.tau_f_s) if config.tau_f_s > 0.0 else 0.0
    return np.array([config.g1, config.g2, config.g3, config.g4, pole, dt_s,
                     3.6 if config.speed_error_in_kmh else 1.0])


@kernel(inline=True)
def _surface_value(surface: np.ndarray, e: float, de: float, kink_aligned: bool) -> float:
    """Interpolated fuzzy output at clipped inputs (bilinear, or triangles aligned with the Mamdani kinks)."""
    n = surface.shape[0]
    pos_e = (e + 1.0) * (0.5 * (n - 1))
    i = min(int(pos_e), n - 2)
    fx = pos_e - i
    pos_d = (de + 1.0) * (0.5 * (n - 1))
    j = min(int(pos_d), n - 2)
    fy = pos_d - j
    f00 = surface[i, j]
    f10 = surface[i + 1, j]
    f01 = surface[i, j + 1]
    f11 = surface[i + 1, j + 1]
    if not kink_aligned:
        return f00 + fx * (f10 - f00) + fy * (f01 - f00) + fx * fy * (f00 - f10 - f01 + f11)
    per_quadrant = (n - 1) // 8
    if ((i // per_quadrant + j // per_quadrant) % 2) == 0:
        if fx >= fy:
            return f00 + fx * (f10 - f00) + fy * (f11 - f10)
        return f00 + fy * (f01 - f00) + fx * (f11 - f01)
    if fx + fy <= 1.0:
        return f00 + fx * (f10 - f00) + fy * (f01 - f00)
    return f11 + (1.0 - fx) * (f01 - f11) + (1.0 - fy) * (f10 - f11)


@kernel(inline=True)
def pdflc_step(v: float, v_ref: float, mem: np.ndarray, gains: np.ndarray, surface: np.ndarray,
               kink_aligned: bool) -> tuple[float, float]:
    """Throttle fraction [0..1] and brake pedal force [N] for speed ``v`` and set point ``v_ref`` [m/s]."""
    e_v = v - v_ref
    pole = gains[K_POLE]
    if mem[M_FRESH] != 0.0:
        de = 0.0
        mem[M_FRESH] = 0.0
    else:
        de = pole * mem[M_DE] + (1.0 - pole) * (e_v - mem[M_E_PREV]) / gains[K_DT]
    mem[M_DE] = de
    mem[M_E_PREV] = e_v
    e_hat = min(max(gains[K_G1] * (e_v * gains[K_ESCALE]), -1.0), 1.0)
    de_hat = min(max(gains[K_G2] * de, -1.0), 1.0)
    u = _surface_value(surface, e_hat, de_hat, kink_aligned)
    throttle = min(max(gains[K_G3] * max(u, 0.0), 0.0), 1.0)
    brake = gains[K_G4] * max(-u, 0.0)
    return throttle, brake
