"""The longitudinal law of the decoupled baselines in the longitudinal control modes: the paper's PD-FLC, alone or
with a feed-forward and a bounded integral (``SPEED_LAWS``).

Both work in force at the wheels, through the car's own longitudinal model (``vehicle.longitudinal``): a demand
d >= 0 is the throttle fraction, a drive force ``d F_d(v)`` with ``F_d(v) = min(F_max, P_max / v)``; d < 0 a brake
force ``-d pedal_gain max_pedal_force`` (``envs.control.pedals``).

``"pdflc"``: the PD-FLC's pedals for the observation's ``v_x`` and ``target_speed`` (the env's ``speed_controller``
gains, the compiled ``pdflc_step``), sent as they are (the steer mode's speed loop, outside the env).

``"pdflc_ff"`` (default): the net force

    F = F_pd + R(v) + m a_ref - m v_y r + m a_i

* ``F_pd``: the PD-FLC's pedals as a force (throttle x F_d(v), or minus the brake force);
* ``R(v)``: drag and rolling resistance (what the PD-FLC alone leaves as a steady speed error);
* ``a_ref = (v_1^2 - v_ref^2) / (2 d_1)`` [m/s^2]: the reference's acceleration along the path, from the first
  sample of the speed preview (v^2 is linear in s between the table's rows), clipped to
  +-``REFERENCE_ACCEL_LIMIT_MPS2``: a reference that asks for more jumps (the preview past the finish line of a
  lap driven from a standing start reads the next lap's start) and is left to the feedback;
* ``-m v_y r``: the body's term of the longitudinal equation ``m (dv_x/dt - v_y r) = sum F_x``, from the
  observation's ``v_y`` and ``yaw_rate`` (the sideslip's share of the cornering force that acts along the body);
  the steered wheels' drag ``F_yf sin(delta)`` is left to the feedback: compensating it too (its steady-state
  share ``m v_x r (l_r / L) tan(delta)``) holds the speed through a corner the PD-FLC alone drives 2 % slower and
  raised mpc's max |e_y| on LateralTracking-v0 by 27 % (0.0197 -> 0.0250 m), against 14 % without it;
* ``a_i`` [m/s^2]: a bounded integral of the speed error, ``a_i <- clip(a_i - k_i e_v T, -a_max, a_max)`` with
  ``k_i`` = ``INTEGRAL_GAIN_PER_S2`` and ``a_max`` = ``INTEGRAL_LIMIT_MPS2``, frozen while the demand is saturated
  in the error's direction (no wind-up while the car cannot follow).

F is then mapped to the demand: ``F / F_d(v)`` (at most 1) when F >= 0, else ``F / (pedal_gain max_pedal_force)``
(at least -1).

Per-car memory (``MEMORY``, 4 entries): the PD-FLC's (previous e_v, filtered de_v, fresh flag) and a_i.
"""

from __future__ import annotations

from typing import Any

import numpy as np

SPEED_LAWS: dict[str, str] = {
    "pdflc_ff": "the PD-FLC plus a feed-forward of the resistance, the body's v_y r term and the reference's "
                "acceleration, and a bounded integral of the speed error",
    "pdflc": "the paper's PD-FLC alone (the steer mode's speed loop)",
}
"""Longitudinal law name -> what it is (the first one is the default)."""
MEMORY = 4
"""Memory entries per car: the PD-FLC's three (e_prev, de, fresh) and the integral's acceleration a_i."""
FRESH_MEMORY: tuple[float, ...] = (0.0, 0.0, 1.0, 0.0)
"""The memory at an episode start."""
REFERENCE_ACCEL_LIMIT_MPS2 = 5.0
"""Bound of the reference acceleration the feed-forward follows [m/s^2] (about half a g)."""
INTEGRAL_GAIN_PER_S2 = 0.3
"""k_i [1/s^2]: the integral's acceleration per second per m/s of speed error."""
INTEGRAL_LIMIT_MPS2 = 1.0
"""a_max [m/s^2]: the integral's bound."""


def check_speed_law(name: object) -> str:
    """``name`` if it is a longitudinal law (``SPEED_LAWS``); ``ValueError`` naming ``speed_law`` and the values."""
    if not isinstance(name, str) or name not in SPEED_LAWS:
        raise ValueError(f"speed_law must be one of {', '.join(map(repr, SPEED_LAWS))} (got {name!r})")
    return name


class SpeedLaw:
    """The longitudinal law of one env's car (module docstring): ``demand(row, memory)`` per observation row."""

    def __init__(self, config: Any, name: str = "pdflc_ff") -> None:
        from vtrack_gym.envs.pdflc import control_surface
        from vtrack_gym.envs.pdflc_kernel import pdflc_gains

        self.name = check_speed_law(name)
        period = float(config.control_period_s)
        pd = config.speed_controller
        self._gains = pdflc_gains(pd, period)
        self._surface = np.ascontiguousarray(control_surface(pd.method, pd.surface_resolution))
        self._kinks = pd.method == "mamdani"
        self.period_s = period
        car = config.vehicle
        self.vehicle = car
        self.mass_kg = float(car.chassis.mass_kg)
        self.max_pedal_force_n = float(car.brakes.max_pedal_force_n)
        self.max_brake_force_n = float(car.brakes.pedal_gain) * self.max_pedal_force_n
        layout = config.layout
        self._i = {n: layout.index(n) for n in ("v_x", "v_y", "yaw_rate", "target_speed")}
        self._preview = layout.speed_preview.start if layout.n_speed_preview else None
        self._layout = layout

    def demand(self, row: np.ndarray, mem: np.ndarray) -> float:
        """The longitudinal demand in [-1, 1] for one observation row; updates ``mem`` (``MEMORY`` entries)."""
        from vtrack_gym.envs.control import demand_of
        from vtrack_gym.envs.pdflc_kernel import pdflc_step

        i = self._i
        v, v_ref = float(row[i["v_x"]]), float(row[i["target_speed"]])
        pd_mem = mem[:3].copy()
        throttle, brake = pdflc_step(v, v_ref, pd_mem, self._gains, self._surface, self._kinks)
        mem[:3] = pd_mem
        if self.name == "pdflc":
            return demand_of(throttle, brake, self.max_pedal_force_n)
        drive = self._drive_force_n(v)
        force = throttle * drive - float(self.vehicle.brakes.pedal_gain) * brake
        force += self._feed_forward_n(row, v, v_ref) + self.mass_kg * mem[3]
        demand = force / drive if force >= 0.0 else force / self.max_brake_force_n
        e_v = v - v_ref
        saturated = (demand >= 1.0 and e_v < 0.0) or (demand <= -1.0 and e_v > 0.0)
        if not saturated:
            mem[3] = min(max(mem[3] - INTEGRAL_GAIN_PER_S2 * e_v * self.period_s, -INTEGRAL_LIMIT_MPS2),
                         INTEGRAL_LIMIT_MPS2)
        return min(max(demand, -1.0), 1.0)

    def _drive_force_n(self, v: float) -> float:
        """F_d(v) [N]: full throttle's drive force at speed ``v`` [m/s] (``vehicle.longitudinal.drive_force_n``)."""
        from vtrack_gym.vehicle.longitudinal import drive_force_n

        return float(drive_force_n(self.vehicle, v))

    def _feed_forward_n(self, row: np.ndarray, v: float, v_ref: float) -> float:
        """R(v) + m a_ref - m v_y r [N] (module docstring)."""
        from vtrack_gym.vehicle.longitudinal import resistance_n

        i = self._i
        a_ref = 0.0
        if self._preview is not None:
            d_1 = float(self._layout.speed_preview_distances(v)[0])
            a_ref = (float(row[self._preview]) ** 2 - v_ref ** 2) / (2.0 * d_1)
            a_ref = min(max(a_ref, -REFERENCE_ACCEL_LIMIT_MPS2), REFERENCE_ACCEL_LIMIT_MPS2)
        body = -self.mass_kg * float(row[i["v_y"]]) * float(row[i["yaw_rate"]])
        return float(resistance_n(self.vehicle, v)) + self.mass_kg * a_ref + body
