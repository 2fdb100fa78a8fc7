"""The vtrack observation of a car on a highway-env lane, written through the native env's observation writer.

The Frenet quantities come from the lane's exact geometry (``LaneGeometry``); the row is laid out by
``ObservationLayout`` and written by ``vtrack_gym.envs.kernels.write_scalar_fields``, the same writer as the
native env's compiled step, so both envs put every field at the same index with the same float32 rounding.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from vtrack_gym.envs.observation import ObservationLayout
from vtrack_gym.interop.lane_geometry import LaneGeometry
from vtrack_gym.tracks import wrap_angle


class LaneObservation(NamedTuple):
    """An observation row and the reference quantities the adapter's episode logic needs."""

    obs: np.ndarray      # (layout.size,) float32
    station_m: float     # arc length of the projection on the lane [m]
    e_y_m: float         # signed perpendicular offset, left-positive [m]
    e_phi_rad: float     # heading error in (-pi, pi] [rad]


def observe_on_lane(geom: LaneGeometry, layout: ObservationLayout, x_m: float, y_m: float, psi_rad: float,
                    v_x_mps: float, v_y_mps: float, yaw_rate_radps: float, road_wheel_angle_rad: float,
                    v_x_dot_mps2: float, target_speed_mps: float) -> LaneObservation:
    """Observation of a car at world pose (x, y, psi) with body speeds (v_x, v_y), yaw rate r and steering angle.

    ``v_x_dot_mps2`` is d v_x / dt (the reference yaw acceleration uses it like the native env uses a_x).
    """
    from vtrack_gym.envs.kernels import write_scalar_fields

    x_star, e_y, psi_ref, kappa, dkappa = geom.project(x_m, y_m)
    station = geom.station_at(x_star)
    e_phi = float(wrap_angle(psi_rad - psi_ref))
    s_dot = (v_x_mps * math.cos(e_phi) - v_y_mps * math.sin(e_phi)) / (1.0 - kappa * e_y)
    obs = np.empty(layout.size, dtype=np.float32)
    write_scalar_fields(obs, e_y, e_phi, v_x_mps, v_y_mps, yaw_rate_radps, road_wheel_angle_rad, target_speed_mps,
                        kappa, dkappa, s_dot, v_x_dot_mps2)
    obs[layout.preview] = geom.curvature_at_stations(station + layout.preview_distances(v_x_mps))
    obs[layout.speed_preview] = target_speed_mps  # the adapter holds one speed
    return LaneObservation(obs, station, e_y, e_phi)
