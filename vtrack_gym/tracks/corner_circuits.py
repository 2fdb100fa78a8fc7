"""Procedural closed circuits of straights and constant-radius corners: the race split's ``rs-<k>`` training circuits.

A circuit ``rs-<k>`` is drawn from seed k as the handling course is built: straights joined by corners of one
radius each (``handling_course.turn_segments``: the curvature blended from 0 to 1/R over 10-25 m, at most 0.4 of
the corner's arc, held, and blended back), so a straight runs directly into a constant radius, which the smooth
``rc-<k>`` loops never do. 4 to 7 corners of radius 15-60 m, the turns drawn left (45-150 deg) or right (30-110
deg, one in four) and the last one closing the heading to one full turn (left for even k, mirrored to a clockwise
loop for odd k); straights 30-180 m, the two most nearly perpendicular of them lengthened or shortened to close the
position (one 2x2 solve, each kept at >= ``MIN_STRAIGHT_M``). Draws that do not close so, or whose road would
touch itself (``Path.self_intersects``), are drawn again. Flat, 3.5 m half width.
"""

from __future__ import annotations

import math

import numpy as np

MIN_STRAIGHT_M = 25.0
"""Shortest straight [m] a closed corner circuit keeps (its two closing straights included)."""
RADIUS_RANGE_M = (15.0, 60.0)
"""Corner radii [m]."""
_ATTEMPTS = 200

Layout = list[tuple[float, float, float, float, float]]
"""(straight before the corner [m], radius [m], turn [deg, left > 0], blend in [m], blend out [m]) per corner."""


def _draw_layout(rng: np.random.Generator) -> Layout | None:
    """One draw of the corners, the last closing the heading to +360 deg; None if that corner would be out of
    range (30-180 deg)."""
    n = int(rng.integers(4, 8))
    turns = [float(rng.uniform(45.0, 150.0)) if rng.random() > 0.25 else -float(rng.uniform(30.0, 110.0))
             for _ in range(n - 1)]
    last = 360.0 - sum(turns)
    if not 30.0 <= last <= 180.0:
        return None
    layout: Layout = []
    for turn in (*turns, last):
        radius = float(rng.uniform(*RADIUS_RANGE_M))
        arc = math.radians(abs(turn)) * radius            # the corner's length at its radius [m]
        blends = [min(float(rng.uniform(10.0, 25.0)), 0.4 * arc) for _ in range(2)]
        layout.append((float(rng.uniform(30.0, 180.0)), radius, turn, blends[0], blends[1]))
    return layout


def _segments(layout: Layout, straights: np.ndarray, mirror: bool) -> list[tuple[float, float]]:
    """The lap's ``(length_m, kappa_end_per_m)`` segments (``CurvatureProfile.from_segments`` from kappa 0)."""
    from vtrack_gym.tracks.handling_course import turn_segments

    sign = -1.0 if mirror else 1.0
    segs: list[tuple[float, float]] = []
    for straight, (_, radius, turn, b_in, b_out) in zip(straights, layout, strict=True):
        segs.append((float(straight), 0.0))
        segs += turn_segments(radius, sign * turn, b_in, b_out)
    return segs


def _closed(layout: Layout, mirror: bool) -> list[tuple[float, float]] | None:
    """The segments with the two most nearly perpendicular straights set so the lap closes in position; None if
    either would be shorter than ``MIN_STRAIGHT_M``."""
    from vtrack_gym.tracks.path import Path
    from vtrack_gym.tracks.profiles import CurvatureProfile

    straights = np.array([c[0] for c in layout])
    segs = _segments(layout, straights, mirror)
    prof = CurvatureProfile.from_segments(0.0, segs)
    starts = np.arange(len(layout)) * 4                  # each corner adds a straight and three segments
    heading = prof.heading(np.asarray(prof.knots_m)[starts])
    pairs = [(i, j) for i in range(len(layout)) for j in range(i + 1, len(layout))]
    i, j = max(pairs, key=lambda p: abs(math.sin(heading[p[0]] - heading[p[1]])))
    if abs(math.sin(heading[i] - heading[j])) < 0.3:
        return None
    end = Path.from_curvature(prof, ds_m=1.0).table[-1, :2]
    basis = np.array([[math.cos(heading[i]), math.cos(heading[j])], [math.sin(heading[i]), math.sin(heading[j])]])
    straights[[i, j]] += np.linalg.solve(basis, -end)
    if straights.min() < MIN_STRAIGHT_M:
        return None
    return _segments(layout, straights, mirror)


def corner_circuit(index: int, name: str, half_width_m: float = 3.5) -> object:
    """The closed corner circuit drawn from seed ``index`` as a ``tracks.Path`` named ``name`` (``ValueError`` if no
    draw closes within the limits)."""
    from vtrack_gym.tracks.path import Path
    from vtrack_gym.tracks.profiles import CurvatureProfile

    rng = np.random.default_rng([index, 1])
    for _ in range(_ATTEMPTS):
        layout = _draw_layout(rng)
        segs = None if layout is None else _closed(layout, mirror=index % 2 == 1)
        if segs is None:
            continue
        path = Path.from_curvature(CurvatureProfile.from_segments(0.0, segs), closed=True,
                                   half_width_m=half_width_m, name=name, version="1")
        if not path.self_intersects(clearance_m=2.0 * half_width_m):
            return path
    raise ValueError(f"corner circuit {name!r}: no closed layout within the limits after {_ATTEMPTS} draws")
