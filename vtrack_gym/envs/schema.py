"""The ``info`` schema shared by the single env, the vector env, the highway-env adapter and ``Trace``.

Every env of the package returns the same keys at ``reset()`` and at every ``step()`` (``INFO_KEYS``, in this
order), with stable types: the single env and the adapter give ``numpy.float64`` scalars, ``float64`` arrays
for ``fz_n`` (4,) and ``acc_substeps_mps2`` (n_sub, 3), a ``str`` termination and a ``bool`` success; the
vector env gives the same keys as (num_envs, ...) arrays (termination: an object array of ``str``, success a
``bool`` array) plus Gymnasium's ``_key`` masks.
The reward terms are 0 at reset (no step yet).

``ROW_SIGNALS`` + ``REWARD_TERMS`` are one float64 row per car that the compiled step writes (``envs.kernels``,
``SIG_*`` offsets derived from these names); ``time_s`` is the car's step count times the control period.
All units SI (m, rad, s, N; ``throttle`` is a fraction 0..1).
"""

from __future__ import annotations

from typing import Any

import numpy as np

ROW_SIGNALS: tuple[str, ...] = (
    "x_m", "y_m", "z_m", "psi_rad", "e_y_m", "e_phi_rad", "v_mps", "v_y_mps", "yaw_rate_radps",
    "road_wheel_angle_rad", "hand_wheel_angle_rad", "steering_command_rad", "roll_rad", "throttle", "brake_n",
    "a_x_mps2", "a_y_mps2", "a_z_mps2", "min_fz_n", "station_m", "progress_m", "target_speed_mps",
    "speed_error_mps", "time_error_s",
)
"""Scalar signals of one car after a step (or a reset), in the order of the kernel's signal row.
``speed_error_mps`` is v_x - v_ref [m/s] and ``time_error_s`` the time error e_t [s] against the reference's time
law (``envs.kernels``: positive = behind the reference), in every control mode."""

REWARD_TERMS: tuple[str, ...] = (
    "reward_alive", "reward_tracking", "reward_heading", "reward_effort", "reward_rate", "reward_terminal",
    "reward_speed")
"""The reward's terms (see ``envs.config.RewardConfig``); they sum to the step's reward (``reward_speed`` is 0 in
the ``steer`` control mode)."""

SIGNAL_ROW: tuple[str, ...] = ROW_SIGNALS + REWARD_TERMS
"""Columns of the per-car signal row the compiled step writes."""

SCALAR_SIGNALS: tuple[str, ...] = ("time_s", *ROW_SIGNALS)
"""The per-step scalar signals a ``Trace`` records (everything the metrics need)."""

ARRAY_SIGNALS: tuple[str, ...] = ("fz_n", "acc_substeps_mps2")
"""Per-step arrays: wheel loads FL, FR, RL, RR [N] (4,); a_x, a_y, a_z at the physics rate (n_sub, 3)."""

SAFETY_SIGNALS: tuple[str, ...] = ("cost", "edge_margin_m")
"""The per-step safety signal (Safety-Gymnasium's convention): ``cost`` 1.0 on a step that broke the scenario's
rule, else 0.0 (its success criterion's ``safety``: the road at the CG by default, a gate newly left on a gated
course, the declared track-limit rule with ``track_limits=``); ``edge_margin_m`` the body's least clearance to a
road edge over the step [m] (negative: the body crossed it), +inf where the scenario does not judge the body
against the edges (``track_limits=`` judges it; inf, not NaN, so that equal episodes give equal infos). Both
0.0 / inf at reset."""

INFO_KEYS: tuple[str, ...] = (*SCALAR_SIGNALS, *REWARD_TERMS, *ARRAY_SIGNALS, "termination", "success",
                              *SAFETY_SIGNALS)
"""Every key of ``info``, in order, at reset and at every step. ``success`` (``bool``; vector env: a bool array)
is the scenario's verdict on the episode (its success criterion, ``envs.criteria``): False until the step that ends
it, then True if the criterion holds (``termination`` stays the end reason). ``cost`` and ``edge_margin_m``:
``SAFETY_SIGNALS`` (``numpy.float64``)."""


def info_dict(time_s: float, row: np.ndarray, fz_n: np.ndarray, acc_substeps_mps2: np.ndarray,
              termination: str, success: bool = False, cost: float = 0.0,
              edge_margin_m: float = float("inf")) -> dict[str, Any]:
    """One car's ``info`` from its signal row (``SIGNAL_ROW`` order, float64) and arrays (copied by the caller);
    ``cost`` and ``edge_margin_m`` [m]: ``SAFETY_SIGNALS``."""
    info: dict[str, Any] = {"time_s": np.float64(time_s)}
    info.update(zip(SIGNAL_ROW, row, strict=True))
    info["fz_n"] = fz_n
    info["acc_substeps_mps2"] = acc_substeps_mps2
    info["termination"] = termination
    info["success"] = bool(success)
    info["cost"] = np.float64(cost)
    info["edge_margin_m"] = np.float64(edge_margin_m)
    return info


def signal_row(**values: float) -> np.ndarray:
    """A float64 signal row from named values (every name of ``SIGNAL_ROW``; ``ValueError`` naming a gap)."""
    missing = [name for name in SIGNAL_ROW if name not in values]
    extra = sorted(set(values) - set(SIGNAL_ROW))
    if missing or extra:
        raise ValueError(f"signal row: missing {missing}, unknown {extra}")
    return np.array([values[name] for name in SIGNAL_ROW], dtype=np.float64)
