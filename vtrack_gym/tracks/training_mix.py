"""The RL training bank: four kinds of road, each with its own speed profile (``TrainingMixProfile``).

=============  ============================================================  ==========================================
kind           geometry                                                      speed profile (drawn per track)
=============  ============================================================  ==========================================
``twisty``     procedural, radii down to 18 m, 800 m                         curvature-limited: max 6-30 m/s, 0.45-0.85 g
``highway``    procedural, radii down to 120 m, 800 m                        curvature-limited: max 15-36 m/s, 0.45-0.85 g
``hairpin``    procedural, radii down to 5.5 m, turns up to 170 deg, 500 m   curvature-limited: max 6-20 m/s, 0.45-0.8 g
``lanechange`` ISO 3888-1 lane sequence (gates), lengths x1-2.5, 2.5-4 m      constant: 50-100 % of the speed whose
               offset, 30-100 m approach                                     centre-line peak is 0.8 g, <= 36 m/s
=============  ============================================================  ==========================================

Every evaluation regime of the package lies inside: Case 1 (R >= 20 m at 11 m/s from rest), DLC120-v0 (3.5 m at
33.3 m/s, x2 lengths), the ISO manoeuvres, and user circuits under ``curvature_limited(40 km/h, 0.7 g)`` with
6 m hairpins. A track's profile parameters are drawn from its name (kind and index), so the bank and its
profiles are a pure function of the seed.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

from vtrack_gym.tracks.dlc import DoubleLaneChangeSpec, build_double_lane_change
from vtrack_gym.tracks.path import Path
from vtrack_gym.tracks.procedural import ProceduralTrackConfig, procedural_track_from_config
from vtrack_gym.tracks.speed_profiles import ConstantSpeed, CurvatureLimited

GRAVITY_MPS2 = 9.81
KINDS: tuple[str, ...] = ("twisty", "highway", "hairpin", "lanechange")
"""The kinds of road in the bank, in the order they repeat (track k is of kind ``KINDS[k % 4]``)."""
DLC120_SPEED_MPS = 120.0 / 3.6
DLC120_PEAK_G = 0.81
"""DLC120-v0 (length x2, 3.5 m offset) at 33.3 m/s peaks at 0.81 g on its centre-line; the peak scales with
v^2 offset / length^2, which sizes the lane-change speeds."""
LANE_CHANGE_PEAK_G = 0.8

_PROCEDURAL: dict[str, ProceduralTrackConfig] = {
    "twisty": ProceduralTrackConfig(length_m=800.0, max_curvature_per_m=1.0 / 18.0, max_dkappa_per_m2=0.008),
    "highway": ProceduralTrackConfig(length_m=800.0, max_curvature_per_m=1.0 / 120.0, max_dkappa_per_m2=0.004),
    "hairpin": ProceduralTrackConfig(length_m=500.0, max_curvature_per_m=1.0 / 5.5, max_dkappa_per_m2=0.06,
                                     min_curvature_fraction=0.1, max_arc_turn_rad=3.0, max_heading_rad=2.6,
                                     min_clearance_m=8.0, half_width_m=3.0, min_blend_m=3.0, lead_in_m=20.0,
                                     max_attempts=400),
}
_SPEED_RANGES: dict[str, tuple[float, float, float, float]] = {  # max speed lo, hi [m/s]; lateral lo, hi [g]
    "twisty": (6.0, 30.0, 0.45, 0.85),
    "highway": (15.0, 36.0, 0.45, 0.85),
    "hairpin": (6.0, 20.0, 0.45, 0.8),
}


def _rng(name: str) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32(name.encode("utf-8")))


def _kind(path: Path) -> str:
    kind = path.name.split("-", 1)[0].removeprefix("mix_")
    if kind not in KINDS:
        raise ValueError(f"{path.name!r} is not a training-mix track (names start with mix_<kind>-)")
    return kind


def lane_change_spec(rng: np.random.Generator, vehicle_width_m: float) -> DoubleLaneChangeSpec:
    """A random ISO 3888-1 style lane change: lengths x1-2.5, offset 2.5-4 m, approach 30-100 m."""
    return DoubleLaneChangeSpec(vehicle_width_m=vehicle_width_m, length_scale=float(rng.uniform(1.0, 2.5)),
                                lane_offset_m=float(rng.uniform(2.5, 4.0)), approach_m=float(rng.uniform(30.0, 100.0)))


def lane_change_max_speed_mps(spec: DoubleLaneChangeSpec) -> float:
    """Speed [m/s] at which ``spec``'s centre-line peaks at ``LANE_CHANGE_PEAK_G`` (scaled from DLC120-v0)."""
    scale = (spec.length_scale / 2.0) * math.sqrt(3.5 / spec.lane_offset_m)
    return DLC120_SPEED_MPS * scale * math.sqrt(LANE_CHANGE_PEAK_G / DLC120_PEAK_G)


@dataclass(frozen=True)
class TrainingMixProfile:
    """The speed profile of every training-mix track, drawn from the track's name (see the module table)."""

    def row_speeds(self, path: Path) -> np.ndarray:
        """Reference speed at every row of ``path`` [m/s]."""
        kind = _kind(path)
        rng = _rng(path.name + "/speed")
        if kind == "lanechange":
            spec = lane_change_spec(_rng(path.name), float(path.name.rsplit("-w", 1)[1]))
            v = min(36.0, max(8.0, lane_change_max_speed_mps(spec) * float(rng.uniform(0.5, 1.0))))
            return ConstantSpeed(v).row_speeds(path)
        v_lo, v_hi, g_lo, g_hi = _SPEED_RANGES[kind]
        profile = CurvatureLimited(float(rng.uniform(v_lo, v_hi)), float(rng.uniform(g_lo, g_hi)) * GRAVITY_MPS2)
        return profile.row_speeds(path)


def training_bank(seed: int, size: int, vehicle_width_m: float) -> tuple[Path, ...]:
    """``size`` training tracks, kinds cycling through ``KINDS``; deterministic for ``seed``."""
    from dataclasses import replace

    paths = []
    for k in range(size):
        kind = KINDS[k % len(KINDS)]
        if kind == "lanechange":
            name = f"mix_lanechange-{seed}-{k}-w{vehicle_width_m:g}"
            path = build_double_lane_change(lane_change_spec(_rng(name), vehicle_width_m))
        else:
            name = f"mix_{kind}-{seed}-{k}"
            path = procedural_track_from_config(seed + k, _PROCEDURAL[kind])
        paths.append(replace(path, name=name))
    return tuple(paths)
