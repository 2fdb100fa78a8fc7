"""The PD-FLC's Mamdani table: the compiled aggregation gives the bits of the level-by-level numpy reference."""

from __future__ import annotations

import numpy as np
import pytest

from vtrack_gym.envs.pdflc import _centroid_grid, _flat_inputs, _rule_heights, control_surface, mamdani_direct
from vtrack_gym.envs.pdflc_aggregate import grid_cover


def _reference_mamdani(e_hat: np.ndarray, de_hat: np.ndarray, chunk: int = 1024) -> np.ndarray:
    """The inference as first written (each clipped output triangle max-ed into the aggregate in turn)."""
    e, de, shape = _flat_inputs(e_hat, de_hat)
    y, tri, support = _centroid_grid()
    out = np.empty(e.size)
    for start in range(0, e.size, chunk):
        heights = _rule_heights(e[start:start + chunk], de[start:start + chunk])
        mu = np.zeros((heights.shape[0], y.size))
        for k, (lo, hi) in enumerate(support):
            np.maximum(mu[:, lo:hi], np.minimum(heights[:, k, None], tri[k, lo:hi]), out=mu[:, lo:hi])
        out[start:start + chunk] = (mu @ y) / mu.sum(axis=1)
    return out.reshape(shape)


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


@pytest.mark.parametrize("resolution", [201, 9])
def test_control_surface_is_bit_identical_to_the_reference(resolution: int) -> None:
    g = np.linspace(-1.0, 1.0, resolution)
    e, de = np.meshgrid(g, g, indexing="ij")
    assert _same_bits(control_surface("mamdani", resolution), _reference_mamdani(e, de))


def test_direct_inference_is_bit_identical_off_the_grid() -> None:
    rng = np.random.default_rng(3)
    e = rng.uniform(-1.2, 1.2, 3000)  # beyond the universe too (clipped memberships)
    de = rng.uniform(-1.2, 1.2, 3000)
    for chunk in (1024, 77):
        assert _same_bits(mamdani_direct(e, de, chunk=chunk), _reference_mamdani(e, de, chunk=chunk))
    assert _same_bits(mamdani_direct(0.3, -0.7), _reference_mamdani(np.float64(0.3), np.float64(-0.7)))


def test_grid_cover_lists_every_non_zero_triangle() -> None:
    _, tri, support = _centroid_grid()
    levels, tops = grid_cover(tri, support)
    rebuilt = np.zeros_like(tri)
    for c in range(levels.shape[1]):
        np.maximum.at(rebuilt, (levels[:, c], np.arange(tri.shape[1])), tops[:, c])
    assert np.array_equal(rebuilt, tri)
    with pytest.raises(ValueError, match="overlap"):
        grid_cover(np.ones((3, 5)), ((0, 5), (0, 5), (0, 5)))
