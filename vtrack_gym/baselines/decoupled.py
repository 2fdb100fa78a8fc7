"""The decoupled design: a lateral law paired with the paper's PD-FLC as its longitudinal law, so every steering
baseline drives an env in any control mode (``envs.control``).

``make_policy(name, env)`` and the agent resolver return the steering policy itself for a ``steer`` env and
``Decoupled(policy, env)`` for the longitudinal modes. Each step:

* the lateral law's action is its steering command ``c*`` (fraction of the road-wheel limit);
* ``steer_accel`` sends ``c*``; ``steer_rate_accel`` sends the rate that moves the env's integrated command ``c``
  towards ``c*`` in one control period, ``rate = clip((c* - c) / rate_step, -1, 1)`` with ``rate_step`` the command
  change of a full-rate action over a period (``BatchSim.rate_step``), and integrates ``c`` exactly as the env does
  (0 at an episode start), so the car steers like ``c*`` behind a rate limit equal to the car's own actuator's;
* the longitudinal demand is the PD-FLC's output for the observation's ``v_x`` and ``target_speed`` (the env's
  ``speed_controller`` gains, the kernel's own ``pdflc_step``): ``throttle`` if it is > 0, else
  ``-brake / brakes.max_pedal_force_n`` (``envs.control.demand_of``), which the env's throttle/brake map turns
  back into the same pedals.

So ``steer_accel`` with a decoupled baseline reproduces the ``steer`` mode's episode up to the float32 rounding of
the observation and the action. The state (SB3 protocol) is the lateral law's memory followed by the PD-FLC's
three memory entries and the integrated command.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vtrack_gym.baselines.base import _episode_starts

EXTRA_STATE = 4
"""State entries the pairing adds after the lateral law's: PD-FLC memory (e_prev, de, fresh) and the integrated
steering command."""


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


def for_control(policy: Any, env: Any) -> Any:
    """``policy`` for ``env``: itself in the ``steer`` mode (or an env without control modes, or an agent whose
    action already has the demand), else the steering policy paired with the PD-FLC (``Decoupled``)."""
    control = _env_value(env, "control") if env is not None else None
    if control in (None, "steer") or isinstance(policy, Decoupled) or getattr(policy, "action_dim", 1) != 1:
        return policy   # a steer env, or an agent trained with the longitudinal action already
    return Decoupled(policy, env)


class Decoupled:
    """A steering policy paired with the PD-FLC speed law for a longitudinal control mode (module docstring)."""

    def __init__(self, lateral: Any, env: Any) -> None:
        from vtrack_gym.envs.control import check_control
        from vtrack_gym.envs.pdflc import control_surface
        from vtrack_gym.envs.pdflc_kernel import pdflc_gains

        config = _env_value(env, "config")
        self.control = check_control(_env_value(env, "control"))
        if config is None:
            raise ValueError("Decoupled needs the env's config (env.unwrapped.config) for its PD-FLC gains")
        layout = config.layout
        period = float(config.control_period_s)
        self.lateral = lateral
        pd = config.speed_controller
        self._gains = pdflc_gains(pd, period)
        self._surface = np.ascontiguousarray(control_surface(pd.method, pd.surface_resolution))
        self._kinks = pd.method == "mamdani"
        self.max_pedal_force_n = float(config.vehicle.brakes.max_pedal_force_n)
        self.rate_step = config.vehicle.steering.max_road_wheel_rate_radps * period / \
            config.vehicle.steering.max_road_wheel_angle_rad
        self._v, self._v_ref = layout.index("v_x"), layout.index("target_speed")
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
        own[starts] = (0.0, 0.0, 1.0, 0.0)
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
        fresh = np.tile((0.0, 0.0, 1.0, 0.0), (n, 1))
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
        rate = float(np.float32(min(max((target - own[3]) / self.rate_step, -1.0), 1.0)))
        own[3] = min(max(own[3] + rate * self.rate_step, -1.0), 1.0)   # the env's own integration
        return rate

    def _demand(self, row: np.ndarray, own: np.ndarray) -> float:
        """The PD-FLC's pedals for this observation as a demand (``envs.control.demand_of``)."""
        from vtrack_gym.envs.control import demand_of
        from vtrack_gym.envs.pdflc_kernel import pdflc_step

        mem = own[:3].copy()
        throttle, brake = pdflc_step(float(row[self._v]), float(row[self._v_ref]), mem, self._gains, self._surface,
                                     self._kinks)
        own[:3] = mem
        return demand_of(throttle, brake, self.max_pedal_force_n)

    def __repr__(self) -> str:
        return f"Decoupled({self.lateral!r}, control={self.control!r})"


def _starts(episode_start: Any, n: int) -> np.ndarray:
    """``episode_start`` as a bool mask of ``n`` rows (all False when None; ``base._episode_starts`` checks it)."""
    mask = _episode_starts(episode_start, n)
    return np.zeros(n, dtype=bool) if mask is None else mask
