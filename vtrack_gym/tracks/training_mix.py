"""The RL training bank: four kinds of road (half the bank lane changes), each with its own speed profile
(``TrainingMixProfile``).

=============  ============================================================  ==========================================
kind           geometry                                                      speed profile (drawn per track)
=============  ============================================================  ==========================================
``twisty``     procedural, radii down to 18 m, 800 m                         curvature-limited: 6-30 m/s, 0.45-0.85 g
``highway``    procedural, radii down to 120 m, 800 m                        curvature-limited: 15-36 m/s, 0.45-0.85 g
``hairpin``    procedural, radii down to 5.5 m, turns up to 170 deg, 500 m   curvature-limited: 6-20 m/s, 0.45-0.8 g
``lanechange`` 8 cone-lined lanes (ISO 3888 widths 1.1-1.3 w + 0.25 m), each  constant, 15-37 m/s (drawn first; the
               2.5-4 m left or right of the road and back, transitions       transitions are sized for it)
               sized for a centre-line peak of 0.4-0.85 g at the speed
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

from vtrack_gym.tracks.maneuvers import GRAVITY_MPS2
from vtrack_gym.tracks.path import DEFAULT_DS_M, Path
from vtrack_gym.tracks.procedural import ProceduralTrackConfig, procedural_track_from_config
from vtrack_gym.tracks.speed_profiles import ConstantSpeed, CurvatureLimited

KINDS: tuple[str, ...] = ("twisty", "highway", "hairpin", "lanechange")
"""The kinds of road in the bank."""
BANK_PATTERN: tuple[str, ...] = ("twisty", "lanechange", "highway", "lanechange", "hairpin", "lanechange")
"""Track k is of kind ``BANK_PATTERN[k % 6]``: half the episodes are lane-change courses (they are the shortest,
~20-30 s against 60 s, and the most demanding at speed), a sixth each twisty, highway and hairpin roads."""
DLC120_SPEED_MPS = 120.0 / 3.6
DLC120_PEAK_G = 0.81
"""DLC120-v0 (length x2, 3.5 m offset) at 33.3 m/s peaks at 0.81 g on its centre-line; the peak scales with
v^2 offset / length^2, which sizes the lane-change speeds."""

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


LANE_CHANGE_SPEED_MPS = (15.0, 37.0)
"""Speed range of the lane-change courses [m/s] (DLC120-v0 drives at 33.3 m/s, the robust suite up to 36.7)."""
LANE_CHANGE_PEAK_G = (0.4, 0.85)
"""Centre-line peak lateral acceleration of each transition [g] (DLC120-v0: 0.81 g)."""
N_LANES = 8


def _lane_change_speed(rng: np.random.Generator) -> float:
    """The course's speed [m/s]: the first draw of the course's generator (the profile re-draws it by name)."""
    return float(rng.uniform(*LANE_CHANGE_SPEED_MPS))


def lane_change_course(name: str, vehicle_width_m: float) -> Path:
    """``N_LANES`` cone-lined lanes alternating between the road's line and 2.5-4 m left or right of it, each
    transition sized so that the centre-line peaks at 0.4-0.9 g at the course's speed (scaled from DLC120-v0:
    a 3.5 m offset over 50 m at 33.3 m/s peaks at 0.81 g; the peak goes as v^2 offset / length^2)."""
    from vtrack_gym.tracks.lanes import LaneSection, lane_sequence_path

    rng = _rng(name)
    v = _lane_change_speed(rng)
    lanes, gaps = [], []
    y = 0.0
    for k in range(N_LANES):
        width = float(rng.uniform(1.1, 1.3)) * vehicle_width_m + 0.25
        lanes.append(LaneSection(float(rng.uniform(10.0, 30.0)) * max(v / 20.0, 1.0), width, y, f"lane {k + 1}"))
        if k < N_LANES - 1:
            offset = float(rng.uniform(2.5, 4.0))
            new_y = 0.0 if y != 0.0 else (offset if rng.random() < 0.5 else -offset)
            peak_g = float(rng.uniform(*LANE_CHANGE_PEAK_G))
            gaps.append(50.0 * (v / DLC120_SPEED_MPS) * math.sqrt(DLC120_PEAK_G / peak_g * abs(new_y - y) / 3.5))
            y = new_y
    return lane_sequence_path(lanes, gaps, approach_m=float(rng.uniform(30.0, 60.0)), run_out_m=30.0,
                              ramp_fraction=0.135, half_width_m=4.0, ds_m=DEFAULT_DS_M, name=name,
                              version="mix-1")


@dataclass(frozen=True)
class TrainingMixProfile:
    """The speed profile of every training-mix track, drawn from the track's name (see the module table)."""

    def row_speeds(self, path: Path) -> np.ndarray:
        """Reference speed at every row of ``path`` [m/s]."""
        kind = _kind(path)
        if kind == "lanechange":
            return ConstantSpeed(_lane_change_speed(_rng(path.name))).row_speeds(path)
        rng = _rng(path.name + "/speed")
        v_lo, v_hi, g_lo, g_hi = _SPEED_RANGES[kind]
        profile = CurvatureLimited(float(rng.uniform(v_lo, v_hi)), float(rng.uniform(g_lo, g_hi)) * GRAVITY_MPS2)
        return profile.row_speeds(path)


def training_bank(seed: int, size: int, vehicle_width_m: float) -> tuple[Path, ...]:
    """``size`` training tracks, kinds cycling through ``BANK_PATTERN``; deterministic for ``seed``."""
    from dataclasses import replace

    paths = []
    for k in range(size):
        kind = BANK_PATTERN[k % len(BANK_PATTERN)]
        if kind == "lanechange":
            name = f"mix_lanechange-{seed}-{k}-w{vehicle_width_m:g}"
            path = lane_change_course(name, vehicle_width_m)
        else:
            name = f"mix_{kind}-{seed}-{k}"
            path = procedural_track_from_config(seed + k, _PROCEDURAL[kind])
        paths.append(replace(path, name=name))
    return tuple(paths)
