"""The reference-line geometry records of ASAM OpenDRIVE (``line``, ``arc``, ``spiral``, ``poly3``,
``paramPoly3``) evaluated at arc lengths: position [m], heading [rad] and curvature [1/m].

Lines and arcs are closed-form (a chord of length ``s sinc(kappa s / 2)`` at the mean heading, exact for
kappa -> 0). A spiral (Euler spiral, clothoid) has curvature linear in s, kappa(s) = k0 + c s; its position is the
Fresnel integral, evaluated with ``scipy.special.fresnel`` after completing the square in the heading
theta(s) = theta0 + k0 s + c s^2 / 2 (|c| below ``STRAIGHT_RATE`` [1/m^2] is an arc). The cubic records are
given in a local (u, v) frame: ``poly3`` as v(u), ``paramPoly3`` as u(p), v(p); their arc length is integrated with
Gauss-Legendre quadrature and inverted by interpolation on ``CUBIC_SAMPLES`` sub-intervals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

STRAIGHT_RATE = 1e-12
"""A spiral whose curvature rate |c| is below this [1/m^2] is evaluated as an arc."""
CUBIC_SAMPLES = 512
"""Sub-intervals of a cubic record's parameter on which its arc length is tabulated."""
GEOMETRY_KINDS = ("line", "arc", "spiral", "poly3", "paramPoly3")
"""The geometry records this reader evaluates (OpenDRIVE 1.4-1.8)."""

_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)


@dataclass(frozen=True)
class Geometry:
    """One ``<geometry>`` record: start ``s0`` [m], start point ``x0, y0`` [m], heading ``hdg`` [rad], ``length``
    [m], ``kind`` (one of ``GEOMETRY_KINDS``) and its coefficients ``params`` (arc: (k,), spiral: (k0, k1), poly3:
    (a, b, c, d), paramPoly3: (aU, bU, cU, dU, aV, bV, cV, dV, p_end) with p_end 1 or the length)."""

    s0: float
    x0: float
    y0: float
    hdg: float
    length: float
    kind: str
    params: tuple[float, ...] = ()

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, heading, curvature) at distances ``s`` [m] from this record's start (0 <= s <= length)."""
        s = np.asarray(s, dtype=float)
        if self.kind == "line":
            return _arc(self, s, 0.0)
        if self.kind == "arc":
            return _arc(self, s, self.params[0])
        if self.kind == "spiral":
            return _spiral(self, s)
        return _cubic(self, s)


def _arc(g: Geometry, s: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A circular arc of curvature ``k`` [1/m] (0: a line): the chord s sinc(k s / 2) at heading hdg + k s / 2."""
    half = 0.5 * k * s
    chord = s * np.sinc(half / math.pi)
    mid = g.hdg + half
    return (g.x0 + chord * np.cos(mid), g.y0 + chord * np.sin(mid), g.hdg + k * s, np.full_like(s, k))


def _spiral(g: Geometry, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """An Euler spiral from curvature k0 to k1 over the record's length, by Fresnel integrals."""
    from scipy.special import fresnel

    k0, k1 = g.params
    c = (k1 - k0) / g.length
    if abs(c) < STRAIGHT_RATE:
        return _arc(g, s, 0.5 * (k0 + k1))
    sigma = 1.0 if c > 0.0 else -1.0
    scale = math.sqrt(math.pi / abs(c))        # t = scale * u  with  theta = phi + sigma * pi u^2 / 2
    phi = g.hdg - k0 * k0 / (2.0 * c)
    u0 = (k0 / c) / scale
    u = (s + k0 / c) / scale
    s_u, c_u = fresnel(u)
    s_0, c_0 = fresnel(u0)
    dc, ds = c_u - c_0, sigma * (s_u - s_0)
    x = g.x0 + scale * (math.cos(phi) * dc - math.sin(phi) * ds)
    y = g.y0 + scale * (math.sin(phi) * dc + math.cos(phi) * ds)
    return x, y, g.hdg + k0 * s + 0.5 * c * s * s, k0 + c * s


def _cubic_coefficients(g: Geometry) -> tuple[np.ndarray, np.ndarray, float]:
    """(u coefficients, v coefficients, parameter end) of a cubic record, lowest order first."""
    if g.kind == "poly3":
        a, b, c, d = g.params
        # v(u) with u the parameter itself; its end is where the arc length reaches the record's length
        return np.array([0.0, 1.0, 0.0, 0.0]), np.array([a, b, c, d]), math.nan
    au, bu, cu, du, av, bv, cv, dv, p_end = g.params
    return np.array([au, bu, cu, du]), np.array([av, bv, cv, dv]), p_end


def _speed(cu: np.ndarray, cv: np.ndarray, p: np.ndarray) -> np.ndarray:
    """|d(u, v)/dp| of the cubics."""
    du = np.polynomial.polynomial.polyval(p, np.polynomial.polynomial.polyder(cu))
    dv = np.polynomial.polynomial.polyval(p, np.polynomial.polynomial.polyder(cv))
    return np.hypot(du, dv)


def _arc_table(cu: np.ndarray, cv: np.ndarray, p_end: float) -> tuple[np.ndarray, np.ndarray]:
    """(parameter, arc length) at ``CUBIC_SAMPLES + 1`` points on [0, p_end] (Gauss-Legendre on each piece)."""
    p = np.linspace(0.0, p_end, CUBIC_SAMPLES + 1)
    half = 0.5 * np.diff(p)
    nodes = (p[:-1] + half)[:, None] + half[:, None] * _GL_X[None, :]
    pieces = (_speed(cu, cv, nodes) * _GL_W[None, :]).sum(axis=1) * half
    return p, np.concatenate(([0.0], np.cumsum(pieces)))


def cubic_arc_length(g: Geometry) -> float:
    """Arc length [m] of a ``paramPoly3`` record over its parameter range (for a ``poly3`` record: over u in
    [0, length], an upper bound of the u range the record's length reaches)."""
    cu, cv, p_end = _cubic_coefficients(g)
    return float(_arc_table(cu, cv, g.length if math.isnan(p_end) else p_end)[1][-1])


def _cubic(g: Geometry, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A ``poly3`` / ``paramPoly3`` record at arc lengths ``s``: the parameter found from the tabulated arc length
    (linear between ``CUBIC_SAMPLES`` Gauss-Legendre pieces, refined by two Newton steps)."""
    cu, cv, p_end = _cubic_coefficients(g)
    p_tab, s_tab = _arc_table(cu, cv, g.length if math.isnan(p_end) else p_end)
    p = np.interp(s, s_tab, p_tab)
    d1u, d1v = np.polynomial.polynomial.polyder(cu), np.polynomial.polynomial.polyder(cv)
    for _ in range(2):
        idx = np.clip(np.searchsorted(p_tab, p) - 1, 0, CUBIC_SAMPLES - 1)
        lo = p_tab[idx]
        h = 0.5 * (p - lo)
        nodes = (lo + h)[:, None] + h[:, None] * _GL_X[None, :]
        s_p = s_tab[idx] + (_speed(cu, cv, nodes) * _GL_W[None, :]).sum(axis=1) * h
        p = p - (s_p - s) / np.maximum(_speed(cu, cv, p), 1e-12)
    u = np.polynomial.polynomial.polyval(p, cu)
    v = np.polynomial.polynomial.polyval(p, cv)
    du, dv = np.polynomial.polynomial.polyval(p, d1u), np.polynomial.polynomial.polyval(p, d1v)
    ddu = np.polynomial.polynomial.polyval(p, np.polynomial.polynomial.polyder(d1u))
    ddv = np.polynomial.polynomial.polyval(p, np.polynomial.polynomial.polyder(d1v))
    kappa = (du * ddv - dv * ddu) / np.maximum(np.hypot(du, dv), 1e-12) ** 3
    ch, sh = math.cos(g.hdg), math.sin(g.hdg)
    return g.x0 + ch * u - sh * v, g.y0 + sh * u + ch * v, g.hdg + np.arctan2(dv, du), kappa
