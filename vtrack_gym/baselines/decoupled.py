"""The decoupled design: a lateral law paired with a speed law built on the paper's PD-FLC, so every steering
baseline drives an env in any control mode (``envs.control``).

``make_policy(name, env)`` and the agent resolver return the steering policy itself for a ``steer`` env and
``Decoupled(policy, env)`` for the longitudinal modes. Each step:

* the lateral law's action is its steering command ``c*`` (fraction of the road-wheel limit);
* ``steer_accel`` sends ``c*``; ``steer_rate_accel`` sends the rate that moves the env's integrated command ``c``
  towards ``c*`` in one control period, ``rate = clip((c* - c) / rate_step, -1, 1)`` with ``rate_step`` the command
  change of a full-rate action over a period (``BatchSim.rate_step``), and integrates ``c`` exactly as the env does
  (0 at an episode start), so the car steers like ``c*`` behind a rate limit equal to the car's own actuator's;
* the longitudinal demand is the speed law's (``speed_law``, ``baselines.speed_law.SPEED_LAWS``): by default
  ``"pdflc_ff"``, the PD-FLC's pedals (the env's ``speed_controller`` gains, the kernel's own ``pdflc_step``) plus
  a feed-forward of the car's resistance, of the steered wheels' drag and of the reference's acceleration, and a
  bounded integral of the speed error, mapped to the demand through the car's own longitudinal model;
  ``"pdflc"``: the PD-FLC's pedals alone, ``throttle`` if it is > 0, else ``-brake / brakes.max_pedal_force_n``
  (``envs.control.demand_of``), which the env's throttle/brake map turns back into the same pedals.

So ``steer_accel`` with ``speed_law="pdflc"`` reproduces the ``steer`` mode's episode up to the float32 rounding of
the observation and the action. The state (SB3 protocol) is the lateral law's memory followed by the speed law's
memory (``speed_law.MEMORY`` entries) and the integrated command.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vtrack_gym.baselines.base import _episode_starts
from vtrack_gym.baselines.speed_law import FRESH_MEMORY, MEMORY, SpeedLaw

EXTRA_STATE = MEMORY + 1
"""State entries the pairing adds after the lateral law's: the speed law's memory (``speed_law.MEMORY``: the
PD-FLC's e_prev, de, fresh and the integral's a_i) and the integrated steering command."""
COMMAND = MEMORY
"""Index of the integrated steering command in the pairing's state."""


def _env_value(env: Any, name: str) -> Any:
    """``env.unwrapped.<name>`` (or an SB3 VecEnv's ``get_attr``); None when the env has no such attribute."""
    base = getattr(env, "unwrapped", env)
    if hasattr(base, name):
        return getattr(base, name)
    if hasattr(env, "get_attr"):
        try:
            return env.get_attr(name)[0]
        except AttributeError:
            return None
    return None


def control_of(env: Any) -> str | None:
    """``env``'s control mode (``envs.control``); None for no env or an env without control modes."""
    return _env_value(env, "control") if env is not None else None


def for_control(policy: Any, env: Any, speed_law: str = "pdflc_ff") -> Any:
    """``policy`` for ``env``: itself in the ``steer`` mode (or an env without control modes, or an agent whose
    action already has the demand), else the steering policy paired with the speed law ``speed_law``
    (``Decoupled``)."""
    control = control_of(env)
    if control in (None, "steer") or isinstance(policy, Decoupled) or getattr(policy, "action_dim", 1) != 1:
        return policy   # a steer env, or an agent trained with the longitudinal action already
    return Decoupled(policy, env, speed_law)


class Decoupled:
    """A steering policy paired with a speed law (``speed_law``: ``"pdflc_ff"``, default, or ``"pdflc"``) for a
    longitudinal control mode (module docstring)."""

    def __init__(self, lateral: Any, env: Any, speed_law: str = "pdflc_ff") -> None:
        from vtrack_gym.envs.control import check_control

        config = _env_value(env, "config")
        self.control = check_control(_env_value(env, "control"))
        if config is None:
            raise ValueError("Decoupled needs the env's config (env.unwrapped.config) for its PD-FLC gains")
        layout = config.layout
        period = float(config.control_period_s)
        self.lateral = lateral
        self.speed_law = SpeedLaw(config, speed_law)
        self.rate_step = rate_step_of(config.vehicle, period)
        self.lateral_state = int(getattr(lateral, "state_size", 0) or 0)
        self.state_size = self.lateral_state + EXTRA_STATE
        self.obs_dim = layout.size
        self._memory: np.ndarray | None = None

    @property
    def name(self) -> str:
        """The lateral law's name (the pairing is the same policy in another control mode)."""
        return str(getattr(self.lateral, "name", type(self.lateral).__name__))

    @property
    def policy_id(self) -> str:
        """The lateral law's id (rows record the control mode with the env)."""
        return str(getattr(self.lateral, "policy_id", self.name))

    @property
    def solver_failures(self) -> Any:
        """The lateral law's failed solves (``Policy.solver_failures``)."""
        return getattr(self.lateral, "solver_failures", 0)

    @property
    def defer_preparation(self) -> bool:
        """The lateral law's two-phase switch (the NMPC's ``defer_preparation``): read from and written to the
        lateral law, so a harness that defers the preparation defers the law's own (AttributeError where the
        law has none)."""
        return bool(self.lateral.defer_preparation)

    @defer_preparation.setter
    def defer_preparation(self, value: bool) -> None:
        self.lateral.defer_preparation = value

    def __getattr__(self, name: str) -> Any:
        if name == "lateral":
            raise AttributeError(name)
        return getattr(self.lateral, name)

    def reset(self) -> None:
        """Forget both laws' own memory."""
        self._memory = None
        if callable(getattr(self.lateral, "reset", None)):
            self.lateral.reset()

    def predict(self, observation: Any, state: np.ndarray | None = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """``[steering (or its rate), demand]`` of shape (2,) for one observation, (N, 2) for a batch, and the state
        (N, state_size) (SB3's ``predict`` contract, as the steering baselines')."""
        obs = np.asarray(observation, dtype=np.float64)
        single = obs.ndim == 1
        rows = obs.reshape(1, -1) if single else obs
        n = rows.shape[0]
        lat_state, own = self._split(state, n)
        steer, lat_new = self.lateral.predict(observation, state=lat_state, episode_start=episode_start,
                                              deterministic=deterministic)
        steer = np.asarray(steer, dtype=np.float64).reshape(n)
        starts = _starts(episode_start, n)
        own[starts] = (*FRESH_MEMORY, 0.0)
        action = np.empty((n, 2), dtype=np.float32)
        for i in range(n):
            action[i, 0] = self._steering(float(steer[i]), own[i])
            action[i, 1] = self._demand(rows[i], own[i])
        if state is None:
            self._memory = own.copy()
        new_state = own if lat_new is None or self.lateral_state == 0 else np.hstack(
            (np.asarray(lat_new, dtype=np.float64).reshape(n, -1), own))
        return (action[0] if single else action), new_state

    def _split(self, state: Any, n: int) -> tuple[np.ndarray | None, np.ndarray]:
        """(the lateral law's state or None, this pairing's memory (n, EXTRA_STATE), a copy)."""
        fresh = np.tile((*FRESH_MEMORY, 0.0), (n, 1))
        if state is None:
            own = self._memory.copy() if self._memory is not None and self._memory.shape[0] == n else fresh
            return None, own
        st = np.array(state, dtype=np.float64, copy=True).reshape(n, -1)
        if st.shape[1] != self.state_size:
            raise ValueError(f"state must have shape ({n}, {self.state_size}) (got {np.shape(state)})")
        lateral = st[:, :self.lateral_state] if self.lateral_state else None
        return lateral, st[:, self.lateral_state:].copy()

    def _steering(self, target: float, own: np.ndarray) -> float:
        """The steering entry: the command, or (``steer_rate_accel``) the rate towards it, integrated in ``own``."""
        if self.control != "steer_rate_accel":
            return target
        rate, own[COMMAND] = rate_towards(target, float(own[COMMAND]), self.rate_step)
        return rate

    def _demand(self, row: np.ndarray, own: np.ndarray) -> float:
        """The speed law's demand for this observation (``speed_law.SpeedLaw.demand``), its memory in ``own``."""
        mem = own[:MEMORY].copy()
        demand = self.speed_law.demand(row, mem)
        own[:MEMORY] = mem
        return demand

    def __repr__(self) -> str:
        return f"Decoupled({self.lateral!r}, control={self.control!r}, speed_law={self.speed_law.name!r})"


def rate_step_of(vehicle: Any, control_period_s: float) -> float:
    """The command change [fraction of the road-wheel limit] of a full-rate action over one control period."""
    steering = vehicle.steering
    return steering.max_road_wheel_rate_radps * control_period_s / steering.max_road_wheel_angle_rad


def rate_towards(target: float, command: float, rate_step: float) -> tuple[float, float]:
    """(the ``steer_rate_accel`` rate that moves the integrated ``command`` towards ``target`` in one period, clipped
    to [-1, 1] and rounded to the float32 action, the command after the env's own integration)."""
    rate = float(np.float32(min(max((target - command) / rate_step, -1.0), 1.0)))
    return rate, min(max(command + rate * rate_step, -1.0), 1.0)


def _starts(episode_start: Any, n: int) -> np.ndarray:
    """``episode_start`` as a bool mask of ``n`` rows (all False when None; ``base._episode_starts`` checks it)."""
    mask = _episode_starts(episode_start, n)
    return np.zeros(n, dtype=bool) if mask is None else mask
