"""The env's tables carry cos and sin of each row's heading; the projection and the row interpolation read them
instead of computing them, with the same bits as computing them (the observations keep theirs)."""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym.envs import kernels as k
from vtrack_gym.envs.config import EnvConfig
from vtrack_gym.envs.scenarios import resolve_scenario
from vtrack_gym.envs.sim import BatchSim
from vtrack_gym.tracks.kernels import interp_row, project_point


def _track(scenario: str) -> tuple[np.ndarray, float, float, bool]:
    sim = BatchSim(resolve_scenario(scenario), EnvConfig(), 1)
    meta = sim.tracks.meta[0]
    start, rows = int(meta[k.TM_START]), int(meta[k.TM_N])
    return sim.tracks.tables[start:start + rows], meta[k.TM_DS], meta[k.TM_LEN], bool(meta[k.TM_CLOSED])


def test_the_columns_hold_the_headings_cos_and_sin() -> None:
    table, *_ = _track("LateralTracking-v0")
    np.testing.assert_array_equal(table[:, k.C_COS], [math.cos(p) for p in table[:, k.C_PSI].tolist()])
    np.testing.assert_array_equal(table[:, k.C_SIN], [math.sin(p) for p in table[:, k.C_PSI].tolist()])


def test_reading_them_gives_the_same_bits() -> None:
    rng = np.random.default_rng(7)
    for scenario in ("LateralTracking-v0", "DLC120-v0"):
        table, ds, length, closed = _track(scenario)
        computed, read = np.empty(table.shape[1]), np.empty(table.shape[1])
        for s in rng.uniform(-5.0, length + 5.0, 400):
            interp_row(table, ds, length, closed, s, computed)
            interp_row(table, ds, length, closed, s, read, k.C_COS)
            np.testing.assert_array_equal(read[:k.N_COLS], computed[:k.N_COLS])
            x, y = computed[k.C_X] + rng.normal(0.0, 2.0), computed[k.C_Y] + rng.normal(0.0, 2.0)
            guess = s + rng.normal(0.0, 1.0)
            assert project_point(table, ds, length, closed, x, y, guess, 6.0) == \
                project_point(table, ds, length, closed, x, y, guess, 6.0, k.C_COS)


def test_a_station_inside_the_lap_wraps_to_the_formulas_bits() -> None:
    """``wrap_s`` returns a closed path's station inside the lap without the division: the formula's bits."""
    from vtrack_gym.tracks.kernels import INSIDE_LAP, wrap_s

    rng = np.random.default_rng(3)
    for length in (215.7, 1.0, 3.3e4):
        edge = INSIDE_LAP * length
        stations = [*rng.uniform(0.0, length, 2000), np.nextafter(edge, 0.0), edge, np.nextafter(edge, 2 * edge),
                    np.nextafter(length, 0.0), 5e-324, 0.0, -0.0, -1e-9, length, length + 1e-9]
        for s in stations:
            w = s - math.floor(s / length) * length
            expected = 0.0 if (w >= length or w < 0.0) else w
            got = wrap_s(s, length, True)
            assert got == expected and math.copysign(1.0, got) == math.copysign(1.0, expected), (length, s)
