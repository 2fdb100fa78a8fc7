"""Branch-free sin/cos, atan and tanh for the ``fast`` plant (``vehicle.fast_kernels``): straight-line float64
arithmetic (polynomials, one division, selects), so a loop over cars that calls them compiles to SIMD code, where
numba's ``math.sin`` / ``math.atan2`` / ``math.tanh`` are scalar library calls that stop the loop vectoriser.

Error bounds (measured by ``tests/test_fast_numerics.py`` against 40-digit mpmath on dense grids; the
polynomial fits themselves are below 1e-17, ``vehicle.fast_math_fit``; the rest is float64 rounding):

- ``sin_cos(x)``: |error| <= 4e-16 absolute for |x| <= 4 pi, growing with the quarter-turn count as
  |x| 1.2e-16 beyond (the reduction subtracts q pi/2 in two float64 parts): 3e-13 at |x| = 1e3 rad;
- ``atan_ratio(y, x)`` = atan2(y, x) for x > 0: |error| <= 4e-16 rad for any finite y;
- ``tanh_bounded(y)``: |error| <= 1e-14 for |y| < 20, exactly +-1 beyond (as the default plant's shortcut).

All are odd/even exactly as the functions they replace (sin(-x) = -sin(x), atan(-y) = -atan(y), ...).
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel

SIN_COEFFS = (  # sin(x)/x in s = x^2, |x| <= pi/4, highest order first (fast_math_fit)
    1.5894736324816257e-10,
    -2.505071696855487e-08,
    2.755731337636513e-06,
    -0.000198412698286502,
    0.008333333333320363,
    -0.16666666666666616,
    1.0,
)
COS_COEFFS = (  # cos(x) in s = x^2, |x| <= pi/4
    -1.1353379404688011e-11,
    2.0875582375980447e-09,
    -2.7557313097753415e-07,
    2.4801587283881013e-05,
    -0.0013888888888861095,
    0.04166666666666645,
    -0.5,
    1.0,
)
ATAN_COEFFS = (  # atan(t)/t in s = t^2, |t| <= tan(pi/8)
    -0.017805367187792815,
    0.03796523036806375,
    -0.05035101403429524,
    0.058468780664528784,
    -0.06662951782282021,
    0.0769204532817595,
    -0.09090896808912241,
    0.11111110744914408,
    -0.1428571427925014,
    0.1999999999994089,
    -0.3333333333333312,
    1.0,
)
EXPM_COEFFS = (  # exp(-v), 0 <= v <= 0.625
    -1.836295942991452e-08,
    2.6518425223242024e-07,
    -2.7462043706259705e-06,
    2.4795983827954155e-05,
    -0.000198410509364246,
    0.0013888883165654388,
    -0.008333333234632768,
    0.04166666665586142,
    -0.16666666666596805,
    0.49999999999997663,
    -0.9999999999999997,
    1.0,
)
TWO_OVER_PI = 0.6366197723675814
PIO2_HI = 1.5707963267341256   # pi/2 to 33 significant bits: q * PIO2_HI is exact for |q| < 2^20
PIO2_LO = 6.077100506506192e-11  # pi/2 - PIO2_HI (to 3.5e-27)
QUARTER_PI = 0.7853981633974483
HALF_PI = 1.5707963267948966
TAN_PI_8 = 0.41421356237309503
TAN_3PI_8 = 2.414213562373095
TANH_SATURATION = 20.0   # |y| from which tanh(y) is +-1 in float64 (the default plant's shortcut)
TANH_SQUARINGS = 6       # exp(-u) = exp(-u / 64)^64
TANH_SCALE = 2.0 / 64.0  # v = 2 |y| / 64 <= 0.625


@kernel(inline=True)
def _poly(coeffs: tuple, s: float) -> float:
    """Horner's scheme, ``coeffs`` highest order first."""
    acc = 0.0
    for c in coeffs:
        acc = acc * s + c
    return acc


@kernel(inline=True)
def sin_cos(x: float) -> tuple[float, float]:
    """(sin x, cos x) for finite x [rad] (error in the module docstring)."""
    q = np.floor(x * TWO_OVER_PI + 0.5)          # nearest quarter turn
    r = (x - q * PIO2_HI) - q * PIO2_LO          # |r| <= pi/4 (+ rounding)
    s = r * r
    sin_r = r * _poly(SIN_COEFFS, s)
    cos_r = _poly(COS_COEFFS, s)
    quadrant = q - 4.0 * np.floor(0.25 * q)      # 0, 1, 2, 3
    odd = quadrant == 1.0 or quadrant == 3.0
    sin_x = cos_r if odd else sin_r
    cos_x = sin_r if odd else cos_r
    sin_x = -sin_x if quadrant >= 2.0 else sin_x
    cos_x = -cos_x if (quadrant == 1.0 or quadrant == 2.0) else cos_x
    return sin_x, cos_x


@kernel(inline=True)
def atan_ratio(y: float, x: float) -> float:
    """atan2(y, x) [rad] for x > 0 (so atan(y / x) in (-pi/2, pi/2)), with one division."""
    a = abs(y)
    big = a > TAN_3PI_8 * x
    mid = a > TAN_PI_8 * x
    num = -x if big else (a - x if mid else a)
    den = a if big else (a + x if mid else x)
    base = HALF_PI if big else (QUARTER_PI if mid else 0.0)
    t = num / den
    return math.copysign(base + t * _poly(ATAN_COEFFS, t * t), y)


@kernel(inline=True)
def tanh_bounded(y: float) -> float:
    """tanh(y): exactly +-1 for |y| >= 20, else (1 - e) / (1 + e) with e = exp(-2|y|) (error in the docstring)."""
    a = min(abs(y), TANH_SATURATION)
    e = _poly(EXPM_COEFFS, a * TANH_SCALE)
    for _ in range(TANH_SQUARINGS):
        e = e * e
    t = (1.0 - e) / (1.0 + e)
    return math.copysign(1.0 if abs(y) >= TANH_SATURATION else t, y)
