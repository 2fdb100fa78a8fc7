"""Smooth 1-D profiles along arc length: piecewise C^2 curvature kappa(s) and a sine-sum elevation z(s).

``CurvatureProfile`` joins knots with the quintic "smootherstep" blend ``S(t) = 10t^3 - 15t^4 + 6t^5`` whose first
and second derivatives vanish at both ends, so kappa is C^2 and dkappa/ds is C^1 everywhere (a clothoid-like
transition with a smooth curvature rate). Equal values at two consecutive knots give a constant-curvature piece
(a circular arc, or a straight if the value is 0).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

import numpy as np


def smootherstep(t: np.ndarray) -> np.ndarray:
    """Quintic blend S(t) = 10t^3 - 15t^4 + 6t^5 on t in [0, 1] (clipped outside); S' = S'' = 0 at both ends."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * t * (10.0 + t * (-15.0 + 6.0 * t))


def smootherstep_d1(t: np.ndarray) -> np.ndarray:
    """dS/dt = 30 t^2 (1 - t)^2 (zero outside [0, 1])."""
    inside = (t >= 0.0) & (t <= 1.0)
    tc = np.clip(t, 0.0, 1.0)
    return np.where(inside, 30.0 * tc * tc * (1.0 - tc) ** 2, 0.0)


def smootherstep_integral(t: np.ndarray) -> np.ndarray:
    """Integral of S from 0 to t for t in [0, 1] (= 2.5t^4 - 3t^5 + t^6; 0.5 at t = 1)."""
    t = np.clip(t, 0.0, 1.0)
    return t ** 4 * (2.5 + t * (-3.0 + t))


@dataclass(frozen=True)
class CurvatureProfile:
    """Piecewise C^2 curvature kappa(s) [1/m] over arc length s in [0, length_m] [m].

    ``knots_m`` are the arc lengths of the piece boundaries (strictly increasing, starting at 0) and
    ``kappa_per_m`` the curvature there; between two knots kappa blends with ``smootherstep``. Outside
    [0, length_m] kappa is held constant. Build it with :meth:`from_segments`.
    """

    knots_m: tuple[float, ...]
    kappa_per_m: tuple[float, ...]

    def __post_init__(self) -> None:
        knots = np.asarray(self.knots_m, dtype=float)
        kap = np.asarray(self.kappa_per_m, dtype=float)
        if knots.ndim != 1 or knots.size < 2:
            raise ValueError(f"CurvatureProfile.knots_m must hold >= 2 values (got {knots.size})")
        if kap.shape != knots.shape:
            raise ValueError("CurvatureProfile.kappa_per_m must have one value per knot "
                             f"(got {kap.size} values for {knots.size} knots)")
        if not (np.all(np.isfinite(knots)) and np.all(np.isfinite(kap))):
            raise ValueError("CurvatureProfile.knots_m and kappa_per_m must be finite")
        if knots[0] != 0.0:
            raise ValueError(f"CurvatureProfile.knots_m must start at 0 (got {knots[0]})")
        if np.any(np.diff(knots) <= 0.0):
            raise ValueError("CurvatureProfile.knots_m must be strictly increasing (every piece length > 0 m)")

    @classmethod
    def from_segments(cls, kappa0_per_m: float, segments: Iterable[tuple[float, float]]) -> CurvatureProfile:
        """Profile starting at curvature ``kappa0_per_m`` [1/m]; each ``(length_m, kappa_end_per_m)`` segment blends
        from the previous curvature to ``kappa_end_per_m`` over ``length_m`` [m] (constant if they are equal)."""
        knots = [0.0]
        kap = [float(kappa0_per_m)]
        for k, (length, kappa_end) in enumerate(segments):
            if not (math.isfinite(length) and length > 0.0):
                raise ValueError(f"CurvatureProfile segment {k}: length_m must be > 0 (got {length})")
            knots.append(knots[-1] + float(length))
            kap.append(float(kappa_end))
        return cls(tuple(knots), tuple(kap))

    @cached_property
    def _arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        knots = np.asarray(self.knots_m, dtype=float)
        kap = np.asarray(self.kappa_per_m, dtype=float)
        lengths = np.diff(knots)
        turn = np.concatenate(([0.0], np.cumsum(0.5 * (kap[:-1] + kap[1:]) * lengths)))
        return knots, kap, lengths, turn

    @property
    def length_m(self) -> float:
        """Total arc length [m]."""
        return float(self.knots_m[-1])

    @property
    def total_turn_rad(self) -> float:
        """Heading change over the whole profile, the integral of kappa [rad] (exact)."""
        return float(self._arrays[3][-1])

    def _piece(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        knots, _, lengths, _ = self._arrays
        i = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, lengths.size - 1)
        return i, (s - knots[i]) / lengths[i]

    def kappa(self, s: np.ndarray) -> np.ndarray:
        """Curvature kappa(s) [1/m]."""
        s = np.asarray(s, dtype=float)
        _, kap, _, _ = self._arrays
        i, t = self._piece(s)
        return kap[i] + (kap[i + 1] - kap[i]) * smootherstep(t)

    def dkappa(self, s: np.ndarray) -> np.ndarray:
        """Curvature rate dkappa/ds [1/m^2]."""
        s = np.asarray(s, dtype=float)
        _, kap, lengths, _ = self._arrays
        i, t = self._piece(s)
        return (kap[i + 1] - kap[i]) / lengths[i] * smootherstep_d1(t)

    def heading(self, s: np.ndarray) -> np.ndarray:
        """Heading change from s = 0, the integral of kappa from 0 to s [rad] (exact; linear outside the range)."""
        s = np.asarray(s, dtype=float)
        knots, kap, lengths, turn = self._arrays
        i, t = self._piece(s)
        tc = np.clip(t, 0.0, 1.0)
        inside = turn[i] + lengths[i] * (kap[i] * tc + (kap[i + 1] - kap[i]) * smootherstep_integral(tc))
        before = kap[0] * np.minimum(s, 0.0)
        after = kap[-1] * np.maximum(s - knots[-1], 0.0)
        return inside + before + after

    def __call__(self, s: np.ndarray) -> np.ndarray:
        """Same as :meth:`kappa`."""
        return self.kappa(s)


@dataclass(frozen=True)
class SineElevation:
    """Elevation z(s) = offset_m + sum_k a_k sin(2 pi s / lambda_k + phi_k) [m] over arc length s [m].

    Infinitely smooth. With every wavelength an integer fraction of a closed path's length it is periodic.
    """

    amplitudes_m: tuple[float, ...]
    wavelengths_m: tuple[float, ...]
    phases_rad: tuple[float, ...]
    offset_m: float = 0.0

    def __post_init__(self) -> None:
        n = len(self.amplitudes_m)
        if len(self.wavelengths_m) != n or len(self.phases_rad) != n:
            raise ValueError("SineElevation.amplitudes_m, wavelengths_m and phases_rad must have equal lengths "
                             f"(got {n}, {len(self.wavelengths_m)}, {len(self.phases_rad)})")
        for name in ("amplitudes_m", "wavelengths_m", "phases_rad"):
            if not all(math.isfinite(v) for v in getattr(self, name)):
                raise ValueError(f"SineElevation.{name} must be finite")
        if any(w <= 0.0 for w in self.wavelengths_m):
            raise ValueError(f"SineElevation.wavelengths_m must all be > 0 (got {self.wavelengths_m})")
        if not math.isfinite(self.offset_m):
            raise ValueError(f"SineElevation.offset_m must be finite (got {self.offset_m})")

    def _terms(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = np.asarray(s, dtype=float)
        a = np.asarray(self.amplitudes_m, dtype=float)
        w = 2.0 * np.pi / np.asarray(self.wavelengths_m, dtype=float)
        arg = s[..., None] * w + np.asarray(self.phases_rad, dtype=float)
        return a, w, arg

    def z(self, s: np.ndarray) -> np.ndarray:
        """Elevation z(s) [m]."""
        a, _, arg = self._terms(s)
        return self.offset_m + np.sum(a * np.sin(arg), axis=-1)

    def grade(self, s: np.ndarray) -> np.ndarray:
        """Grade dz/ds [-]."""
        a, w, arg = self._terms(s)
        return np.sum(a * w * np.cos(arg), axis=-1)

    def zpp(self, s: np.ndarray) -> np.ndarray:
        """Vertical curvature d2z/ds2 [1/m]."""
        a, w, arg = self._terms(s)
        return -np.sum(a * w * w * np.sin(arg), axis=-1)

    @property
    def max_abs_grade_bound(self) -> float:
        """Upper bound sum_k |a_k| 2 pi / lambda_k on |dz/ds| [-]."""
        pairs = zip(self.amplitudes_m, self.wavelengths_m, strict=True)
        return float(sum(abs(a) * 2.0 * math.pi / w for a, w in pairs))
