"""Per-car disturbances around the compiled step: sensor noise on the observation and actuator delay on the command.

Each car draws its noise from its own generator, so car i of a batch reproduces a single env bit for bit.
"""

from __future__ import annotations

import numpy as np


class SensorNoise:
    """Gaussian noise on the noisy observation fields, scaled per car, clipped to the observation box."""

    def __init__(self, n: int, noise_std: tuple[float, ...], noisy_indices: tuple[int, ...],
                 low: np.ndarray, high: np.ndarray) -> None:
        self.scale = np.zeros(n)
        """Each car's noise scale (x ``noise_std``; 0: none)."""
        self._std = np.asarray(noise_std)
        self._idx = np.asarray(noisy_indices, dtype=np.intp)
        self._low = np.asarray(low, dtype=np.float32)[self._idx]
        self._high = np.asarray(high, dtype=np.float32)[self._idx]
        self.active = False
        """True when any car has noise (the step skips ``apply`` otherwise)."""

    def set_scale(self, i: int, scale: float) -> None:
        """Car ``i``'s noise scale for its new episode."""
        self.scale[i] = scale
        self.active = bool(self.scale.any())

    def apply(self, obs: np.ndarray, rngs: list[np.random.Generator], quiet: np.ndarray | None = None) -> None:
        """Add each noisy car's noise to its row of ``obs`` (float32 (n, obs_dim)) in place. ``quiet`` (bool (n,))
        marks cars whose step is discarded (the vector env's autoreset step): they draw nothing, so their generator
        stays where a single env's would be."""
        idx = self._idx
        cars = self.scale != 0.0
        if quiet is not None:
            cars &= ~quiet
        for i in np.flatnonzero(cars):
            noisy = obs[i, idx] + (self.scale[i] * self._std * rngs[i].standard_normal(idx.size)).astype(np.float32)
            obs[i, idx] = np.minimum(np.maximum(noisy, self._low), self._high)


class ActuatorDelay:
    """A FIFO of steering commands per car, delaying each by a whole number of control periods."""

    def __init__(self, n: int, control_period_s: float) -> None:
        self.n = n
        self.control_period_s = control_period_s
        self.steps = np.zeros(n, dtype=np.int64)
        """Each car's delay in control periods."""
        self._buffer = np.zeros((n, 1))
        self.active = False
        """True when any car has a delay."""

    def steps_of(self, delay_s: float) -> int:
        """``delay_s`` [s] in control periods; ``ValueError`` naming the reset option unless it is a whole number of
        control periods (within 1e-9 of one; the delay is applied exactly, never rounded)."""
        period = self.control_period_s
        ratio = delay_s / period
        steps = round(ratio)
        if abs(ratio - steps) > 1e-9:
            raise ValueError(f"reset option 'actuator_delay_s' must be a whole number of control periods "
                             f"({period * 1e3:g} ms; e.g. 0, {period:g}, {2 * period:g} s) (got {delay_s!r})")
        return steps

    def set_delay(self, i: int, delay_s: float) -> None:
        """Car ``i``'s delay for its new episode; its FIFO emptied (zero commands before the first)."""
        steps = self.steps_of(delay_s)
        self.steps[i] = steps
        if steps + 1 > self._buffer.shape[1]:
            grown = np.zeros((self.n, steps + 1))
            grown[:, : self._buffer.shape[1]] = self._buffer
            self._buffer = grown
        self._buffer[i] = 0.0
        self.active = bool(self.steps.any())

    def delayed(self, actions: np.ndarray) -> np.ndarray:
        """Push this step's ``actions`` (n,) and return each car's delayed command."""
        buf = self._buffer
        buf[:, 1:] = buf[:, :-1].copy()
        buf[:, 0] = actions
        return buf[np.arange(self.n), self.steps]
