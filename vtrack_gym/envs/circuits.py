"""The circuits of the ``trajectory`` suite as registered ids: a track with a speed profile that varies along it,
so an agent that drives the pedals is scored on the timing of its trajectory as well as its path.

Each id is ``vtrack/Track-v0`` with its ``track=`` and ``speed_profile=`` fixed (``CIRCUIT_SETUPS``): the
friction-ellipse profile ``CIRCUIT_PROFILE`` (70 km/h cap, 4 m/s^2 lateral, 2 m/s^2 forward, 3 m/s^2 braking, a
standing start, so the reference leaves s = 0 at 1 m/s as the car does), from standstill, one lap or the whole
road:

* ``vtrack/HandlingCourseCircuit-v0``: the paper's 2.33 km handling course (radii down to 20 m);
* ``vtrack/RingCircuit-v0``: the shipped example map's stadium loop (``tracks.example_maps``, ``ring.gpx``: two
  100 m straights, two R 40 m half turns entered through 20 m clothoids);
* ``vtrack/ProceduralRoad-v0``: an open procedural road (``tracks.procedural``, the bank of
  ``LateralTrackingRandom-v0``; the reset seed draws which), not a closed loop.

Imports nothing heavy (the profile is a frozen dataclass of ``tracks.speed_profiles``, numpy only).
"""

from __future__ import annotations

from typing import Any

CIRCUIT_IDS: tuple[str, ...] = ("vtrack/HandlingCourseCircuit-v0", "vtrack/RingCircuit-v0", "vtrack/ProceduralRoad-v0")
"""The registered circuit ids, in the ``trajectory`` suite's order."""
CIRCUIT_MAX_SPEED_KMH = 70.0
"""Speed cap of ``CIRCUIT_PROFILE`` [km/h]."""
CIRCUIT_LATERAL_MPS2 = 4.0
"""Lateral acceleration of ``CIRCUIT_PROFILE`` [m/s^2] (0.41 g, half the paper's car's grip)."""


def circuit_profile() -> Any:
    """The circuits' speed profile (``tracks.speed_profiles.EnvelopeLimited``, see the module docstring)."""
    from vtrack_gym.tracks.speed_profiles import EnvelopeLimited

    return EnvelopeLimited(max_speed_mps=CIRCUIT_MAX_SPEED_KMH / 3.6, max_lateral_accel_mps2=CIRCUIT_LATERAL_MPS2,
                           start_speed_mps=1.0)


def circuit_setups() -> dict[str, tuple[str, dict[str, Any]]]:
    """``{id: (scenario, make kwargs)}`` of the circuits (registered by ``envs.registration.register_envs``)."""
    from vtrack_gym.tracks.example_maps import example_map

    tracks = ("handling_course", str(example_map("ring.gpx")), "procedural")
    return {env_id: ("Track-v0", {"track": track, "speed_profile": circuit_profile()})
            for env_id, track in zip(CIRCUIT_IDS, tracks, strict=True)}
