"""The path table: column schema, sample spacing and closure of a uniformly sampled centre-line.

Conventions (ISO 8855): global X, Y, Z up; heading psi counter-clockwise from +X; curvature kappa > 0 for a left
turn; lateral error e_y LEFT-positive, ``e_y = -(X - X_r) sin(psi_r) + (Y - Y_r) cos(psi_r)`` at the projection
(closest point) s* of the point onto the path. Arc length s is measured in the horizontal plane.

Table columns (float64, C-contiguous, row i at s = i * ds_m; closed paths repeat the start point at s = length_m
with psi increased by 2 pi times the turning number):

=====  ============  ======  ===============================
index  constant      unit    meaning
=====  ============  ======  ===============================
0      COL_X         m       X
1      COL_Y         m       Y
2      COL_PSI       rad     heading psi, UNWRAPPED (continuous)
3      COL_KAPPA     1/m     curvature kappa
4      COL_DKAPPA    1/m^2   dkappa/ds
5      COL_Z         m       elevation z
6      COL_GRADE     -       grade dz/ds
7      COL_ZPP       1/m     vertical curvature d2z/ds2
=====  ============  ======  ===============================
"""

from __future__ import annotations

import logging
import math
from typing import NamedTuple

import numpy as np

logger = logging.getLogger(__name__)

COL_X, COL_Y, COL_PSI, COL_KAPPA, COL_DKAPPA, COL_Z, COL_GRADE, COL_ZPP = range(8)
N_COLS = 8
COLUMN_NAMES = ("x_m", "y_m", "psi_rad", "kappa_per_m", "dkappa_per_m2", "z_m", "grade", "zpp_per_m")
DEFAULT_DS_M = 0.25
CLOSURE_TOL_M = 1e-6            # closed paths: max start/end mismatch of X, Y [m] and psi (mod 2 pi) [rad]


class PathSample(NamedTuple):
    """Interpolated path columns at the requested s (arrays of the shape of s)."""

    x: np.ndarray       # [m]
    y: np.ndarray       # [m]
    psi: np.ndarray     # [rad], unwrapped
    kappa: np.ndarray   # [1/m]
    dkappa: np.ndarray  # [1/m^2]
    z: np.ndarray       # [m]
    grade: np.ndarray   # [-]
    zpp: np.ndarray     # [1/m]


class Projection(NamedTuple):
    """Closest point of the path to each query point (arrays of shape (N,))."""

    s: np.ndarray        # arc length of the projection s* [m] (wrapped / clamped)
    e_y: np.ndarray      # lateral error, left-positive [m]
    psi_ref: np.ndarray  # path heading at s* [rad], unwrapped table value
    kappa: np.ndarray    # curvature at s* [1/m]
    x_ref: np.ndarray    # X of the projection point [m]
    y_ref: np.ndarray    # Y of the projection point [m]

def uniform_grid(length_m: float, ds_m: float) -> tuple[int, float]:
    """Number of rows and the actual spacing [m] (<= ds_m) dividing length_m evenly."""
    if not (math.isfinite(length_m) and length_m > 0.0):
        raise ValueError(f"length_m must be > 0 (got {length_m})")
    if not (math.isfinite(ds_m) and 0.0 < ds_m <= length_m):
        raise ValueError(f"ds_m must be in (0, length_m={length_m}] (got {ds_m})")
    n = math.ceil(length_m / ds_m - 1e-9) + 1
    return n, length_m / (n - 1)


def close_exactly(table: np.ndarray, s: np.ndarray, name: str, allow_zero_turns: bool = False) -> None:
    """Check the closure of a closed table and spread the (round-off) residual linearly along s, in place.

    The heading must change by a multiple of 2 pi, non-zero unless ``allow_zero_turns`` (a figure-eight).
    """
    length = s[-1]
    gx = table[-1, COL_X] - table[0, COL_X]
    gy = table[-1, COL_Y] - table[0, COL_Y]
    dpsi = table[-1, COL_PSI] - table[0, COL_PSI]
    turns = round(dpsi / (2.0 * math.pi))
    rpsi = dpsi - 2.0 * math.pi * turns
    if math.hypot(gx, gy) > CLOSURE_TOL_M or abs(rpsi) > CLOSURE_TOL_M or (turns == 0 and not allow_zero_turns):
        raise ValueError(f"path {name!r} does not close: end - start = ({gx:.3g}, {gy:.3g}) m, heading change "
                         f"{dpsi:.9f} rad (need |gap| <= {CLOSURE_TOL_M} m and a non-zero multiple of 2 pi)")
    ramp = s / length
    table[:, COL_X] -= gx * ramp
    table[:, COL_Y] -= gy * ramp
    table[:, COL_PSI] -= rpsi * ramp
    table[-1, COL_X] = table[0, COL_X]
    table[-1, COL_Y] = table[0, COL_Y]
    for col, unit in ((COL_KAPPA, "1/m"), (COL_DKAPPA, "1/m^2"), (COL_Z, "m"), (COL_GRADE, "-")):
        jump = abs(table[-1, col] - table[0, col])
        if jump > 1e-6:
            logger.warning("closed path %r: %s jumps by %.3g %s across the closure", name, COLUMN_NAMES[col], jump,
                           unit)
