"""The compiled PD-FLC step used inside the env equals the numpy reference controller."""

from __future__ import annotations

import numpy as np
import pytest

from vtrack_gym.envs.pdflc import PDFLC, PDFLCConfig
from vtrack_gym.envs.pdflc_kernel import pdflc_gains, pdflc_step


@pytest.mark.parametrize("method", ["mamdani", "sugeno"])
def test_kernel_matches_numpy_controller(method: str) -> None:
    from vtrack_gym.envs.pdflc import control_surface

    config = PDFLCConfig(method=method)
    dt = 0.01
    reference = PDFLC(config, 1, dt)
    reference.reset()
    gains = pdflc_gains(config, dt)
    surface = np.ascontiguousarray(control_surface(method, config.surface_resolution))
    mem = np.array([0.0, 0.0, 1.0])
    rng = np.random.default_rng(0)
    v = 0.0
    for _ in range(3000):  # random speed walk across every fuzzy cell, saturations included
        v = max(0.0, v + rng.normal(0.0, 0.3))
        v_ref = 11.11 if rng.random() > 0.01 else rng.uniform(0.0, 30.0)
        t_ref, b_ref = reference(np.array([v]), np.array([v_ref]))
        t_k, b_k = pdflc_step(v, v_ref, mem, gains, surface, method == "mamdani")
        assert t_k == pytest.approx(t_ref[0], abs=1e-12)
        assert b_k == pytest.approx(b_ref[0], abs=1e-9)
