"""Case 2 of the paper: ISO 3888-1 double lane change (driven at 120 km/h) with its cone gates as data.

Gate structure (ISO 3888-1, reference-data section 3; w = vehicle width [m]):

=======  ===============  ==============  =====================================================
section  ISO length [m]   lane width [m]  lateral placement of the lane
=======  ===============  ==============  =====================================================
1        15               1.1 w + 0.25    centred on y = 0
2        30               -               lane change (centre-line transition)
3        25               1.2 w + 0.25    centre 3.5 m LEFT of lane 1's centre (CHOICE, paper)
4        25               -               lane change back (centre-line transition)
5        15               1.3 w + 0.25    right boundary aligned with lane 1's right boundary
run-out  15               -               straight
=======  ===============  ==============  =====================================================

CHOICE, length scale: ISO's native lengths make the manoeuvre a limit test at ~80 km/h. At 120 km/h
(33.33 m/s) a smooth centre-line through the lane centres over a 30 m section would need ~2.5 g, impossible at
mu = 0.9. All longitudinal lengths are therefore multiplied by ``length_scale`` (default 2.0: 30 / 60 / 50 / 50 /
30 m, run-out 30 m). With the default transition shape (``ramp_fraction`` 0.135) the peak centre-line curvature
is 7.115e-3 1/m in section 4 (5.23e-3 1/m in section 2), i.e. a peak lateral acceleration v^2 kappa of 0.806 g
at 120 km/h (0.593 g in section 2); the paper reports 0.81 g. ``length_scale = 1.0`` is the exact ISO geometry
(peak v^2 kappa 3.2 g at 120 km/h).

Centre-line: a straight approach of ``approach_m`` [m], then straight at the lane centres in sections 1, 3 and 5
and C^2 transitions only inside sections 2 and 4. A transition is a trapezoidal curvature pulse
(0 -> +K -> -K -> 0, smootherstep blends over ``ramp_fraction`` of its length at the ends and twice that at the
reversal), antisymmetric so the heading returns exactly to 0; K and its arc length are solved so that it spans
exactly the section length in X and the lane offset in Y. Built with ``Path.from_curvature`` (exact kappa and
dkappa/ds). Open path; ``half_width_m`` = 4.0 m for termination. Start at (0, 0), heading +X. With ``overlap_m``
> 0 the transitions also reach that far into the lanes (gentler, the gates become anchored rectangles; see
``tracks.lanes``); the default 0 is the paper's construction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks.lanes import LaneSection, lane_sequence_path
from vtrack_gym.tracks.path import DEFAULT_DS_M, Gate, Path

VERSION = "1"
ISO_SECTION_LENGTHS_M = (15.0, 30.0, 25.0, 25.0, 15.0)   # sections 1..5 at length_scale = 1
ISO_RUN_OUT_M = 15.0
LANE_WIDTH_FACTORS = (1.1, 1.2, 1.3)                      # lanes 1, 3, 5: factor * w + 0.25 m
LANE_WIDTH_ADD_M = 0.25
OUTLINE_STEP_M = 0.25                                     # spacing of the body-outline points [m]


@documented
@dataclass(frozen=True)
class DoubleLaneChangeSpec:
    """Parameters of the double lane change (lengths [m], widths [m])."""

    vehicle_width_m: float = ranged(1.916, gt=0.5, le=4.0, unit="m")  # w, the paper's car (IDSC body width)
    length_scale: float = ranged(2.0, gt=0.5, le=10.0)  # CHOICE: multiplies every ISO longitudinal length (1.0 = ISO)
    approach_m: float = ranged(100.0, ge=0.0, le=10000.0, unit="m")  # straight before section 1
    lane_offset_m: float = ranged(3.5, gt=0.5, le=20.0, unit="m")  # lane-3 centre left of lane-1 centre (paper)
    # transition shape: blend length / transition length
    ramp_fraction: float = ranged(0.135, gt=0.0, lt=0.25)
    # transitions reach this far into the lanes before/after them; > 0 anchors the gates (see tracks.lanes)
    overlap_m: float = ranged(0.0, ge=0.0, le=50.0, unit="m")
    half_width_m: float = ranged(4.0, gt=0.5, le=50.0, unit="m")  # drivable half width for off-road termination
    ds_m: float = ranged(DEFAULT_DS_M, gt=0.0, le=5.0, unit="m")  # table spacing

    def __post_init__(self) -> None:
        validate(self)

    def lane_widths_m(self) -> tuple[float, float, float]:
        """Widths of lanes 1, 3, 5 [m]."""
        w = self.vehicle_width_m
        return tuple(f * w + LANE_WIDTH_ADD_M for f in LANE_WIDTH_FACTORS)  # type: ignore[return-value]

    def lane_centres_m(self) -> tuple[float, float, float]:
        """Global Y of the centres of lanes 1, 3, 5 [m] (lane 1 centred on y = 0)."""
        w1, _, w5 = self.lane_widths_m()
        return 0.0, self.lane_offset_m, 0.5 * (w5 - w1)

    def section_lengths_m(self) -> tuple[float, ...]:
        """Scaled lengths of sections 1..5 and the run-out [m]."""
        return tuple(self.length_scale * v for v in (*ISO_SECTION_LENGTHS_M, ISO_RUN_OUT_M))


def build_double_lane_change(spec: DoubleLaneChangeSpec) -> Path:
    """Path of the double lane change described by ``spec`` (see the module docstring)."""
    l1, l2, l3, l4, l5, l_out = spec.section_lengths_m()
    y1, y3, y5 = spec.lane_centres_m()
    w1, w3, w5 = spec.lane_widths_m()
    lanes = (LaneSection(l1, w1, y1, "lane 1 (entry)"), LaneSection(l3, w3, y3, "lane 3 (side lane)"),
             LaneSection(l5, w5, y5, "lane 5 (exit)"))
    name = f"dlc_iso3888-1_w{spec.vehicle_width_m:g}_x{spec.length_scale:g}"
    if spec.overlap_m > 0.0:
        name += f"_o{spec.overlap_m:g}"
    if spec.lane_offset_m != DoubleLaneChangeSpec.lane_offset_m:
        name += f"_y{spec.lane_offset_m:g}"
    return lane_sequence_path(lanes, (l2, l4), approach_m=spec.approach_m, run_out_m=l_out,
                              ramp_fraction=spec.ramp_fraction, half_width_m=spec.half_width_m, ds_m=spec.ds_m,
                              name=name, version=VERSION, overlap_m=spec.overlap_m)


@lru_cache(maxsize=16)
def double_lane_change(vehicle_width_m: float = 1.916, length_scale: float = 2.0, approach_m: float = 100.0) -> Path:
    """ISO 3888-1 double lane change for a car of width vehicle_width_m [m]; longitudinal lengths x length_scale
    (2.0 for 120 km/h, 1.0 = ISO; see the module docstring), approach_m [m] of straight before section 1. Cached."""
    return build_double_lane_change(DoubleLaneChangeSpec(vehicle_width_m=vehicle_width_m, length_scale=length_scale,
                                                         approach_m=approach_m))


def car_outline(x: np.ndarray, y: np.ndarray, psi: np.ndarray, vehicle_length_m: float, vehicle_width_m: float,
                cg_to_front_m: float | None = None, step_m: float = OUTLINE_STEP_M) -> tuple[np.ndarray, np.ndarray]:
    """Global X, Y [m] of points around the body rectangle (the 4 corners and points along every side at most
    ``step_m`` [m] apart) of cars at CG (x, y) [m] with heading psi [rad] -> two arrays of shape (T, P)."""
    if not step_m > 0.0:
        raise ValueError(f"step_m must be > 0 m (got {step_m})")
    x = np.atleast_1d(np.asarray(x, dtype=float))
    y = np.atleast_1d(np.asarray(y, dtype=float))
    psi = np.atleast_1d(np.asarray(psi, dtype=float))
    front = 0.5 * vehicle_length_m if cg_to_front_m is None else cg_to_front_m
    rear = front - vehicle_length_m
    half = 0.5 * vehicle_width_m
    n_long = max(1, int(np.ceil(vehicle_length_m / step_m)))
    n_lat = max(1, int(np.ceil(vehicle_width_m / step_m)))
    t_long = np.linspace(0.0, 1.0, n_long + 1)[:-1]
    t_lat = np.linspace(0.0, 1.0, n_lat + 1)[:-1]
    lon = np.concatenate((front + (rear - front) * t_long, np.full(n_lat, rear),      # left side FL -> RL, rear
                          rear + (front - rear) * t_long, np.full(n_lat, front)))     # right side RR -> FR, front
    lat = np.concatenate((np.full(n_long, half), half - 2.0 * half * t_lat,
                          np.full(n_long, -half), -half + 2.0 * half * t_lat))
    c, s = np.cos(psi)[:, None], np.sin(psi)[:, None]
    return x[:, None] + c * lon - s * lat, y[:, None] + s * lon + c * lat


def gate_boundaries(path: Path, gate: Gate, n: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Global X, Y [m] of ``n`` points along the left and the right boundary (the cone lines) of ``gate`` on
    ``path`` -> two arrays of shape (n, 2): offsets from the centre-line, or from the anchor line of an anchored
    gate. Use it to draw cones."""
    if n < 2:
        raise ValueError(f"n must be >= 2 (got {n})")
    out = []
    if gate.anchor is None:
        row = path.sample(np.linspace(gate.s_start_m, gate.s_end_m, n))
        x, y, c, s = row.x, row.y, np.cos(row.psi), np.sin(row.psi)
    else:
        x0, y0, psi0 = gate.anchor
        u = np.linspace(0.0, gate.lane_length_m, n)
        c, s = np.full(n, math.cos(psi0)), np.full(n, math.sin(psi0))
        x, y = x0 + u * c, y0 + u * s
    for lat in (gate.y_left_m, gate.y_right_m):
        out.append(np.column_stack((x - lat * s, y + lat * c)))
    return out[0], out[1]


def gate_violations(path: Path, x: np.ndarray, y: np.ndarray, psi: np.ndarray, vehicle_length_m: float,
                    vehicle_width_m: float, cg_to_front_m: float | None = None) -> int:
    """Number of ``path.gates`` in which any point of the car's outline (corners and sides, sampled every
    ``OUTLINE_STEP_M``) left the lane at any sample of the trajectory x, y [m], psi [rad] (arrays of shape (T,));
    the "cones hit" count of ISO 3888. Sampling the sides as well as the corners catches a single-cone gate (a
    slalom cone, shorter than the car) that the body passes between its corners. A gate without an anchor is
    checked in the path's Frenet frame (station window, e_y bounds; each outline point projected from the car's
    station), an anchored gate against its fixed rectangle: the env's compiled ``kernels.body_outside_gates``."""
    from vtrack_gym.tracks import kernels

    if not (vehicle_length_m > 0.0 and vehicle_width_m > 0.0):
        raise ValueError(f"vehicle_length_m and vehicle_width_m must be > 0 (got {vehicle_length_m}, "
                         f"{vehicle_width_m})")
    if not path.gates:
        return 0
    x, y, psi = (np.ascontiguousarray(np.atleast_1d(np.asarray(a, dtype=float))) for a in (x, y, psi))
    lon, lat = car_outline(0.0, 0.0, 0.0, vehicle_length_m, vehicle_width_m, cg_to_front_m)
    station = path.project(x, y).s
    hit = np.zeros((x.size, len(path.gates)), dtype=np.bool_)
    kernels.body_outside_gates(path.table, path.ds_m, path.length_m, path.closed, kernels.gate_rows(path.gates), x,
                               y, psi, station, lon.ravel(), lat.ravel(), math.inf, hit, np.zeros(kernels.N_COLS))
    return int(np.count_nonzero(hit.any(axis=0)))
