"""Reference paths: an arc-length parameterised centre-line (``Path``), the paper's two scenarios (the Case-1
handling course and the Case-2 ISO 3888-1 double lane change with cone gates), procedural training tracks and a
CSV loader.

``import vtrack_gym.tracks`` imports numpy only (no numba, no scipy); the numba kernels used by the env's compiled
step live in ``vtrack_gym.tracks.kernels`` and are imported on demand.
"""

from vtrack_gym.tracks.csv_loader import load_track_csv
from vtrack_gym.tracks.dlc import DoubleLaneChangeSpec, build_double_lane_change, double_lane_change, gate_violations
from vtrack_gym.tracks.handling_course import handling_course
from vtrack_gym.tracks.path import (
    COL_DKAPPA,
    COL_GRADE,
    COL_KAPPA,
    COL_PSI,
    COL_X,
    COL_Y,
    COL_Z,
    COL_ZPP,
    COLUMN_NAMES,
    N_COLS,
    Gate,
    Path,
    PathSample,
    Projection,
    wrap_angle,
)
from vtrack_gym.tracks.procedural import ProceduralTrackConfig, procedural_track, procedural_track_from_config
from vtrack_gym.tracks.profiles import CurvatureProfile, SineElevation

__all__ = [
    "COLUMN_NAMES",
    "COL_DKAPPA",
    "COL_GRADE",
    "COL_KAPPA",
    "COL_PSI",
    "COL_X",
    "COL_Y",
    "COL_Z",
    "COL_ZPP",
    "N_COLS",
    "CurvatureProfile",
    "DoubleLaneChangeSpec",
    "Gate",
    "Path",
    "PathSample",
    "ProceduralTrackConfig",
    "Projection",
    "SineElevation",
    "build_double_lane_change",
    "double_lane_change",
    "gate_violations",
    "handling_course",
    "load_track_csv",
    "procedural_track",
    "procedural_track_from_config",
    "wrap_angle",
]
