"""Random smooth open tracks for RL training, deterministic for a seed.

The curvature profile alternates smootherstep blends and constant-curvature holds (arcs or straights) after a
straight lead-in: |kappa| <= max_curvature_per_m, |dkappa/ds| <= max_dkappa_per_m2, kappa C^2. The heading is
kept within +- max_heading_rad of the start direction (the next turn bends back once it is exceeded) so that the
track makes progress, and each arc turns by at most max_arc_turn_rad. Elevation is a sum of three random
sinusoids with |grade| <= max_grade and z(0) = 0. A track whose centre-line crosses itself or comes within
min_clearance_m of a distant part of itself is redrawn from the same generator, so the result depends only on the
seed and the config. All randomness comes from ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks.path import DEFAULT_DS_M, Path
from vtrack_gym.tracks.profiles import CurvatureProfile, SineElevation

logger = logging.getLogger(__name__)

VERSION = "1"
_N_WAVES = 3
_SMOOTHERSTEP_PEAK_SLOPE = 1.875     # max dS/dt of the quintic blend


@documented
@dataclass(frozen=True)
class ProceduralTrackConfig:
    """Knobs of :func:`procedural_track` (lengths [m], curvature [1/m], curvature rate [1/m^2], angles [rad])."""

    length_m: float = ranged(1000.0, ge=50.0, le=1e5, unit="m")
    max_curvature_per_m: float = ranged(1.0 / 30.0, gt=0.0, le=0.5, unit="1/m")
    max_dkappa_per_m2: float = ranged(0.004, gt=0.0, le=1.0, unit="1/m^2")
    # non-zero arcs have |kappa| >= this * max_curvature_per_m
    min_curvature_fraction: float = ranged(0.2, ge=0.0, le=1.0)
    min_blend_m: float = ranged(5.0, gt=0.0, le=1000.0, unit="m")
    min_hold_m: float = ranged(5.0, gt=0.0, le=1000.0, unit="m")
    max_hold_m: float = ranged(60.0, ge="min_hold_m", le=10000.0, unit="m")
    straight_probability: float = ranged(0.3, ge=0.0, le=1.0)
    max_arc_turn_rad: float = ranged(2.0, gt=0.0, le=2.0 * math.pi, unit="rad")
    max_heading_rad: float = ranged(0.75 * math.pi, gt=0.0, le=math.pi, unit="rad")
    lead_in_m: float = ranged(30.0, ge=0.0, lt="length_m", unit="m")
    max_grade: float = ranged(0.05, ge=0.0, le=0.3)
    elevation_amplitude_m: float = ranged(3.0, ge=0.0, le=100.0, unit="m")
    min_wavelength_m: float = ranged(100.0, gt=0.0, le=1e5, unit="m")
    max_wavelength_m: float = ranged(600.0, ge="min_wavelength_m", le=1e5, unit="m")
    min_clearance_m: float = ranged(20.0, ge=0.0, le=1000.0, unit="m")
    half_width_m: float = ranged(3.5, gt=0.0, le=50.0, unit="m")
    ds_m: float = ranged(DEFAULT_DS_M, gt=0.0, le=5.0, unit="m")
    max_attempts: int = ranged(100, ge=1, le=100000, integer=True)

    def __post_init__(self) -> None:
        validate(self)


def _curvature(rng: np.random.Generator, cfg: ProceduralTrackConfig) -> CurvatureProfile:
    """Random C^2 curvature profile at least cfg.length_m long."""
    kmax = cfg.max_curvature_per_m
    segs: list[tuple[float, float]] = [(cfg.lead_in_m, 0.0)] if cfg.lead_in_m > 0.0 else []
    s = cfg.lead_in_m
    k = 0.0
    heading = 0.0
    while s < cfg.length_m:
        if rng.random() < cfg.straight_probability:
            k_new = 0.0
        else:
            sign = 1.0 if rng.random() < 0.5 else -1.0
            if abs(heading) > cfg.max_heading_rad:
                sign = -math.copysign(1.0, heading)
            k_new = sign * kmax * rng.uniform(cfg.min_curvature_fraction, 1.0)
        blend = max(_SMOOTHERSTEP_PEAK_SLOPE * abs(k_new - k) / cfg.max_dkappa_per_m2, cfg.min_blend_m)
        blend *= rng.uniform(1.0, 1.5)
        hold = rng.uniform(cfg.min_hold_m, cfg.max_hold_m)
        if k_new != 0.0:
            hold = min(hold, max(cfg.max_arc_turn_rad / abs(k_new) - 0.5 * blend, cfg.min_hold_m))
        segs += [(blend, k_new), (hold, k_new)]
        heading += 0.5 * (k + k_new) * blend + k_new * hold
        s += blend + hold
        k = k_new
    return CurvatureProfile.from_segments(0.0, segs)


def _elevation(rng: np.random.Generator, cfg: ProceduralTrackConfig) -> SineElevation:
    """Sum of _N_WAVES random sinusoids with |grade| <= cfg.max_grade and z(0) = 0 [m]."""
    amp = cfg.elevation_amplitude_m * rng.uniform(0.3, 1.0, _N_WAVES)
    wave = rng.uniform(cfg.min_wavelength_m, cfg.max_wavelength_m, _N_WAVES)
    phase = rng.uniform(0.0, 2.0 * math.pi, _N_WAVES)
    bound = float(np.sum(amp * 2.0 * math.pi / wave))
    if bound > cfg.max_grade:
        amp *= cfg.max_grade / bound
    offset = -float(np.sum(amp * np.sin(phase)))
    return SineElevation(tuple(amp.tolist()), tuple(wave.tolist()), tuple(phase.tolist()), offset)


def procedural_track_from_config(seed: int, config: ProceduralTrackConfig) -> Path:
    """Random open track for ``seed`` (int >= 0) and ``config``; RuntimeError if max_attempts draws all fail."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an int >= 0 (got {seed!r})")
    rng = np.random.default_rng(int(seed))
    for attempt in range(config.max_attempts):
        profile = _curvature(rng, config)
        elevation = _elevation(rng, config)
        path = Path.from_curvature(profile, config.length_m, elevation=elevation, ds_m=config.ds_m,
                                   half_width_m=config.half_width_m, name=f"procedural-{int(seed)}",
                                   version=VERSION)
        if not path.self_intersects(config.min_clearance_m):
            return path
        logger.debug("procedural track seed %d: draw %d too close to itself, redrawing", seed, attempt)
    raise RuntimeError(f"procedural track seed {seed}: no valid track in {config.max_attempts} draws; "
                       "relax min_clearance_m, max_heading_rad or max_curvature_per_m")


def procedural_track(seed: int, length_m: float | None = None, max_curvature: float | None = None,
                     config: ProceduralTrackConfig | None = None) -> Path:
    """Random smooth open track, deterministic for ``seed``.

    ``length_m`` [m] (default 1000) and ``max_curvature`` [1/m] (default 1/30) override the fields of ``config``
    (default ``ProceduralTrackConfig()``) when given.
    """
    cfg = ProceduralTrackConfig() if config is None else config
    overrides: dict[str, float] = {}
    if length_m is not None:
        overrides["length_m"] = length_m
    if max_curvature is not None:
        overrides["max_curvature_per_m"] = max_curvature
    if overrides:
        cfg = dataclasses.replace(cfg, **overrides)
    return procedural_track_from_config(seed, cfg)
