"""Compute in the loop: a decision's compute time delays its steering command.

``Latency`` is the part that says how (off, a fixed budget, or measured); ``CommandSchedule`` turns each car's
decisions and their delays into the command in force at every physics step. A delay is rounded up to a whole
number of physics steps (``EnvConfig.physics_dt_s``, 2 ms by default): a decision made from the observation at
time t with delay d takes effect at t + ceil(d / dt) dt; until then the previous command holds. A newer decision
that takes effect replaces every older one still waiting. A decision is *late* when its delay exceeds the control
period (it missed the next decision's time).
"""

from __future__ import annotations

import math
import numbers
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

LATENCY_MODES: tuple[str, ...] = ("off", "fixed", "measured")
"""``Latency.mode`` values: no delay (the default), ``latency_s`` a decision, each decision's measured time."""
MAX_LATENCY_S = 1.0
"""Largest fixed budget [s] (``latency_s``)."""

Clock = Callable[[], float]
"""A clock in seconds (``time.perf_counter`` by default; tests inject their own)."""


@dataclass(frozen=True)
class Latency:
    """How each decision's compute delays its command: ``mode`` in ``LATENCY_MODES``, ``seconds`` the fixed budget
    [s] (mode ``fixed``, in [0, 1])."""

    mode: str = "off"
    seconds: float = 0.0

    def __post_init__(self) -> None:
        if self.mode not in LATENCY_MODES:
            raise ValueError(f"latency must be one of {', '.join(LATENCY_MODES)} or a number of seconds "
                             f"(got {self.mode!r})")
        if not (0.0 <= self.seconds <= MAX_LATENCY_S):
            raise ValueError(f"latency_s must be in [0, {MAX_LATENCY_S:g}] s (got {self.seconds!r})")

    @classmethod
    def parse(cls, latency: Any = None, latency_s: Any = None) -> Latency:
        """From the ``latency=`` (``None``, ``"off"``, ``"measured"`` or seconds) and ``latency_s=`` (seconds)
        arguments; ``ValueError`` naming the argument for anything else or both given."""
        if latency is not None and latency_s is not None:
            raise ValueError("pass either latency= or latency_s=, not both")
        if latency_s is not None:
            return cls("fixed", _seconds(latency_s, "latency_s"))
        if latency is None or (isinstance(latency, str) and latency in ("off", "measured")):
            return cls("off" if latency is None else latency)
        if isinstance(latency, str):
            try:
                return cls("fixed", _seconds(float(latency), "latency"))
            except ValueError:
                raise ValueError(f"latency must be 'off', 'measured' or a number of seconds in "
                                 f"[0, {MAX_LATENCY_S:g}] (got {latency!r})") from None
        return cls("fixed", _seconds(latency, "latency"))

    @property
    def on(self) -> bool:
        """Whether decisions are delayed at all."""
        return self.mode != "off"

    @property
    def label(self) -> str:
        """``off``, ``measured`` or the fixed budget in seconds (e.g. ``0.015``): what a result row records."""
        return f"{self.seconds:g}" if self.mode == "fixed" else self.mode


def _seconds(value: Any, name: str) -> float:
    """``value`` as a finite number of seconds in [0, MAX_LATENCY_S]; ``ValueError`` naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not math.isfinite(value) \
            or not (0.0 <= value <= MAX_LATENCY_S):
        raise ValueError(f"{name} must be a number of seconds in [0, {MAX_LATENCY_S:g}] (got {value!r})")
    return float(value)


class DecisionTimer:
    """Measures a decision's compute: from the observation handed out to the next command received [s]."""

    def __init__(self, clock: Clock | None = None) -> None:
        self.clock: Clock = clock if clock is not None else time.perf_counter
        self._handed_out = 0.0
        self._charged: float | None = None

    def handed_out(self) -> None:
        """The observation leaves the env now."""
        self._handed_out = self.clock()
        self._charged = None

    def charge(self, seconds: float) -> None:
        """Use ``seconds`` [s] as the next decision's compute instead of the clock (a harness that timed the
        policy call itself)."""
        if not math.isfinite(seconds) or seconds < 0.0:
            raise ValueError(f"charged compute must be a finite number of seconds >= 0 (got {seconds!r})")
        self._charged = min(float(seconds), MAX_LATENCY_S)

    def elapsed(self) -> float:
        """The decision's compute [s]: the charged time, else the clock since the observation left."""
        if self._charged is not None:
            return self._charged
        return max(0.0, self.clock() - self._handed_out)


class CommandSchedule:
    """Each car's commands in force at every physics step of its current control period."""

    def __init__(self, n: int, n_sub: int, physics_dt_s: float, scheduled: np.ndarray) -> None:
        self.n_sub = n_sub
        self.dt = physics_dt_s
        self.cmds = np.zeros((n, n_sub))
        """Steering command [rad] per physics step of this period (the kernel reads it where ``scheduled``)."""
        self._scheduled = scheduled   # the kernel's CAR_SCHEDULED column (a view)
        self._current = np.zeros(n)
        self._pending: list[list[tuple[int, float]]] = [[] for _ in range(n)]
        self.decisions = np.zeros(n, dtype=np.int64)
        self.late = np.zeros(n, dtype=np.int64)
        self.max_delay_s = np.zeros(n)

    def substeps_of(self, delay_s: float) -> int:
        """``delay_s`` [s] rounded up to whole physics steps (a 1e-9 step tolerance absorbs float noise)."""
        return max(0, math.ceil(delay_s / self.dt - 1e-9))

    def reset_car(self, i: int) -> None:
        """Car ``i``'s new episode: command 0 in force, nothing waiting, counts at 0."""
        self._current[i] = 0.0
        self._pending[i] = []
        self._scheduled[i] = 0.0
        self.decisions[i] = self.late[i] = 0
        self.max_delay_s[i] = 0.0

    def schedule(self, i: int, step: int, cmd_rad: float, delay_s: float) -> float:
        """Car ``i``'s decision of control step ``step`` (``cmd_rad`` [rad], computed in ``delay_s`` [s]); fills
        its row of ``cmds`` and returns the command in force at the period's end [rad]."""
        n_sub = self.n_sub
        self.decisions[i] += 1
        self.late[i] += delay_s > n_sub * self.dt * (1.0 + 1e-9)
        self.max_delay_s[i] = max(self.max_delay_s[i], delay_s)
        pending = self._pending[i]
        pending.append((step * n_sub + self.substeps_of(delay_s), cmd_rad))
        row = self.cmds[i]
        for j in range(n_sub):
            t = step * n_sub + j
            due = [k for k, (start, _) in enumerate(pending) if start <= t]
            if due:   # the newest due decision wins; older ones still waiting are dropped
                self._current[i] = pending[due[-1]][1]
                del pending[: due[-1] + 1]
            row[j] = self._current[i]
        self._scheduled[i] = 0.0 if bool((row == row[0]).all()) else 1.0
        return float(row[-1])

    def stats(self, i: int) -> dict[str, float]:
        """Car ``i``'s episode so far: ``decisions``, ``late_decisions``, ``late_share`` (0..1) and
        ``max_latency_s`` [s]."""
        d = int(self.decisions[i])
        return {"decisions": d, "late_decisions": int(self.late[i]),
                "late_share": float(self.late[i]) / d if d else 0.0, "max_latency_s": float(self.max_delay_s[i])}
