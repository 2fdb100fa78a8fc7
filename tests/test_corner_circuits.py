"""The race split's corner circuits (``rs-<k>``, ``tracks.corner_circuits``) through ``race_circuit``: training
circuits only, closed loops whose straights run into corners of one radius, a pure function of the name."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.tracks.corner_circuits import MIN_STRAIGHT_M, RADIUS_RANGE_M
from vtrack_gym.tracks.race_circuits import RACE_SPLIT, race_circuit
from vtrack_gym.tracks.table import COL_KAPPA


def constant_radius_entries(kappa: np.ndarray, ds_m: float) -> list[tuple[float, float]]:
    """(radius [m], length [m] of the blend from the last straight row) of every corner section of ``kappa``
    held constant for >= 5 m: where a straight (kappa 0) runs into a constant radius."""
    held = np.abs(np.diff(kappa)) < 1e-12
    entries, i, n = [], 1, kappa.size
    while i < n - 1:
        run = i
        while run < n - 1 and held[run] and abs(kappa[run]) > 1e-9:
            run += 1
        if (run - i) * ds_m >= 5.0:
            straight = np.flatnonzero(np.abs(kappa[:i]) < 1e-12)
            if straight.size:
                entries.append((1.0 / abs(kappa[i]), (i - straight[-1]) * ds_m))
        i = run + 1
    return entries


def test_only_the_training_group_holds_corner_circuits() -> None:
    train = RACE_SPLIT["train"]
    corners = [name for name in train if name.startswith("rs-")]
    assert len(corners) == 12 and train[0] == "rc-0" and len(set(train)) == len(train)
    assert all(train[3 * j + 2] == f"rs-{j}" for j in range(12))      # one after every two smooth loops
    assert [n for n in train if n.startswith("rc-")] == [f"rc-{k}" for k in range(24)]
    assert RACE_SPLIT["validation"] == tuple(f"rc-{k}" for k in range(24, 32))
    assert RACE_SPLIT["held_out"] == tuple(f"rc-{k}" for k in range(2000, 2004))


@pytest.mark.parametrize("name", ["rs-0", "rs-1"])
def test_a_corner_circuit_runs_straights_into_constant_radii(name: str) -> None:
    """Closed (once round, left for even seeds and right for odd), clear of itself, and every corner a constant
    radius in the recipe's range entered from a straight through a blend of at most 25 m."""
    path = race_circuit(name)
    kappa = path.table[:, COL_KAPPA]
    assert path.closed and not path.self_intersects(clearance_m=7.0)
    turns = float(np.sum(kappa) * path.ds_m / (2.0 * math.pi))
    assert turns == pytest.approx(1.0 if name == "rs-0" else -1.0, abs=1e-3)
    entries = constant_radius_entries(kappa, path.ds_m)
    assert len(entries) >= 4
    assert all(RADIUS_RANGE_M[0] - 1e-6 <= r <= RADIUS_RANGE_M[1] + 1e-6 for r, _ in entries)
    assert all(0.0 < blend <= 25.0 + path.ds_m for _, blend in entries)
    straight_rows = np.abs(kappa) < 1e-12
    assert np.count_nonzero(straight_rows) * path.ds_m >= 4 * MIN_STRAIGHT_M
    assert np.array_equal(path.table, race_circuit(name).table)       # a pure function of the name


def test_a_smooth_loop_has_no_constant_radius() -> None:
    """What the corner circuits add: the smooth loops' curvature is never held at one radius."""
    path = race_circuit("rc-0")
    assert constant_radius_entries(path.table[:, COL_KAPPA], path.ds_m) == []


def test_circuit_names_are_refused_outside_their_forms() -> None:
    with pytest.raises(ValueError, match="rc-<k> or rs-<k>"):
        race_circuit("rs-x")
