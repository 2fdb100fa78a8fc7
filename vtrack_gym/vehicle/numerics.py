"""The plant's numerics modes (``numerics=`` of ``Plant``, ``EnvConfig`` and ``gym.make``): which compiled kernel
integrates the cars.

``"default"``: ``vehicle.kernels``, IEEE operations in a fixed order with the maths library's sin/cos/atan2/tanh;
every registered id is pinned with it. ``"fast"``: ``vehicle.fast_kernels``, the same model and RK4 laid out for
SIMD (structure of arrays, polynomial sin/cos/atan/tanh with errors of about 1e-16, reciprocals of parameters);
agrees with the default within the tolerances ``docs/performance.md`` states, and is recorded in a result's
identity (``options["env_config"]["numerics"]``), so rows of the two modes never share a leaderboard entry.
"""

from __future__ import annotations

NUMERICS: dict[str, str] = {
    "default": "the pinned kernel: maths-library transcendental functions, one car at a time",
    "fast": "structure-of-arrays SIMD kernel with bounded-error polynomial sin/cos/atan/tanh (about 1e-16)",
}
"""Numerics mode name -> what it is."""


def check_numerics(numerics: object) -> str:
    """``numerics`` if it is a mode name; ``ValueError`` naming the field and the allowed values otherwise."""
    if not isinstance(numerics, str) or numerics not in NUMERICS:
        raise ValueError(f"numerics must be one of {', '.join(map(repr, NUMERICS))} (got {numerics!r})")
    return numerics
