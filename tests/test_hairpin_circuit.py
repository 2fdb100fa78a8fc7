"""Every default baseline laps a compact circuit with 6 m hairpins from a user's CSV file (issue 16), through the
public entry points: ``gym.make("vtrack/Track-v0", track=<csv>, speed_profile=curvature_limited(40 km/h, 0.7 g))``,
``vtrack_gym.make_policy`` and the plain Gymnasium loop."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.baselines.registry import available_policies
from vtrack_gym.tracks import CurvatureLimited

MAX_E_Y_M = 0.5
"""Bound on max |e_y| [m] of every default baseline (measured: smc 0.07, mpc 0.26, lqr 0.16, stanley 0.10,
pure_pursuit 0.37, mpc_osqp 0.25; before the rate-limit anticipation and the low-speed fixes smc 0.77 and
pure_pursuit 0.97)."""


def _pose(segments: list[tuple[float, float]], s: float) -> tuple[float, float, float]:
    """(x, y, heading) [m, m, rad] at arc length ``s`` [m] along (length [m], curvature [1/m]) pieces from the
    origin heading east."""
    x = y = psi = 0.0
    for length, kappa in segments:
        h = min(s, length)
        if kappa == 0.0:
            x, y = x + h * math.cos(psi), y + h * math.sin(psi)
        else:
            p = psi + kappa * h
            x, y = x + (math.sin(p) - math.sin(psi)) / kappa, y - (math.cos(p) - math.cos(psi)) / kappa
            psi = p
        s -= h
        if s <= 0.0:
            break
    return x, y, psi


def _hairpin_circuit(file: Path, spacing_m: float = 2.0, chicane: bool = False) -> Path:
    """A 270 m counter-clockwise loop: 10 m corner, a left and a right 6 m hairpin back to back, 8 m and 10 m
    corners; the last two straights are solved so that it closes exactly. ``chicane``: a 15 m left-right-left
    chicane (35, 70, 35 deg) and 40 m more straight after the first straight. Written as x, y, right/left widths."""
    quarter, half = 0.5 * math.pi, math.pi
    bend = math.radians(35.0) * 15.0
    s_bends = [(bend, 1 / 15), (2.0 * bend, -1 / 15), (bend, 1 / 15), (40.0, 0.0)] if chicane else []
    head = [(60.0, 0.0), *s_bends, (quarter * 10.0, 0.1), (20.0, 0.0), (half * 6.0, 1 / 6), (12.0, 0.0),
            (half * 6.0, -1 / 6), (20.0, 0.0), (quarter * 8.0, 0.125)]
    x, y, _ = _pose(head, math.inf)
    # then west, left 10 m corner (10 m west, 10 m south), south, left 8 m corner (8 m south, 8 m east)
    west = x - 10.0 + 8.0
    south = y - 8.0 - 10.0
    assert west > 10.0 and south > 10.0
    segments = [*head, (west, 0.0), (quarter * 10.0, 0.1), (south, 0.0), (quarter * 8.0, 0.125)]
    total = sum(length for length, _ in segments)
    end = _pose(segments, math.inf)
    assert math.hypot(end[0], end[1]) < 1e-9
    s = np.arange(0.0, total - 0.5 * spacing_m, spacing_m)
    xy = np.array([_pose(segments, float(v))[:2] for v in s])
    rows = np.column_stack([xy, np.full(len(s), 4.0), np.full(len(s), 4.5)])
    np.savetxt(file, rows, fmt="%.3f", delimiter=",", header="x_m, y_m, w_tr_right_m, w_tr_left_m")
    return file


@pytest.fixture(scope="module")
def circuit(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _hairpin_circuit(tmp_path_factory.mktemp("hairpin") / "hairpin_circuit.csv")


def _lap(file: Path, name: str) -> tuple[dict, float]:
    """One episode of the default ``name`` on ``file`` with curvature_limited(40 km/h, 0.7 g) through the plain
    Gymnasium loop: (last info, max |e_y| [m])."""
    env = gym.make("vtrack/Track-v0", track=str(file), speed_profile=CurvatureLimited(40.0 / 3.6, 0.7 * 9.81))
    policy = vtrack_gym.make_policy(name, env)
    obs, info = env.reset(seed=0)
    max_e_y = 0.0
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = env.step(action)
        max_e_y = max(max_e_y, abs(info["e_y_m"]))
    env.close()
    return info, max_e_y


@pytest.mark.parametrize("name", available_policies())
def test_default_baseline_laps_a_6m_hairpin_circuit(name: str, circuit: Path) -> None:
    info, max_e_y = _lap(circuit, name)
    assert info["termination"] == "completed", f"{name}: {info['termination']} at {info['time_s']:.1f} s"
    assert info["success"] is True
    assert info["progress_m"] > 250.0
    assert max_e_y < MAX_E_Y_M, f"{name}: max |e_y| {max_e_y:.3f} m"


@pytest.mark.parametrize("spacing_m", [1.0, 0.5])
def test_mpc_laps_a_densely_sampled_circuit_with_a_chicane(spacing_m: float, tmp_path: Path) -> None:
    """Points every 1 m or 0.5 m keep the arc/straight curvature steps sharp (the 2 m file's spline rounds them
    over about 3 m). The MPC then laps only with the rate-limit anticipation and the front slip bound (before:
    off the road at the chicane's exit at both spacings; measured after: max |e_y| 0.23 m at 1 m, 0.39 m at
    0.5 m)."""
    info, max_e_y = _lap(_hairpin_circuit(tmp_path / "chicane_circuit.csv", spacing_m, chicane=True), "mpc")
    assert info["termination"] == "completed", f"mpc at {spacing_m} m: {info['termination']} at {info['time_s']:.1f} s"
    assert info["success"] is True
    assert info["progress_m"] > 300.0
    assert max_e_y < MAX_E_Y_M, f"mpc at {spacing_m} m: max |e_y| {max_e_y:.3f} m"


SMC_CHICANE_MAX_E_Y_M = 1.0
"""Bound on the default SMC's max |e_y| [m] round the densely sampled chicane circuit (measured: 0.81 m at 1 m, 0.52 m
at 0.5 m spacing; lqr 0.23 / 0.22). Issue 16's 0.5 m is NOT met here: the SMC has no steer feedforward and its
stiff state feedback (2.06 rad of steer per metre of e_y) overshoots whenever the 0.87 rad/s actuator falls behind
it through a curvature reversal (README, "own circuits"). A regression guard at today's level, not a target."""


@pytest.mark.parametrize("spacing_m", [1.0, 0.5])
def test_smc_laps_a_densely_sampled_circuit_with_a_chicane(spacing_m: float, tmp_path: Path) -> None:
    info, max_e_y = _lap(_hairpin_circuit(tmp_path / "chicane_circuit.csv", spacing_m, chicane=True), "smc")
    assert info["termination"] == "completed", f"smc at {spacing_m} m: {info['termination']} at {info['time_s']:.1f} s"
    assert info["success"] is True
    assert info["progress_m"] > 300.0
    assert max_e_y < SMC_CHICANE_MAX_E_Y_M, f"smc at {spacing_m} m: max |e_y| {max_e_y:.3f} m"
