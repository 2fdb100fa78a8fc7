"""Control modes: what the agent's action drives (the ``control=`` make kwarg, ``EnvConfig.control``).

``"steer"`` (default, the paper's design and every registered id's): the action is ``Box(-1, 1, (1,))``, the
steering command as a fraction of the car's road-wheel limit; the PD-FLC inner loop holds the reference speed.

``"steer_accel"``: the action is ``Box(-1, 1, (2,))``: ``[steering command, longitudinal demand d]``; the PD-FLC
is off and the demand drives the pedals through the throttle/brake map (``pedals``): d >= 0 is the throttle
fraction d (the plant's drive force is ``throttle * min(F_max, P_max / v)``), d < 0 a brake pedal force of
``-d * brakes.max_pedal_force_n``.

``"steer_rate_accel"``: the action is ``Box(-1, 1, (2,))``: ``[steering rate, demand d]``; the rate is a fraction
of the car's maximum road-wheel rate (``SteeringParams.max_road_wheel_rate_radps``); the env integrates it over the
control period into the steering command (a fraction of the road-wheel limit, clipped to [-1, 1], 0 at reset):
``c_{k+1} = clip(c_k + rate * max_rate * T_c / max_angle, -1, 1)``; the demand as in ``steer_accel``.

In both longitudinal modes the observation gains ``speed_error`` and ``time_error`` at its end
(``ObservationLayout(tracking_errors=True)``) and the reward its speed term (``RewardConfig.w_speed``).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

CONTROL_MODES: dict[str, str] = {
    "steer": "steering command; the PD-FLC holds the speed (the paper's design)",
    "steer_accel": "steering command and longitudinal demand (throttle / brake); the PD-FLC is off",
    "steer_rate_accel": "steering rate and longitudinal demand (throttle / brake); the PD-FLC is off",
}
"""Control mode name -> what the action drives."""
MODE_CODES: dict[str, int] = {name: code for code, name in enumerate(CONTROL_MODES)}
"""Control mode -> the code the compiled step reads (``kernels.CFG_CONTROL``; 0 = steer)."""


def check_control(control: object) -> str:
    """``control`` if it is a control mode name; ``ValueError`` naming ``control`` and the allowed values."""
    if not isinstance(control, str) or control not in CONTROL_MODES:
        raise ValueError(f"control must be one of {', '.join(map(repr, CONTROL_MODES))} (got {control!r})")
    return control


def action_dim(control: str) -> int:
    """Action length of a control mode: 1 (steer) or 2 (steering or its rate, and the longitudinal demand)."""
    return 1 if check_control(control) == "steer" else 2


def action_space(control: str) -> gym.spaces.Box:
    """The action box of a control mode: ``Box(-1, 1, (action_dim,), float32)``."""
    return gym.spaces.Box(-1.0, 1.0, shape=(action_dim(control),), dtype=np.float32)


def pedals(demand: float, max_pedal_force_n: float) -> tuple[float, float]:
    """The throttle/brake map (the compiled step's, ``kernels.step_car``): throttle fraction [0..1] and brake pedal
    force [N] of a longitudinal demand in [-1, 1]."""
    if demand >= 0.0:
        return demand, 0.0
    return 0.0, -demand * max_pedal_force_n


def demand_of(throttle: float, brake_n: float, max_pedal_force_n: float) -> float:
    """The inverse map: the demand that gives ``throttle`` (if > 0) or ``brake_n`` [N] (what the decoupled
    baselines send for the PD-FLC's pedals)."""
    if throttle > 0.0:
        return min(throttle, 1.0)
    return -min(brake_n / max_pedal_force_n, 1.0)
