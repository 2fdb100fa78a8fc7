"""ISO 2631-1:1997 frequency weightings (Wk, Wd, Wf), weighted RMS, the total value a_v and the comfort scale.

Weightings (Annex A; Q1 = Q2 = 1/sqrt(2)): ``W(p) = K Hh(p) Hl(p) Ht(p) Hs(p)`` with ``p = j 2 pi f`` and

* band limits: ``Hh = p^2 / (p^2 + sqrt(2) w1 p + w1^2)``, ``Hl = 1 / (1 + sqrt(2) p / w2 + (p / w2)^2)``,
* acceleration-velocity transition: ``Ht = (1 + p / w3) / (1 + p / (Q4 w4) + (p / w4)^2)`` (numerator 1 when
  f3 = inf),
* upward step: ``Hs = (p^2 + p w5 / Q5 + w5^2) / (p^2 + p w6 / Q6 + w6^2)`` (Hs = 1 when f5 = f6 = inf).

``weighting_magnitude`` evaluates |W| analytically; it reproduces the standard's Table 3 factors of Wk and Wd at
the nominal one-third-octave centres 0.1..80 Hz to within 0.33 % (one printed entry, Wd at 10 Hz = 0.212, is
4.9 % above the Annex A filter's 0.2017; its neighbours agree to 0.1 %), and Wf at 0.1..0.5 Hz to within 0.1 %.

Time signals (``weighted``): bilinear transform WITHOUT pre-warping (``scipy.signal.bilinear_zpk`` -> second
order sections -> ``sosfilt``), applied at an internal rate of at least ``INTERNAL_FS_HZ`` = 2000 Hz. Signals
sampled slower are first upsampled by the integer factor ``L = ceil(2000 / fs)`` with the polyphase FIR of
``scipy.signal.resample_poly`` (edge padding; linear phase, delay compensated, so it looks about 10 input
samples ahead), filtered, and decimated back by taking every L-th sample (no aliasing: the upsampled signal is
band-limited to the original Nyquist frequency). Measured steady-state sine RMS vs |W| for Wk and Wd,
0.5..40 Hz: within 0.11 % at fs = 500 Hz, 0.13 % at 250 Hz, 0.05 % at 1000 Hz, 0.15 % at any fs >= 200 Hz
(< 0.9 % up to 80 Hz). Plain bilinear at the native rate would be -2.3 % at 40 Hz for fs = 500 Hz and -9.3 %
for fs = 250 Hz (frequency warping); per-section pre-warping only improves that to -1.5 % / -6.9 %.

Sampling rate: log accelerations at >= 250 Hz (the weightings extend to 100 Hz). ``weighted`` raises ValueError
below ``MIN_FS_HZ`` = 200 Hz, where the 100 Hz band limit is above the Nyquist frequency.
The filters start from rest (the signal is taken as zero before its first sample): a non-zero mean (e.g. gravity
in a_z) produces a decaying start-up transient that inflates the RMS of short records; subtract it first.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

from vtrack_gym._ranges import documented, ranged, validate

MIN_FS_HZ = 200.0
"""Lowest accepted sampling rate for ``weighted`` [Hz]; 250 Hz or more is recommended."""
INTERNAL_FS_HZ = 2000.0
"""Minimum rate at which the bilinear-transformed filters run (by integer oversampling) [Hz]."""


@documented
@dataclass(frozen=True)
class WeightingParams:
    """Annex A parameters of one frequency weighting: corner frequencies [Hz], quality factors [-], gain K [-].

    ``f3_hz = inf`` drops the numerator of Ht; ``f5_hz = f6_hz = inf`` drops Hs (q5, q6 are then unused).
    """

    f1_hz: float = ranged(gt=0.0, unit="Hz")
    f2_hz: float = ranged(gt="f1_hz", unit="Hz")
    f3_hz: float
    f4_hz: float = ranged(gt=0.0, unit="Hz")
    q4: float = ranged(gt=0.0)
    f5_hz: float = math.inf
    q5: float = math.nan
    f6_hz: float = math.inf
    q6: float = math.nan
    gain: float = ranged(1.0, gt=0.0)

    def __post_init__(self) -> None:
        validate(self)
        if not (isinstance(self.f3_hz, (int, float)) and self.f3_hz > 0.0) or math.isnan(self.f3_hz):
            raise ValueError(f"WeightingParams.f3_hz must be > 0 or inf (got {self.f3_hz!r})")
        if math.isinf(self.f5_hz) != math.isinf(self.f6_hz):
            raise ValueError("WeightingParams.f5_hz and f6_hz must both be finite or both be inf "
                             f"(got {self.f5_hz}, {self.f6_hz})")
        if math.isfinite(self.f5_hz):
            for name in ("f5_hz", "q5", "f6_hz", "q6"):
                value = getattr(self, name)
                if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0):
                    raise ValueError(f"WeightingParams.{name} must be a finite number > 0 when the step "
                                     f"stage is used (got {value!r})")

    @property
    def has_step(self) -> bool:
        """Whether the upward-step stage Hs is present."""
        return math.isfinite(self.f5_hz)


WEIGHTINGS: Mapping[str, WeightingParams] = MappingProxyType({
    "Wd": WeightingParams(f1_hz=0.4, f2_hz=100.0, f3_hz=2.0, f4_hz=2.0, q4=0.63),
    "Wf": WeightingParams(f1_hz=0.08, f2_hz=0.63, f3_hz=math.inf, f4_hz=0.25, q4=0.86,
                          f5_hz=0.0625, q5=0.80, f6_hz=0.10, q6=0.80),
    "Wk": WeightingParams(f1_hz=0.4, f2_hz=100.0, f3_hz=12.5, f4_hz=12.5, q4=0.63,
                          f5_hz=2.37, q5=0.91, f6_hz=3.35, q6=0.91),
})
"""ISO 2631-1 Annex A parameters: Wd horizontal x, y; Wk vertical z (seat); Wf motion sickness (z)."""

COMFORT_SCALE: tuple[tuple[float, float, str], ...] = (
    (0.0, 0.315, "not uncomfortable"),
    (0.315, 0.63, "a little uncomfortable"),
    (0.5, 1.0, "fairly uncomfortable"),
    (0.8, 1.6, "uncomfortable"),
    (1.25, 2.5, "very uncomfortable"),
    (2.0, math.inf, "extremely uncomfortable"),
)
"""ISO 2631-1 Annex C reaction scale (overlapping bands): (lower, upper [m/s^2], label)."""


def _params(name: str) -> WeightingParams:
    """Look up a weighting, raising ValueError that lists the valid names."""
    try:
        return WEIGHTINGS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown weighting {name!r}; valid names: {sorted(WEIGHTINGS)}") from None


def weighting_magnitude(name: str, freqs_hz: ArrayLike) -> np.ndarray:
    """Analytic gain |W(j 2 pi f)| [-] of weighting ``name`` ("Wd", "Wk" or "Wf") at frequencies f [Hz]."""
    par = _params(name)
    f = np.asarray(freqs_hz, dtype=np.float64)
    if not np.isfinite(f).all():
        raise ValueError("freqs_hz must be finite")
    p = 2j * np.pi * f
    w1, w2, w4 = (2.0 * np.pi * x for x in (par.f1_hz, par.f2_hz, par.f4_hz))
    h = p**2 / (p**2 + math.sqrt(2.0) * w1 * p + w1**2)
    h = h / (1.0 + math.sqrt(2.0) * p / w2 + (p / w2) ** 2)
    numerator = 1.0 if math.isinf(par.f3_hz) else 1.0 + p / (2.0 * np.pi * par.f3_hz)
    h = h * numerator / (1.0 + p / (par.q4 * w4) + (p / w4) ** 2)
    if par.has_step:
        w5, w6 = 2.0 * np.pi * par.f5_hz, 2.0 * np.pi * par.f6_hz
        h = h * (p**2 + p * w5 / par.q5 + w5**2) / (p**2 + p * w6 / par.q6 + w6**2)
    return par.gain * np.abs(h)


def _analog_zpk(par: WeightingParams) -> tuple[np.ndarray, np.ndarray, float]:
    """Zeros, poles [rad/s] and gain of the analog weighting filter."""
    w1, w2, w4 = (2.0 * np.pi * x for x in (par.f1_hz, par.f2_hz, par.f4_hz))
    zeros = [0.0, 0.0]
    poles = [*np.roots([1.0, math.sqrt(2.0) * w1, w1**2]), *np.roots([1.0, math.sqrt(2.0) * w2, w2**2]),
             *np.roots([1.0, w4 / par.q4, w4**2])]
    gain = par.gain * w2**2 * w4**2
    if math.isfinite(par.f3_hz):
        w3 = 2.0 * np.pi * par.f3_hz
        zeros.append(-w3)
        gain /= w3
    if par.has_step:
        w5, w6 = 2.0 * np.pi * par.f5_hz, 2.0 * np.pi * par.f6_hz
        zeros.extend(np.roots([1.0, w5 / par.q5, w5**2]))
        poles.extend(np.roots([1.0, w6 / par.q6, w6**2]))
    return np.asarray(zeros, dtype=complex), np.asarray(poles, dtype=complex), gain


@functools.lru_cache(maxsize=32)
def _digital_sos(name: str, fs_hz: float) -> np.ndarray:
    """Second-order sections of the bilinear transform (no pre-warping) of weighting ``name`` at fs [Hz]."""
    from scipy import signal

    z, p, k = _analog_zpk(_params(name))
    zd, pd, kd = signal.bilinear_zpk(z, p, k, fs_hz)
    sos = signal.zpk2sos(zd, pd, kd)
    sos.setflags(write=False)
    return sos


def _check_signal(x: ArrayLike, label: str = "signal") -> np.ndarray:
    """A finite, non-empty 1-D float array, or ValueError."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{label} must be a non-empty 1-D array (got shape {arr.shape})")
    if not np.isfinite(arr).all():
        raise ValueError(f"{label} must be finite (found NaN or inf)")
    return arr


def _check_fs(fs_hz: float) -> float:
    """The sampling rate as float, or ValueError naming fs_hz."""
    if isinstance(fs_hz, bool) or not isinstance(fs_hz, (int, float, np.floating, np.integer)):
        raise ValueError(f"fs_hz must be a number (got {fs_hz!r})")
    if not (math.isfinite(fs_hz) and fs_hz >= MIN_FS_HZ):
        raise ValueError(f"fs_hz must be >= {MIN_FS_HZ} Hz (250 Hz or more recommended; got {fs_hz})")
    return float(fs_hz)


def weighted(signal: ArrayLike, fs_hz: float, name: str) -> np.ndarray:
    """Frequency-weighted time signal (same length and unit as ``signal``, e.g. m/s^2) sampled at fs [Hz].

    Bilinear transform without pre-warping, run at ``L fs >= 2000 Hz`` (see the module docstring); the filter
    starts from rest. Raises ValueError for an unknown name, fs_hz < 200 Hz, or a non-finite / non-1-D signal.
    """
    _params(name)
    fs = _check_fs(fs_hz)
    x = _check_signal(signal)
    factor = max(1, math.ceil(INTERNAL_FS_HZ / fs - 1e-9))
    sos = _digital_sos(name, fs * factor)
    from scipy import signal as sps

    if factor == 1:
        return sps.sosfilt(sos.copy(), x)
    return sps.sosfilt(sos.copy(), sps.resample_poly(x, factor, 1, padtype="edge"))[::factor]


def weighted_rms(signal: ArrayLike, fs_hz: float, name: str) -> float:
    """RMS over the whole record of the frequency-weighted signal, a_w (unit of ``signal``, e.g. m/s^2)."""
    y = weighted(signal, fs_hz, name)
    return float(np.sqrt(np.mean(y * y)))


def vibration_total(a_x: ArrayLike, a_y: ArrayLike, a_z: ArrayLike, fs_hz: float,
                    k: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> float:
    """Total value a_v = sqrt(sum k_i^2 a_wi^2) [m/s^2] from x, y, z accelerations [m/s^2] sampled at fs [Hz].

    Wd weights x and y, Wk weights z. ``k = (1, 1, 1)`` (default) is the usual choice for comfort on the seat
    surface (the spec could not confirm it from the printed standard; hence configurable); health (seated) uses
    ``k = (1.4, 1.4, 1.0)``.
    """
    return vibration_axes(a_x, a_y, a_z, fs_hz, k)[0]


def vibration_axes(a_x: ArrayLike, a_y: ArrayLike, a_z: ArrayLike, fs_hz: float,
                   k: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> tuple[float, tuple[float, float, float]]:
    """``vibration_total`` [m/s^2] and the three weighted RMS values a_wx, a_wy, a_wz it is made of [m/s^2]
    (unscaled by k), each filtered once."""
    ks = tuple(k)
    if len(ks) != 3 or not all(isinstance(v, (int, float)) and math.isfinite(v) and v >= 0.0 for v in ks):
        raise ValueError(f"k must be three finite numbers >= 0 (got {k!r})")
    axes = [_check_signal(a, label) for a, label in ((a_x, "a_x"), (a_y, "a_y"), (a_z, "a_z"))]
    if len({a.size for a in axes}) != 1:
        raise ValueError(f"a_x, a_y, a_z must have the same length (got {[a.size for a in axes]})")
    a_w = [weighted_rms(a, fs_hz, name) for a, name in zip(axes, ("Wd", "Wd", "Wk"), strict=True)]
    total = float(math.sqrt(sum((ki * ai) ** 2 for ki, ai in zip(ks, a_w, strict=True))))
    return total, (a_w[0], a_w[1], a_w[2])


def comfort_band(a_v: float) -> str:
    """ISO 2631-1 Annex C comfort reaction for a total value a_v [m/s^2].

    The published bands overlap; we return the band with the highest lower bound that a_v reaches (lower bounds
    inclusive), i.e. the most severe applicable reaction: [0, 0.315) not uncomfortable, [0.315, 0.5) a little,
    [0.5, 0.8) fairly, [0.8, 1.25) uncomfortable, [1.25, 2) very, [2, inf) extremely uncomfortable.
    """
    if isinstance(a_v, bool) or not isinstance(a_v, (int, float, np.floating, np.integer)) \
            or not math.isfinite(a_v) or a_v < 0.0:
        raise ValueError(f"a_v must be a finite number >= 0 m/s^2 (got {a_v!r})")
    label = COMFORT_SCALE[0][2]
    for lower, _upper, band in COMFORT_SCALE:
        if a_v >= lower:
            label = band
    return label
