"""Reference paths: an arc-length parameterised centre-line (``Path``), the paper's two scenarios (the Case-1
handling course and the Case-2 ISO 3888-1 double lane change with cone gates), standard manoeuvres as data
(``tracks.maneuvers``: ISO 3888-1/-2, ISO 4138, slalom, step curvature), procedural training tracks, track files
(``load_track`` resolves a built-in name, a Path or a file of any format of ``FORMATS``: a CSV of points, an
OpenDRIVE, Lanelet2, CommonRoad or GPX map, read as a ``TrackRead`` says), speed profiles (``speed_table``), a
track's minimum-curvature racing line (``racing_line``) and the car's quasi-steady-state lap-time bound
(``lap_time_bound``).

``import vtrack_gym.tracks`` imports numpy only (no numba, no scipy); the numba kernels used by the env's compiled
step live in ``vtrack_gym.tracks.kernels`` and are imported on demand.
"""

from vtrack_gym.tracks.csv_loader import load_track_csv
from vtrack_gym.tracks.dlc import (
    DoubleLaneChangeSpec,
    build_double_lane_change,
    double_lane_change,
    gate_boundaries,
    gate_violations,
)
from vtrack_gym.tracks.formats import FORMATS, TrackRead
from vtrack_gym.tracks.gg_limits import GGLimits, gg_limits
from vtrack_gym.tracks.handling_course import handling_course
from vtrack_gym.tracks.lanes import LaneSection, lane_sequence_path
from vtrack_gym.tracks.lap_time import LapTimeBound, QuasiSteadyState, lap_time_bound
from vtrack_gym.tracks.maneuvers import (
    MANEUVERS,
    SUCCESS_CRITERIA,
    Maneuver,
    ManeuverSpec,
    build_maneuver,
    grip_limit_speed_mps,
)
from vtrack_gym.tracks.path import Gate, Path, PathSample, Projection, wrap_angle
from vtrack_gym.tracks.procedural import ProceduralTrackConfig, procedural_track, procedural_track_from_config
from vtrack_gym.tracks.profiles import CurvatureProfile, SineElevation
from vtrack_gym.tracks.raceline import RacingLine, RacingLineSpec, racing_line, solve_racing_line
from vtrack_gym.tracks.sources import file_digest, load_track, path_digest
from vtrack_gym.tracks.speed_profiles import (
    ConstantSpeed,
    CurvatureLimited,
    EnvelopeLimited,
    FileSpeed,
    SpeedProfile,
    SpeedRamp,
    SpeedTable,
    as_speed_profile,
    speed_table,
)
from vtrack_gym.tracks.table import (
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
)
from vtrack_gym.tracks.track_registry import build_track, register_track, track_names, unregister_track

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
    "FORMATS",
    "MANEUVERS",
    "N_COLS",
    "SUCCESS_CRITERIA",
    "ConstantSpeed",
    "CurvatureLimited",
    "CurvatureProfile",
    "DoubleLaneChangeSpec",
    "EnvelopeLimited",
    "FileSpeed",
    "GGLimits",
    "Gate",
    "LaneSection",
    "LapTimeBound",
    "Maneuver",
    "ManeuverSpec",
    "Path",
    "PathSample",
    "ProceduralTrackConfig",
    "Projection",
    "QuasiSteadyState",
    "RacingLine",
    "RacingLineSpec",
    "SineElevation",
    "SpeedProfile",
    "SpeedRamp",
    "SpeedTable",
    "TrackRead",
    "as_speed_profile",
    "build_double_lane_change",
    "build_maneuver",
    "build_track",
    "double_lane_change",
    "file_digest",
    "gate_boundaries",
    "gate_violations",
    "gg_limits",
    "grip_limit_speed_mps",
    "handling_course",
    "lane_sequence_path",
    "lap_time_bound",
    "load_track",
    "load_track_csv",
    "path_digest",
    "procedural_track",
    "procedural_track_from_config",
    "racing_line",
    "register_track",
    "solve_racing_line",
    "speed_table",
    "track_names",
    "unregister_track",
    "wrap_angle",
]
