"""How the polynomial coefficients of ``vehicle.fast_math`` were obtained: run ``python -m
vtrack_gym.vehicle.fast_math_fit`` to print them (needs mpmath; not imported by the package at run time).

Each is ``mpmath.chebyfit`` (a Chebyshev fit in 40-digit arithmetic, near-minimax) of a smooth function of
``s = x^2`` (of ``v`` for EXPM) on the reduced range the fast functions use, rounded to float64:

- ``SIN``: sin(x) / x for |x| <= pi/4, ``COS``: cos(x) for |x| <= pi/4 (after reduction by quarter turns);
- ``ATAN``: atan(t) / t for |t| <= tan(pi/8) (after atan(a) = pi/4 + atan((a - 1) / (a + 1)) or pi/2 - atan(1 / a));
- ``EXPM``: exp(-v) for 0 <= v <= 0.625 (tanh for |y| <= 20 from exp(-2|y|) = exp(-2|y| / 64)^64).

The fits' own error (printed) is below 1e-17 for each; what remains is float64 rounding, measured by
``tests/test_fast_numerics.py``.
"""

from __future__ import annotations

TERMS = {"SIN": 7, "COS": 8, "ATAN": 12, "EXPM": 12}
"""Number of coefficients of each fit."""
EXP_RANGE = 0.625
"""Upper end of the EXPM fit [-]: 40 / 64, tanh's argument range |y| <= 20 after the 2^6 reduction."""


def fitted() -> dict[str, tuple[tuple[float, ...], float]]:
    """Name -> (coefficients, highest order first, as float64; the fit's max error in 40-digit arithmetic)."""
    import mpmath as mp

    mp.mp.dps = 40
    widen = 1 + mp.mpf("1e-6")   # the reductions may land a rounding step outside the nominal range
    quarter, tan8 = mp.pi / 4, mp.tan(mp.pi / 8)
    functions = {
        "SIN": (lambda s: mp.sin(mp.sqrt(s)) / mp.sqrt(s) if s else mp.mpf(1), (quarter * widen) ** 2),
        "COS": (lambda s: mp.cos(mp.sqrt(s)), (quarter * widen) ** 2),
        "ATAN": (lambda s: mp.atan(mp.sqrt(s)) / mp.sqrt(s) if s else mp.mpf(1), (tan8 * widen) ** 2),
        "EXPM": (lambda v: mp.exp(-v), mp.mpf(EXP_RANGE) * widen),
    }
    out = {}
    for name, (f, top) in functions.items():
        coef, err = mp.chebyfit(f, [0, top], TERMS[name], error=True)
        out[name] = (tuple(float(c) for c in coef), float(err))
    return out


if __name__ == "__main__":
    for name, (coef, err) in fitted().items():
        print(f"{name}_COEFFS = (  # fit error {err:.1e}")
        for c in coef:
            print(f"    {c!r},")
        print(")")
