"""Planned lines of the second version (tracks.exact_line) and the exact gate judge (tracks.gate_judge)."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import brentq

from vtrack_gym.tracks.exact_line import plan_exact_line
from vtrack_gym.tracks.gate_judge import path_gate_clearance_m, rect_gate, sweep_gate
from vtrack_gym.tracks.lanes import LaneSection
from vtrack_gym.tracks.planned_line import BodyRectangle

BODY = np.array([2.0, -3.0, 1.0])                   # front, rear, half width [m]
GATE = np.array([10.0, 0.0, 0.0, 5.0, 1.5, -1.5])   # lane from x = 10 m, 5 m long, cone lines at y = +-1.5 m
SMALL = BodyRectangle(0.6, 0.6, 0.3, "small body")
SWITCHED_OFF = "X86_V4 AVX512_ICL AVX512_SPR AVX512_SKX"


def test_a_centred_body_clears_both_cone_lines_by_the_slack() -> None:
    assert rect_gate(12.0, 0.0, 0.0, *BODY, GATE) == pytest.approx(0.5, abs=1e-12)
    assert rect_gate(12.0, 0.501, 0.0, *BODY, GATE) == pytest.approx(-0.001, abs=1e-12)   # 1 mm into the line
    assert rect_gate(12.0, -0.499, 0.0, *BODY, GATE) == pytest.approx(0.001, abs=1e-12)


def test_a_yawed_body_at_the_lane_end_is_measured_to_the_first_cone() -> None:
    """The rear-right corner lies before the lane (x < 10): the nearest cone-line point is the first cone
    (10, -1.5), whose distance to the body's right side is its vertical gap times cos(psi)."""
    psi = 0.1
    rr_x = 12.0 - 3.0 * math.cos(psi) + math.sin(psi)
    assert rr_x < 10.0
    side_y = -3.0 * math.sin(psi) - math.cos(psi) + (10.0 - rr_x) * math.tan(psi)
    assert rect_gate(12.0, 0.0, psi, *BODY, GATE) == pytest.approx((side_y + 1.5) * math.cos(psi), abs=1e-12)


def test_a_body_beside_the_lane_before_it_starts_is_clear() -> None:
    assert rect_gate(7.0, 2.0, 0.0, *BODY, GATE) == pytest.approx(1.0, abs=1e-12)   # its front 1 m before the cones


def test_a_crossing_between_two_steps_is_found() -> None:
    """Both poses are clear (outside the lane's length), the body crosses the left cone line in between."""
    before, after = np.array([5.0, 2.0, 0.0]), np.array([20.0, 2.0, 0.0])
    assert rect_gate(*before, *BODY, GATE) > 0.0 and rect_gate(*after, *BODY, GATE) > 0.0
    assert sweep_gate(before, after, BODY, GATE, 1e-3, 0.05) == pytest.approx(-1.5, abs=1e-3)
    grazing = sweep_gate(np.array([0.0, 0.0, 0.0]), np.array([30.0, 0.7, 0.0]), BODY, GATE, 1e-4, 1.0)
    assert grazing == pytest.approx(1.5 - (1.0 + 0.7 * 18.0 / 30.0), abs=1e-4)   # rear-left corner at x = 15


def _lane_change(scale: float = 1.0, margin_m: float = 0.0):
    lanes = [LaneSection(20.0 * scale, (0.6 + 0.02) * scale, 0.0, "lane 1"),
             LaneSection(20.0 * scale, (0.6 + 0.02) * scale, 2.0 * scale, "lane 2")]
    body = BodyRectangle(0.6 * scale, 0.6 * scale, 0.3 * scale, "small body")
    return plan_exact_line(lanes, [60.0 * scale], body, approach_m=10.0 * scale, run_out_m=10.0 * scale,
                           margin_m=margin_m)


def _bang_bang_peak_curvature(dy_m: float, gap_m: float, slack_m: float) -> float:
    """Least peak curvature of a point leaving |y| <= slack (x <= 0) into |y - dy| <= slack (x >= gap), zero
    heading in both (small angles): a parabola per half of the gap (see test_planned_line)."""
    return brentq(lambda k: -slack_m + 0.5 * k * (0.5 * gap_m + 2.0 * math.sqrt(slack_m / k)) ** 2 - 0.5 * dy_m,
                  1e-7, 1.0)


def test_lane_change_reaches_the_bang_bang_peak_and_clears_the_cones_exactly() -> None:
    line = _lane_change()
    expected = _bang_bang_peak_curvature(2.0, 60.0, 0.01)
    assert line.peak_curvature_per_m == pytest.approx(expected, rel=5e-3)
    assert line.peak_curvature_per_m >= expected * (1.0 - 5e-3)
    assert line.clearance_m >= -2e-4
    row = np.array([0.3, -0.3, 0.3])
    assert np.min(path_gate_clearance_m(line.path, row)) >= -1e-3    # through the path's own interpolation too


def test_one_line_for_inputs_a_last_bit_apart() -> None:
    """A relative 1e-12 change of every input moves the line by far less than 1e-6 m: one optimum, found to the
    last bits of its active set's linear system."""
    a, b = _lane_change(), _lane_change(1.0 + 1e-12)
    ya, yb = a.path.table[:, 1], np.interp(a.path.table[:, 0], b.path.table[:, 0], b.path.table[:, 1])
    assert np.max(np.abs(ya - yb)) < 1e-6


def test_the_line_holds_without_numpys_avx512_code() -> None:
    """The same line in a fresh interpreter with numpy's AVX-512 code paths switched off (another CPU's code)."""
    code = ("import json; from tests.test_exact_line import _lane_change; "
            "print(json.dumps(_lane_change().path.table[:, 1].tolist()))")
    env = {**os.environ, "NPY_DISABLE_CPU_FEATURES": SWITCHED_OFF}
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=root,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    import json

    other = np.array(json.loads(done.stdout.strip().splitlines()[-1]))
    assert np.max(np.abs(other - _lane_change().path.table[:, 1])) < 1e-6


def test_the_exact_curvature_is_the_tables_at_its_rows_and_never_below_between_them() -> None:
    line = _lane_change()
    t = line.path.table
    assert np.allclose(line.kappa_at(line.path.s_m), t[:, 3], atol=1e-12)
    s = np.linspace(0.0, line.path.length_m, 20001)
    assert np.max(np.abs(line.kappa_at(s))) == pytest.approx(line.peak_curvature_per_m, rel=1e-4)


def test_bad_input_is_refused_naming_the_field() -> None:
    lanes = [LaneSection(20.0, 0.62, 0.0), LaneSection(20.0, 0.62, 2.0)]
    with pytest.raises(ValueError, match=r"margin_m must be in \[0, 0.5\] m"):
        plan_exact_line(lanes, [60.0], SMALL, approach_m=10.0, run_out_m=10.0, margin_m=-0.1)
    with pytest.raises(ValueError, match="does not fit"):
        plan_exact_line(lanes, [60.0], SMALL, approach_m=10.0, run_out_m=10.0, margin_m=0.02)
    with pytest.raises(ValueError, match="one gap between consecutive lanes"):
        plan_exact_line(lanes, [], SMALL, approach_m=10.0, run_out_m=10.0)


@pytest.mark.slow
def test_the_v2_env_judges_its_gates_exactly_as_the_offline_judge() -> None:
    """Through ``gym.make``: a car steering a fixed small angle leaves a lane; the env's live judge (swept between
    control steps) and the offline sweep of the recorded poses agree on every gate and on the least clearance."""
    import gymnasium as gym

    import vtrack_gym  # noqa: F401
    from vtrack_gym.tracks.gate_judge import gate_table, judge_gates

    env = gym.make("vtrack/ISO3888-2-v2", entry_speed_kmh=40.0)
    _, info = env.reset(seed=0)
    poses = [(info["x_m"], info["y_m"], info["psi_rad"])]
    done = False
    while not done:
        _, _, term, trunc, info = env.step(np.array([0.004], dtype=np.float32))
        poses.append((info["x_m"], info["y_m"], info["psi_rad"]))
        done = term or trunc
    live = env.unwrapped.success_metrics()
    path, c = env.unwrapped.current_path, env.unwrapped.config.vehicle.chassis
    env.close()
    body = np.array([c.cg_to_front_end_m, c.cg_to_front_end_m - c.body_length_m, 0.5 * c.body_width_m])
    gates = gate_table(path.gates)
    p = np.array(poses, dtype=float)
    hit, least = np.zeros((1, len(gates)), dtype=bool), np.full(1, np.inf)
    for k in range(1, p.shape[0]):   # the same kernel, step by step over the recorded poses
        judge_gates(gates, body, np.zeros(1, dtype=np.int64), p[k - 1:k], p[k:k + 1, 0], p[k:k + 1, 1],
                    p[k:k + 1, 2], 1e-3, hit, least)
    offline = path_gate_clearance_m(path, body, tol=1e-3, pose=(p[:, 0], p[:, 1], p[:, 2]), floor_m=0.05)
    assert live["cones_hit"] == np.count_nonzero(hit) == np.count_nonzero(offline < 0.0) >= 1
    assert live["min_gate_clearance_m"] == pytest.approx(float(least[0]), abs=1e-9)
    assert live["min_gate_clearance_m"] == pytest.approx(float(np.min(offline)), abs=2e-3)


def test_the_working_set_solve_is_the_solve_over_all_rows() -> None:
    """The least-distance problem solved over a growing working set of rows has the optimum of the one over all
    rows (strictly convex: one optimum), and a working set that is infeasible reports the whole as infeasible."""
    from vtrack_gym.tracks.exact_line import _least_distance, _nnls_distance

    rng = np.random.default_rng(3)
    g = rng.normal(size=(4000, 30))
    g /= np.linalg.norm(g, axis=1)[:, None]
    h = g @ rng.normal(size=30) + rng.uniform(0.0, 2.0, size=4000)   # feasible; the origin is not
    full = _nnls_distance(g, h)
    worked = _least_distance(g, h, np.zeros(30))
    assert full is not None and worked is not None
    assert np.max(g @ worked - h) <= 1e-12
    np.testing.assert_allclose(worked, full, rtol=0.0, atol=1e-10)
    both = np.vstack((g[:1], -g[:1]))
    assert _least_distance(both, np.array([-1.0, -1.0]), np.zeros(30)) is None   # g0 x <= -1 and g0 x >= 1
