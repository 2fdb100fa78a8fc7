"""The race's generalisation split: procedural closed circuits to train on, the shipped circuits held out.

``RACE_SPLIT`` is the registry: ``"train"`` names the training circuits (``race_circuit(name)`` builds each one), and
``"held_out"`` the race ids an agent trained on the split is judged on (``vtrack/Race-v0``: the handling course,
``vtrack/RaceRing-v0``: the example ring), which training never drives.

A training circuit ``rc-<k>`` is a smooth closed loop drawn from seed k: in polar form about its centre,
r(theta) = R (1 + sum_j a_j cos(j theta + phi_j)) for j = 2..5, with R 55-95 m and sum |a_j| < 0.45 (so r > 0
and the loop never crosses itself); for odd k the loop is stretched (R x 0.7, then x scaled by 1.8-2.8: long fast
sides between tight ends); a two-lane 3.5 m half width as the shipped circuits have. Loops whose tightest radius is
below ``MIN_RADIUS_M`` or whose road would touch itself (``Path.self_intersects``) are drawn again. Laps are
400-1000 m with radii from 12 m to near-straights. Pure numpy and the package's own path fitting.
"""

from __future__ import annotations

import math

import numpy as np

TRAIN_CIRCUITS: tuple[str, ...] = tuple(f"rc-{k}" for k in range(24))
"""The training circuits' names (seeds 0..23)."""
HELD_OUT_IDS: tuple[str, ...] = ("vtrack/Race-v0", "vtrack/RaceRing-v0")
"""The held-out race ids (the shipped circuits)."""
RACE_SPLIT: dict[str, tuple[str, ...]] = {"train": TRAIN_CIRCUITS, "held_out": HELD_OUT_IDS}
"""The split: training circuit names and held-out race ids."""
HALF_WIDTH_M = 3.5
"""Half width of every training circuit [m] (as the handling course and the ring)."""
MIN_RADIUS_M = 12.0
"""Tightest centre-line radius a training circuit may have [m]."""
_POINTS = 180
_ATTEMPTS = 50


def _loop(rng: np.random.Generator, stretched: bool) -> tuple[np.ndarray, np.ndarray]:
    """One draw of the polar loop's points x, y [m] (counter-clockwise, not repeating the first); ``stretched``:
    x scaled by 1.8-2.8, y by 0.7 (long fast sides between tight ends)."""
    radius = float(rng.uniform(55.0, 95.0)) * (0.7 if stretched else 1.0)
    orders = np.arange(2, 6)
    amps = rng.dirichlet(np.ones(orders.size)) * float(rng.uniform(0.15, 0.45))
    phases = rng.uniform(0.0, 2.0 * math.pi, orders.size)
    theta = np.linspace(0.0, 2.0 * math.pi, _POINTS, endpoint=False)
    r = radius * (1.0 + np.sum(amps[:, None] * np.cos(orders[:, None] * theta + phases[:, None]), axis=0))
    stretch = float(rng.uniform(1.8, 2.8)) if stretched else 1.0
    return stretch * r * np.cos(theta), r * np.sin(theta)


def race_circuit(name: str) -> object:
    """The training circuit ``name`` (one of ``TRAIN_CIRCUITS``, or ``rc-<k>`` for any k >= 0) as a closed
    ``tracks.Path``; ``ValueError`` naming the form otherwise."""
    from vtrack_gym.tracks.path import Path
    from vtrack_gym.tracks.table import COL_KAPPA

    prefix, _, index = str(name).partition("-")
    if prefix != "rc" or not index.isdigit():
        raise ValueError(f"race circuit name must be rc-<k> with k >= 0, e.g. {TRAIN_CIRCUITS[0]!r} (got {name!r})")
    rng = np.random.default_rng(int(index))
    for _ in range(_ATTEMPTS):
        x, y = _loop(rng, int(index) % 2 == 1)
        path = Path.from_points(x, y, closed=True, half_width_m=HALF_WIDTH_M, name=str(name), version="1")
        if float(np.max(np.abs(path.table[:, COL_KAPPA]))) > 1.0 / MIN_RADIUS_M:
            continue
        if not path.self_intersects(clearance_m=2.0 * HALF_WIDTH_M):
            return path
    raise ValueError(f"race circuit {name!r}: no loop within the limits after {_ATTEMPTS} draws")
