"""The race's generalisation split: procedural closed circuits to train on, to choose a recipe on, to judge on.

``RACE_SPLIT`` is the registry (``race_circuit(name)`` builds every circuit it names):

- ``"train"``: the training circuits ``rc-0`` .. ``rc-23`` and ``rs-0`` .. ``rs-11`` (one ``rs`` after every two
  ``rc``), the only ones a trainer drives;
- ``"validation"``: ``rc-24`` .. ``rc-31``, never trained on, the circuits a recipe is developed against;
- ``"held_out"``: ``rc-2000`` .. ``rc-2003``, from a disjoint range of seeds, never trained on and not driven while a
  recipe is developed: the circuits an agent is judged on, once, at the end;
- ``"held_out_ids"``: the shipped race ids (``vtrack/Race-v0``: the handling course, ``vtrack/RaceRing-v0``: the
  example ring), never trained on, also reported; both were driven while earlier race recipes were developed, so
  they are not an untouched test.

A training circuit ``rc-<k>`` is a smooth closed loop drawn from seed k: in polar form about its centre,
r(theta) = R (1 + sum_j a_j cos(j theta + phi_j)) for j = 2..5, with R 55-95 m and sum |a_j| < 0.45 (so r > 0
and the loop never crosses itself); for odd k the loop is stretched (R x 0.7, then x scaled by 1.8-2.8: long fast
sides between tight ends); a two-lane 3.5 m half width as the shipped circuits have. Loops whose tightest radius is
below ``MIN_RADIUS_M`` or whose road would touch itself (``Path.self_intersects``) are drawn again. Laps are
400-1000 m with radii from 12 m to near-straights. Pure numpy and the package's own path fitting.

A training circuit ``rs-<k>`` is a loop of straights and constant-radius corners (``tracks.corner_circuits``: a
straight runs into a corner of one radius, 15-60 m, through a 10-25 m blend, as on the handling course), 600-1500 m;
only the training group has any. The validation and held-out circuits are all ``rc-<k>``.
"""

from __future__ import annotations

import math

import numpy as np

CORNER_TRAIN_CIRCUITS = 12
"""How many corner circuits (``rs-0`` ..) the training group holds."""
TRAIN_CIRCUITS: tuple[str, ...] = tuple(name for k in range(24) for name in
                                        ((f"rc-{k}",) + ((f"rs-{k // 2}",) if k % 2 == 1 else ())))
"""The training circuits' names: the smooth loops of seeds 0..23, with a corner circuit ``rs-<j>`` (seeds 0..11)
after every second one, so that every few consecutive training races include one."""
VALIDATION_CIRCUITS: tuple[str, ...] = tuple(f"rc-{k}" for k in range(24, 32))
"""The validation circuits' names (seeds 24..31): never trained on; a recipe is chosen on them."""
HELD_OUT_CIRCUITS: tuple[str, ...] = tuple(f"rc-{k}" for k in range(2000, 2004))
"""The held-out circuits' names (seeds 2000..2003): never trained on, not driven while a recipe is developed."""
HELD_OUT_IDS: tuple[str, ...] = ("vtrack/Race-v0", "vtrack/RaceRing-v0")
"""The held-out race ids (the shipped circuits; seen while earlier race recipes were developed)."""
RACE_SPLIT: dict[str, tuple[str, ...]] = {"train": TRAIN_CIRCUITS, "validation": VALIDATION_CIRCUITS,
                                          "held_out": HELD_OUT_CIRCUITS, "held_out_ids": HELD_OUT_IDS}
"""The split: training, validation and held-out circuit names, and the held-out race ids."""
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
    """The circuit ``name`` (one of ``RACE_SPLIT``'s, or ``rc-<k>`` / ``rs-<k>`` for any k >= 0) as a closed
    ``tracks.Path``; ``ValueError`` naming the forms otherwise."""
    from vtrack_gym.tracks.path import Path
    from vtrack_gym.tracks.table import COL_KAPPA

    prefix, _, index = str(name).partition("-")
    if prefix not in ("rc", "rs") or not index.isdigit():
        raise ValueError(f"race circuit name must be rc-<k> or rs-<k> with k >= 0, e.g. {TRAIN_CIRCUITS[0]!r} "
                         f"(got {name!r})")
    if prefix == "rs":
        from vtrack_gym.tracks.corner_circuits import corner_circuit

        return corner_circuit(int(index), str(name), HALF_WIDTH_M)
    rng = np.random.default_rng(int(index))
    for _ in range(_ATTEMPTS):
        x, y = _loop(rng, int(index) % 2 == 1)
        path = Path.from_points(x, y, closed=True, half_width_m=HALF_WIDTH_M, name=str(name), version="1")
        if float(np.max(np.abs(path.table[:, COL_KAPPA]))) > 1.0 / MIN_RADIUS_M:
            continue
        if not path.self_intersects(clearance_m=2.0 * HALF_WIDTH_M):
            return path
    raise ValueError(f"race circuit {name!r}: no loop within the limits after {_ATTEMPTS} draws")
