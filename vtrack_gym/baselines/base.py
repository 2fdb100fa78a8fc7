"""Common machinery of the steering baselines: the SB3-style ``Policy`` base class and speed-scheduled gains.

Every controller maps an observation (layout ``ObservationLayout``, raw SI units) to the env's action: the
front road-wheel angle as a fraction of ``DesignModel.max_road_wheel_angle_rad`` (left-positive), float32,
clipped to [-1, 1].

``predict(observation, state=None, episode_start=None, deterministic=True) -> (action, state)`` has
stable-baselines3's signature, so ``stable_baselines3.common.evaluation.evaluate_policy`` accepts any policy:

* ``observation`` of shape ``(obs_dim,)`` gives an action of shape ``(1,)``; ``(N, obs_dim)`` gives ``(N, 1)``.
* Stateless controllers return ``state = None``. Stateful ones (MPC: previous measurement, previous applied
  steering, previous disturbance, hold counter) return their memory as a float64 array of shape
  ``(N, state_size)`` (``(1, state_size)`` for a single observation).
* Two ways to carry that memory, with identical episodes:

  - SB3 protocol: pass the returned ``state`` back, with ``episode_start`` (bool, or N bools) True on the first
    step of an episode; those rows are re-initialised from the observation. The policy object keeps nothing for
    such calls, so one instance serves any number of independent envs (one state array each).
  - Plain loop, ``action, _ = policy.predict(obs)``: with ``state=None`` the policy continues from its own
    memory of its last ``state=None`` call (same N), or initialises from the observation if it has none, and
    re-initialises the rows whose ``episode_start`` is True. Call ``policy.reset()`` (or pass
    ``episode_start=True``) when a new episode starts; a fresh policy starts fresh.
* Non-finite observations raise ``ValueError``; a non-finite command is never returned (``FloatingPointError``,
  not expected for configs inside their ranges). ``deterministic`` is accepted and ignored (all controllers are
  deterministic).

Each controller implements its law once, on a batch (``_act_batch``: float64 observations (N, obs_dim) ->
road-wheel angles [rad] (N,)); a single observation is the batch N = 1. The SMC and MPC laws are compiled
(``vtrack_gym.baselines.laws``) and also run inside the GA's population rollout; ``act`` is the public,
unchecked entry to the law.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

ENV_ATTRIBUTES = ("design_model", "observation_layout", "control_period_s")
"""What ``from_env`` reads from ``env.unwrapped`` (or an SB3 VecEnv's ``get_attr``)."""


def require_choice(owner: object, name: str, choices: Sequence[str]) -> None:
    """Raise ``ValueError`` unless the field is one of ``choices``."""
    value = getattr(owner, name)
    if value not in choices:
        raise ValueError(f"{type(owner).__name__}.{name} must be one of {', '.join(map(repr, choices))} "
                         f"(got {value!r})")


def hold_steps(sample_time_s: float, control_period_s: float, owner: str) -> int:
    """Number of control periods per controller sample (``sample_time_s`` must be an integer multiple)."""
    ratio = sample_time_s / control_period_s
    n = round(ratio)
    if n < 1 or abs(ratio - n) > 1e-6 * max(1.0, ratio):
        raise ValueError(f"{owner}.sample_time_s must be an integer multiple (>= 1) of the env's control period "
                         f"{control_period_s} s (got {sample_time_s} s)")
    return n


def env_contract(env: Any) -> tuple[DesignModel, ObservationLayout, float]:
    """``(design_model, observation_layout, control_period_s [s])`` of a Gymnasium env, vector env or SB3 VecEnv."""
    base = getattr(env, "unwrapped", env)
    values = []
    for name in ENV_ATTRIBUTES:
        if hasattr(base, name):
            values.append(getattr(base, name))
        elif hasattr(env, "get_attr"):
            values.append(env.get_attr(name)[0])
        else:
            raise ValueError(f"env must expose {', '.join(ENV_ATTRIBUTES)} on env.unwrapped (missing {name!r})")
    design, layout, period = values
    if not isinstance(design, DesignModel):
        raise ValueError(f"env.unwrapped.design_model must be a DesignModel (got {type(design).__name__})")
    if not isinstance(layout, ObservationLayout):
        raise ValueError(f"env.unwrapped.observation_layout must be an ObservationLayout (got {type(layout).__name__})")
    period = float(period)
    if not (0.0 < period <= 1.0):
        raise ValueError(f"env.unwrapped.control_period_s must be in (0, 1] s (got {period})")
    return design, layout, period


class SpeedSchedule:
    """Rows of gains tabulated on a speed grid [m/s], each entry linearly interpolated in speed.

    ``table[j]`` holds the gains at ``speeds[j]``; speeds outside the grid are clamped to its ends. The lookups run
    the compiled ``laws.schedule_locate`` / ``schedule_row``, the code of the MPC and LQR laws' ``schedule_dot``.
    """

    def __init__(self, speeds: np.ndarray, table: np.ndarray) -> None:
        from vtrack_gym.baselines.laws import schedule_locate, schedule_row

        speeds = np.asarray(speeds, dtype=np.float64)
        table = np.asarray(table, dtype=np.float64)
        if speeds.ndim != 1 or speeds.size < 2 or not np.all(np.diff(speeds) > 0):
            raise ValueError("SpeedSchedule speeds must be a strictly increasing 1-D grid of >= 2 points")
        if table.shape[0] != speeds.size:
            raise ValueError(f"SpeedSchedule table must have {speeds.size} rows (got {table.shape[0]})")
        self.speeds = np.ascontiguousarray(speeds)
        self.table = np.ascontiguousarray(table.reshape(speeds.size, -1))
        self.slopes = np.ascontiguousarray(np.diff(self.table, axis=0))
        self.v_min = float(speeds[0])
        self.v_max = float(speeds[-1])
        self._locate = schedule_locate
        self._row = schedule_row

    @property
    def width(self) -> int:
        """Number of gains per row."""
        return self.table.shape[1]

    def locate(self, v: float) -> tuple[int, float]:
        """Grid interval ``i`` and fraction ``t`` in [0, 1] of speed ``v`` [m/s] (clamped to the grid)."""
        i, t = self._locate(self.speeds, float(v))
        return int(i), float(t)

    def row(self, v: float) -> np.ndarray:
        """Interpolated gain row at speed ``v`` [m/s]."""
        out = np.empty(self.width)
        self._row(self.speeds, self.table, self.slopes, float(v), out)
        return out


class Policy(abc.ABC):
    """Base class of every steering baseline (see the module docstring for the ``predict`` contract).

    Subclasses set ``name``, ``PRESETS`` (preset name -> frozen config), ``config_type`` and ``state_size`` and
    implement ``_act_batch`` (stateful ones also ``_initial_state_batch``).
    Controllers work in road-wheel radians; the base class scales by ``design.max_road_wheel_angle_rad``.
    """

    name: ClassVar[str] = "policy"
    PRESETS: ClassVar[Mapping[str, Any]] = {}
    FILE_PRESETS: ClassVar[tuple[str, ...]] = ()
    """Preset names read from a packaged file by ``_file_preset`` (the GA-tuned SMC/MPC), before ``PRESETS``."""
    config_type: ClassVar[type] = object
    state_size: int = 0
    solver_failures: int = 0
    """Failed solves of the policy's optimiser so far (a closed-form law never fails: 0; mpc_osqp and nmpc count)."""

    def __init__(self, design: DesignModel, config: Any = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        if not isinstance(design, DesignModel):
            raise ValueError(f"design must be a DesignModel (got {type(design).__name__})")
        if not isinstance(layout, ObservationLayout):
            raise ValueError(f"layout must be an ObservationLayout (got {type(layout).__name__})")
        if not (isinstance(control_period_s, (int, float)) and 0.0 < control_period_s <= 1.0):
            raise ValueError(f"control_period_s must be in (0, 1] s (got {control_period_s!r})")
        if config is None:
            config = type(self).make_config("default")
        if not isinstance(config, self.config_type):
            raise ValueError(f"config must be a {self.config_type.__name__} (got {type(config).__name__})")
        self.design = design
        self.config = config
        self.layout = layout
        self.control_period_s = float(control_period_s)
        self.max_steer_rad = float(design.max_road_wheel_angle_rad)
        self._inv_max_steer = 1.0 / self.max_steer_rad
        self.obs_dim = layout.size
        self._memory: np.ndarray | None = None

    @property
    def policy_id(self) -> str:
        """Readable id for provenance records (the registry name)."""
        return self.name

    # ----------------------------------------------------------------------------------------- construction
    @classmethod
    def preset_names(cls) -> tuple[str, ...]:
        """Every preset name ``make_config`` accepts."""
        return tuple(dict.fromkeys((*cls.FILE_PRESETS, *cls.PRESETS)))

    @classmethod
    def _file_preset(cls, preset: str) -> Any:
        """Config of a ``FILE_PRESETS`` entry (subclasses that have some override this)."""
        raise ValueError(f"{cls.name} has no file preset {preset!r}")

    @classmethod
    def make_config(cls, preset: str = "default", **overrides: Any) -> Any:
        """The preset's config with ``overrides`` applied (unknown preset or field -> ``ValueError``)."""
        if preset in cls.FILE_PRESETS:
            config = cls._file_preset(preset)
        elif preset in cls.PRESETS:
            config = cls.PRESETS[preset]
        else:
            raise ValueError(f"unknown {cls.name} preset {preset!r}; valid: {', '.join(cls.preset_names())}")
        if not overrides:
            return config
        valid = {f.name for f in dataclasses.fields(config)}
        unknown = sorted(set(overrides) - valid)
        if unknown:
            raise ValueError(f"unknown {cls.config_type.__name__} field(s) {', '.join(unknown)}; "
                             f"valid: {', '.join(sorted(valid))}")
        return dataclasses.replace(config, **overrides)

    @classmethod
    def preset_for_control(cls, preset: str, control: str | None) -> str:
        """The preset ``make_policy`` builds when asked for ``preset`` on an env in control mode ``control`` (None:
        an env without control modes): ``preset`` itself unless a policy has its own for the longitudinal modes."""
        return preset

    @classmethod
    def from_env(cls, env: Any, preset: str = "default", **overrides: Any) -> Policy:
        """Build the controller for ``env`` (reads ``env.unwrapped.design_model``, ``observation_layout`` and
        ``control_period_s``) from a preset plus config-field ``overrides``."""
        design, layout, period = env_contract(env)
        return cls(design, cls.make_config(preset, **overrides), layout=layout, control_period_s=period)

    # ------------------------------------------------------------------------------------------- predict
    def predict(self, observation: Any, state: np.ndarray | None = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """SB3-compatible steering: see the module docstring for shapes and the state contract."""
        obs = np.asarray(observation, dtype=np.float64)
        single = obs.ndim == 1
        if single:
            if obs.shape[0] != self.obs_dim:
                raise ValueError(f"observation must have {self.obs_dim} entries (got shape {obs.shape})")
            obs = obs.reshape(1, -1)
        elif obs.ndim != 2 or obs.shape[1] != self.obs_dim:
            raise ValueError(f"observation must have shape ({self.obs_dim},) or (N, {self.obs_dim}) "
                             f"(got {obs.shape})")
        if not math.isfinite(np.add.reduce(obs, axis=None)) and not np.isfinite(obs).all():   # NaN or inf somewhere
            self._check_finite(obs)   # (a finite sum: every entry is finite, without the (n, obs) isfinite array)
        n = obs.shape[0]
        st = None
        own = state is None
        if self.state_size:
            starts = _episode_starts(episode_start, n)
            if own and self._memory is not None and self._memory.shape[0] == n:
                state = self._memory
            if state is None:
                st = self._initial_state_batch(obs)
            else:
                st = np.array(state, dtype=np.float64, copy=True)
                if n == 1 and st.shape == (self.state_size,):
                    st = st.reshape(1, -1)
                if st.shape != (n, self.state_size):
                    raise ValueError(f"state must have shape ({n}, {self.state_size}) (got {st.shape})")
                if starts is not None and starts.any():
                    st[starts] = self._initial_state_batch(obs[starts])
        delta, st = self._act_batch(obs, st)
        if own and st is not None:
            self._memory = st.copy()
        if n == 1:  # a Python-float clip: much cheaper than np.clip on one value
            a = float(delta[0]) * self._inv_max_steer
            if not math.isfinite(a):
                self._non_finite(obs)
            action = np.array((1.0 if a > 1.0 else (-1.0 if a < -1.0 else a),), dtype=np.float32)
        else:
            with np.errstate(over="ignore", invalid="ignore"):
                scaled = delta * self._inv_max_steer
            if not np.isfinite(scaled).all():
                self._non_finite(obs)
            action = np.clip(scaled, -1.0, 1.0).astype(np.float32)
        return (action if single else action.reshape(n, 1)), st

    def reset(self) -> None:
        """Forget the policy's own memory (kept between ``predict`` calls made without ``state``)."""
        self._memory = None

    def act(self, observation: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        """The law without checks, scaling or clipping: road-wheel angles [rad] (N,) and the new memory for
        float64 observations (N, obs_dim) and memory ``state`` (N, state_size) (updated in place; None for
        stateless controllers)."""
        return self._act_batch(observation, state)

    def _non_finite(self, obs: np.ndarray) -> None:
        """Raise ``FloatingPointError`` for a non-finite steering command (never returned as an action).

        Every config inside its declared ranges gives finite commands for finite observations inside the env's
        observation box (``test_bounded_inputs.py::test_policies_at_range_edges_predict_finite_actions``)."""
        raise FloatingPointError(f"{self.name}: non-finite steering command for a finite observation (config "
                                 f"{self.config!r}); no action is returned")

    @staticmethod
    def _check_finite(obs: np.ndarray) -> None:
        if not np.isfinite(obs).all():
            bad = np.argwhere(~np.isfinite(np.atleast_2d(obs)))[0]
            raise ValueError(f"observation contains NaN/inf (first at index {tuple(int(i) for i in bad)})")

    # ------------------------------------------------------------------------------------ to implement
    @abc.abstractmethod
    def _act_batch(self, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        """Road-wheel angles [rad] (N,) and the new state (N, state_size) for float64 observations (N, obs_dim)
        (the one implementation of the law: a single observation is the batch N = 1)."""

    def _initial_state_batch(self, obs: np.ndarray) -> np.ndarray:
        """Initial memory (N, state_size) for a batch of observations (stateful controllers override)."""
        return np.zeros((obs.shape[0], self.state_size))

    def initial_state(self, observation: Any) -> np.ndarray | None:
        """The memory ``predict`` would start from for these observations (None for stateless controllers)."""
        if self.state_size == 0:
            return None
        obs = np.atleast_2d(np.asarray(observation, dtype=np.float64))
        self._check_finite(obs)
        return self._initial_state_batch(obs)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.config!r}, control_period_s={self.control_period_s})"


def _episode_starts(episode_start: Any, n: int) -> np.ndarray | None:
    """``episode_start`` as a bool mask of ``n`` rows (None: no row starts; a bool: every row)."""
    if episode_start is None:
        return None
    if isinstance(episode_start, (bool, np.bool_)):
        return np.full(n, bool(episode_start))
    mask = np.asarray(episode_start, dtype=bool).reshape(-1)
    if mask.size != n:
        raise ValueError(f"episode_start must have {n} entries (got {mask.size})")
    return mask
