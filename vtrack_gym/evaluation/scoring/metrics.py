"""Metrics as pure functions of a ``Trace`` (the paper's eqs. 45-49, ITAE, GA constraints, ISO 2631-1, speed and
time errors against the timed reference, lap times).

Units of the returned numbers are in their names (``_m``, ``_deg``, ``_mps2``, ``_n``); ``itae`` is the
integral of t |e_y| dt in m s^2.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vtrack_gym.evaluation.scoring.trace import Trace

A_Y_LIMIT_MPS2 = 8.83
"""The paper's GA constraint on the lateral acceleration (mu g with mu = 0.9) [m/s^2]."""

REVERSAL_GAP_DEG = 2.0
"""CHOICE: a steering reversal counts once the hand-wheel has turned back by this much [deg] from its last extremum
(the gap of the driving-research steering reversal rate). No low-pass filter first: the metric exists to show a
steering wiggle, which a filter would hide."""



CLOCK_MEASURED: tuple[str, ...] = ("wall_time_per_step_s", "policy_time_p50_us", "policy_time_p95_us",
                                   "policy_time_max_us", "policy_real_time_factor", "late_decision_share",
                                   "max_latency_ms")
"""Metrics measured from the clock (the machine's speed, not the episode's): the only metrics two runs of the same
episode may differ in (with ``latency="measured"`` the compute charged moves the whole episode)."""

def rms(values: np.ndarray, time_s: np.ndarray | None = None) -> float:
    """Root mean square sqrt((1/T) int x^2 dt) (trapezoid on ``time_s``; plain mean for uniform samples)."""
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return math.nan
    if time_s is None or x.size < 2:
        return float(np.sqrt(np.mean(x * x)))
    t = np.asarray(time_s, dtype=np.float64)
    span = t[-1] - t[0]
    return float(np.sqrt(np.trapezoid(x * x, t) / span)) if span > 0 else float(np.sqrt(np.mean(x * x)))


def max_abs(values: np.ndarray) -> float:
    """Largest absolute value (nan for an empty series)."""
    x = np.asarray(values, dtype=np.float64)
    return float(np.max(np.abs(x))) if x.size else math.nan


def itae(time_s: np.ndarray, e_y_m: np.ndarray) -> float:
    """ITAE J = int_0^T t |e_y(t)| dt [m s^2] (paper-math section 8's fix of eq. 40; trapezoid rule)."""
    t = np.asarray(time_s, dtype=np.float64)
    return float(np.trapezoid(t * np.abs(np.asarray(e_y_m, dtype=np.float64)), t)) if t.size > 1 else 0.0


def paper_metrics(trace: Trace) -> dict[str, float]:
    """Case-1 RMS set (eqs. 45-49) and Case-2 max set of hand-wheel angle, e_y, e_phi, a_y, roll."""
    t = trace["time_s"]
    series = {
        "hand_wheel_deg": np.degrees(trace["hand_wheel_angle_rad"]),
        "e_y_m": trace["e_y_m"],
        "e_phi_deg": np.degrees(trace["e_phi_rad"]),
        "a_y_mps2": trace["a_y_mps2"],
        "roll_deg": np.degrees(trace["roll_rad"]),
    }
    out: dict[str, float] = {}
    for name, x in series.items():
        out[f"rms_{name}"] = rms(x, t)
        out[f"max_{name}"] = max_abs(x)
    return out


def constraint_metrics(trace: Trace, a_y_limit_mps2: float = A_Y_LIMIT_MPS2) -> dict[str, float]:
    """The GA's constraints: max |a_y| <= limit and every wheel load > 0 (at the physics rate)."""
    max_ay = max_abs(trace["a_y_mps2"])
    min_fz = float(np.min(trace["min_fz_n"])) if trace.n_steps else math.nan
    return {
        "max_abs_a_y_mps2": max_ay,
        "min_fz_n": min_fz,
        "a_y_violation_mps2": max(0.0, max_ay - a_y_limit_mps2),
        "constraints_ok": float(max_ay <= a_y_limit_mps2 and min_fz > 0.0),
    }


def comfort_metrics(trace: Trace, k: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> dict[str, Any]:
    """ISO 2631-1 comfort from the physics-rate accelerations: the overall vibration total value a_v [m/s^2], its
    comfort band, and the longitudinal weighted RMS ``comfort_a_wx_mps2`` = k_x a_wx [m/s^2] (W_d on a_x, k_x =
    ``k[0]``, 1 for comfort on the seat surface like a_v's; NaN on a record shorter than a second)."""
    from vtrack_gym.evaluation.scoring import iso2631

    acc = trace.acc_physics_mps2
    fs = trace.physics_rate_hz
    if acc.shape[0] < int(fs):  # shorter than a second: weighting filters are meaningless
        return {"comfort_a_v_mps2": math.nan, "comfort_band": "n/a", "comfort_a_wx_mps2": math.nan}
    a_v, a_w = iso2631.vibration_axes(acc[:, 0], acc[:, 1], acc[:, 2], fs, k=k)   # a_x weighted once
    a_wx = float(k[0]) * a_w[0]
    return {"comfort_a_v_mps2": float(a_v), "comfort_band": iso2631.comfort_band(a_v), "comfort_a_wx_mps2": a_wx}


def reversal_count(angle: np.ndarray, gap: float) -> int:
    """Direction reversals of a signal larger than ``gap`` (same unit): a reversal counts when the signal has moved
    back by at least ``gap`` from the extremum reached since the previous one (the first turn sets the direction and
    is not a reversal)."""
    values = np.asarray(angle, dtype=np.float64)
    if values.size < 2:
        return 0
    count, direction, extremum = 0, 0, float(values[0])
    low = high = extremum
    for v in values[1:].tolist():
        if direction == 0:  # no direction yet: wait for the first move of a gap either way
            low, high = min(low, v), max(high, v)
            if high - v >= gap:
                direction, extremum = -1, v
            elif v - low >= gap:
                direction, extremum = 1, v
        elif direction > 0:
            if v > extremum:
                extremum = v
            elif extremum - v >= gap:
                count, direction, extremum = count + 1, -1, v
        elif v < extremum:
            extremum = v
        elif v - extremum >= gap:
            count, direction, extremum = count + 1, 1, v
    return count


def smoothness_metrics(trace: Trace, gap_deg: float = REVERSAL_GAP_DEG) -> dict[str, float]:
    """Hand-wheel reversals larger than ``gap_deg`` per second of driving [1/s]: a driver's few per second at most
    in a lane change; a policy chattering between left and right shows tens (an ISO 2631-1 comfort value, weighted
    towards 0.5-2 Hz, barely sees a 25 Hz wiggle)."""
    duration = float(trace["time_s"][-1]) if trace.n_steps else 0.0
    if duration <= 0.0:
        return {"steering_reversals_per_s": math.nan}
    count = reversal_count(np.degrees(trace["hand_wheel_angle_rad"]), gap_deg)
    return {"steering_reversals_per_s": count / duration}


def speed_metrics(trace: Trace) -> dict[str, float]:
    """Speed tracking error e_v = v - v_ref [m/s] against the env's reference speed (``target_speed_mps``: the
    held speed on the paper scenarios, the profile's v_ref(s) at the car's station on a track with one): its
    time-weighted RMS ``rms_e_v_mps`` and its largest magnitude ``max_e_v_mps``, over every step of the episode.
    Under an ISO 3888 protocol the env shows the car's own speed as v_ref from the entry gate on (no speed loop
    acts there), so e_v = 0 after the gate: the figures measure the approach, the RMS spread over the whole
    episode's duration."""
    err = trace["v_mps"] - trace["target_speed_mps"]
    return {"rms_e_v_mps": rms(err, trace["time_s"]), "max_e_v_mps": max_abs(err)}


def timing_metrics(trace: Trace) -> dict[str, Any]:
    """The time error at the end ``time_lag_s`` [s] (positive: behind the timed reference) and, on a closed path,
    the lap figures (``reference_time.timing_metrics``; NaN when the trace has no reference)."""
    from vtrack_gym.evaluation.scoring.reference_time import timing_metrics as timed

    return timed(trace.reference, trace["time_s"], trace["progress_m"])


def _rate(values: np.ndarray, time_s: np.ndarray) -> np.ndarray:
    """Time derivative of a sampled signal (central differences, one-sided at the ends; empty below 2 samples)."""
    x = np.asarray(values, dtype=np.float64)
    t = np.asarray(time_s, dtype=np.float64)
    if x.size < 2 or not np.all(np.diff(t) > 0.0):
        return np.zeros(0)
    return np.gradient(x, t)


def control_metrics(trace: Trace) -> dict[str, float]:
    """The figures controllers are compared by (Autoware's control evaluator reports the same quantities), from the
    control-rate samples, by central differences: the hand-wheel angle's rate [deg/s] and acceleration [deg/s^2],
    the lateral jerk d(a_y)/dt [m/s^3] and the yaw-rate error d(e_phi)/dt [deg/s] (the car's yaw rate minus the
    path's at the projection, kappa ds/dt), each as its largest magnitude and its time-weighted RMS (NaN below
    two samples)."""
    t = trace["time_s"]
    steer = np.degrees(trace["hand_wheel_angle_rad"])
    rate = _rate(steer, t)
    series = {"steering_rate_degps": rate, "steering_acc_degps2": _rate(rate, t) if rate.size else rate,
              "lateral_jerk_mps3": _rate(trace["a_y_mps2"], t),
              "yaw_rate_error_degps": _rate(np.degrees(np.unwrap(trace["e_phi_rad"])), t)}
    out: dict[str, float] = {}
    for name, x in series.items():
        out[f"max_{name}"] = max_abs(x)
        out[f"rms_{name}"] = rms(x, t) if x.size else math.nan
    return out


SOLVER_TIME_STATS = {"preparation_s": "preparation_time", "feedback_s": "feedback_time", "qp_s": "qp_time"}
"""Per-decision solver times reported as p50/p95 [us] (``<name>_p50_us``), when the policy reports them."""
SOLVER_COUNT_STATS = {"qp_iterations": "qp_iterations", "sqp_iterations": "sqp_iterations",
                      "cold_starts": "cold_starts"}
"""Per-decision solver counts reported as their mean and maximum (``<name>_mean``, ``<name>_max``)."""


def solver_stat_metrics(stats: dict[str, np.ndarray]) -> dict[str, float]:
    """The solver statistics' columns: p50/p95 [us] of each time in ``SOLVER_TIME_STATS``, mean and maximum of each
    count in ``SOLVER_COUNT_STATS`` (only those the policy reported)."""
    out: dict[str, float] = {}
    for key, name in SOLVER_TIME_STATS.items():
        values = np.asarray(stats.get(key, ()), dtype=np.float64)
        if values.size:
            p50, p95 = np.percentile(values, (50.0, 95.0))
            out[f"{name}_p50_us"], out[f"{name}_p95_us"] = 1e6 * float(p50), 1e6 * float(p95)
    for key, name in SOLVER_COUNT_STATS.items():
        values = np.asarray(stats.get(key, ()), dtype=np.float64)
        if values.size:
            out[f"{name}_mean"], out[f"{name}_max"] = float(values.mean()), float(values.max())
    return out


def compute_metrics(trace: Trace) -> dict[str, float]:
    """The policy's own compute per decision (its ``predict`` call, not the env's step): median, 95th percentile
    and maximum [us], the real-time factor ``control period / p95`` (> 1: the policy decides faster than real
    time at the env's control period) and its failed solves (NaN when the trace has no timings or the policy
    reports no count), and the solver's own statistics when it reports them (``solver_stat_metrics``)."""
    times = np.asarray(trace.policy_time_s, dtype=np.float64)
    out = {"policy_time_p50_us": math.nan, "policy_time_p95_us": math.nan, "policy_time_max_us": math.nan,
           "policy_real_time_factor": math.nan,
           "solver_failures": math.nan if trace.solver_failures is None else float(trace.solver_failures)}
    out.update(solver_stat_metrics(trace.solver_stats))
    if times.size:
        p50, p95 = np.percentile(times, (50.0, 95.0))
        out.update({"policy_time_p50_us": 1e6 * float(p50), "policy_time_p95_us": 1e6 * float(p95),
                    "policy_time_max_us": 1e6 * float(times.max()),
                    "policy_real_time_factor": trace.control_period_s / float(p95) if p95 > 0 else math.inf})
    return out


def evaluate_trace(trace: Trace, cones_hit: int | None = None) -> dict[str, Any]:
    """Every metric of one trace, flat (what the leaderboard stores)."""
    out: dict[str, Any] = {
        "completed": float(trace.completed),
        "success": float(trace.success),
        "termination": trace.termination,
        "duration_s": float(trace["time_s"][-1]) if trace.n_steps else 0.0,
        "progress_m": float(trace["progress_m"][-1]) if trace.n_steps else 0.0,
        "itae": itae(trace["time_s"], trace["e_y_m"]),
        "wall_time_per_step_s": trace.wall_time_per_step_s,
    }
    out.update(paper_metrics(trace))
    out.update(speed_metrics(trace))
    out.update(timing_metrics(trace))
    out.update(smoothness_metrics(trace))
    out.update(control_metrics(trace))
    out.update(constraint_metrics(trace))
    out.update(comfort_metrics(trace))
    out.update(compute_metrics(trace))
    if cones_hit is not None:
        out["cones_hit"] = float(cones_hit)
    return out
