"""Metrics on synthetic traces with known answers (constants, sines, ramps)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.evaluation.scoring.metrics import (
    constraint_metrics,
    itae,
    max_abs,
    paper_metrics,
    reversal_count,
    rms,
    smoothness_metrics,
)
from vtrack_gym.evaluation.scoring.trace import STEP_SIGNALS, Trace


def synthetic_trace(duration_s: float = 10.0, dt: float = 0.01, **signals: np.ndarray) -> Trace:
    t = np.arange(1, round(duration_s / dt) + 1) * dt
    data = {name: np.zeros_like(t) for name in STEP_SIGNALS}
    data["time_s"] = t
    data["min_fz_n"] = np.full_like(t, 3000.0)
    for name, values in signals.items():
        data[name] = values(t) if callable(values) else np.broadcast_to(values, t.shape).astype(float)
    n_sub = 5
    return Trace("test", "synthetic", 0, data, np.full((t.size, 4), 3000.0), np.zeros((t.size * n_sub, 3)),
                 n_sub / dt, dt, "completed", 1e-5)


def test_rms_of_constant_and_sine() -> None:
    t = np.linspace(0.0, 10.0, 100001)
    assert rms(np.full_like(t, -0.3), t) == pytest.approx(0.3, rel=1e-12)
    assert rms(2.0 * np.sin(2 * math.pi * 1.0 * t), t) == pytest.approx(2.0 / math.sqrt(2.0), rel=1e-6)
    assert max_abs(np.array([0.1, -0.7, 0.3])) == 0.7


def test_itae_of_constant_and_ramp() -> None:
    t = np.linspace(0.0, 4.0, 40001)
    assert itae(t, np.full_like(t, 0.5)) == pytest.approx(0.5 * 4.0**2 / 2, rel=1e-9)  # int t*0.5 dt = 4
    assert itae(t, -0.1 * t) == pytest.approx(0.1 * 4.0**3 / 3, rel=1e-6)              # int 0.1 t^2 dt
    assert itae(t, np.zeros_like(t)) == 0.0


def test_paper_metrics_units() -> None:
    trace = synthetic_trace(hand_wheel_angle_rad=lambda t: np.radians(100.0) * np.sin(2 * np.pi * t),
                            e_y_m=0.2, roll_rad=np.radians(2.0), a_y_mps2=lambda t: -3.0 * np.ones_like(t))
    m = paper_metrics(trace)
    assert m["max_hand_wheel_deg"] == pytest.approx(100.0, rel=1e-3)
    assert m["rms_hand_wheel_deg"] == pytest.approx(100.0 / math.sqrt(2.0), rel=1e-3)
    assert m["rms_e_y_m"] == pytest.approx(0.2) and m["max_e_y_m"] == pytest.approx(0.2)
    assert m["rms_roll_deg"] == pytest.approx(2.0) and m["max_a_y_mps2"] == pytest.approx(3.0)


def test_constraints() -> None:
    ok = constraint_metrics(synthetic_trace(a_y_mps2=8.0))
    assert ok["constraints_ok"] == 1.0 and ok["a_y_violation_mps2"] == 0.0
    bad = constraint_metrics(synthetic_trace(a_y_mps2=9.0))
    assert bad["constraints_ok"] == 0.0 and bad["a_y_violation_mps2"] == pytest.approx(0.17)
    lift = constraint_metrics(synthetic_trace(min_fz_n=lambda t: 100.0 - 20.0 * t))
    assert lift["constraints_ok"] == 0.0 and lift["min_fz_n"] < 0.0


@pytest.mark.parametrize("freq_hz, amplitude_deg, expected_per_s", [
    (0.5, 30.0, 0.9),    # 2 f T - 1 reversals in T = 10 s (the first turn sets the direction)
    (3.0, 5.0, 5.9),
    (25.0, 1.5, 49.9),   # a 25 Hz wiggle of +-1.5 deg: peak to peak 3 deg > the 2 deg gap
    (25.0, 0.9, 0.0),    # peak to peak 1.8 deg < 2 deg: not counted
])
def test_steering_reversals_of_sines(freq_hz: float, amplitude_deg: float, expected_per_s: float) -> None:
    # sampled at 1 kHz so that every peak is resolved; a phase offset keeps samples off the exact peaks
    trace = synthetic_trace(dt=0.001, hand_wheel_angle_rad=lambda t: np.radians(amplitude_deg)
                            * np.sin(2 * np.pi * freq_hz * t + 0.3))
    assert smoothness_metrics(trace)["steering_reversals_per_s"] == pytest.approx(expected_per_s, abs=0.11)


def test_reversal_count_gap_and_ramps() -> None:
    assert reversal_count(np.array([0.0, 3.0, 1.0, 1.5, -2.0]), 2.0) == 1   # the 0.5 back-step is within the gap
    assert reversal_count(np.array([0.0, 3.0, 0.5, 4.0, 1.0]), 2.0) == 3
    assert reversal_count(np.linspace(0.0, 90.0, 1000), 2.0) == 0           # a steady turn-in never reverses
    assert reversal_count(np.array([5.0]), 2.0) == 0
    assert math.isnan(smoothness_metrics(synthetic_trace(duration_s=0.0))["steering_reversals_per_s"])


def test_control_metrics_of_sines_and_ramps() -> None:
    """Hand-wheel 20 deg sine at 0.5 Hz: rate 20 w, acceleration 20 w^2 (max; RMS / sqrt 2); a_y ramp 3 m/s^3;
    e_phi ramp 0.01 rad/s: a yaw-rate error of 0.573 deg/s. Through ``evaluate_trace`` (every row has them)."""
    from vtrack_gym.evaluation.scoring.metrics import control_metrics, evaluate_trace

    w = 2.0 * math.pi * 0.5
    trace = synthetic_trace(duration_s=20.0, dt=0.001,
                            hand_wheel_angle_rad=lambda t: math.radians(20.0) * np.sin(w * t),
                            a_y_mps2=lambda t: 3.0 * t, e_phi_rad=lambda t: 0.01 * t)
    m = control_metrics(trace)
    assert m["max_steering_rate_degps"] == pytest.approx(20.0 * w, rel=1e-4)
    assert m["rms_steering_rate_degps"] == pytest.approx(20.0 * w / math.sqrt(2.0), rel=1e-3)
    assert m["max_steering_acc_degps2"] == pytest.approx(20.0 * w * w, rel=1e-3)
    assert m["rms_steering_acc_degps2"] == pytest.approx(20.0 * w * w / math.sqrt(2.0), rel=1e-3)
    assert m["max_lateral_jerk_mps3"] == pytest.approx(3.0, rel=1e-9)
    assert m["rms_lateral_jerk_mps3"] == pytest.approx(3.0, rel=1e-9)
    assert m["max_yaw_rate_error_degps"] == pytest.approx(math.degrees(0.01), rel=1e-9)
    import dataclasses

    assert set(m) <= set(evaluate_trace(dataclasses.replace(trace, success=True)))
    one = control_metrics(synthetic_trace(duration_s=0.01, dt=0.01))
    assert all(math.isnan(v) for v in one.values())
