"""A speed profile from user-facing limits: kind, top speed [km/h] and lateral acceleration [g], checked against a car.

What ``vtrack eval --track`` (``--speed-profile``, ``--max-speed-kmh``, ``--max-lateral-g``) and Python users share:
the defaults (``envelope``: the fastest profile inside the friction ellipse, ``EnvelopeLimited``, speeding up as the
driven car's powertrain allows at the throttle its speed loop holds), the ranges in the
user's units, the refusal of a limit the chosen kind does not use, and :func:`check_profile_for_car`: a lateral
limit above the driven car's own steady-state limit is refused, above 90 % of it warned (the env runs this check
where its car meets the profile, so every route gets it).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from vtrack_gym.tracks.maneuvers import GRAVITY_MPS2, KMH_TO_MPS
from vtrack_gym.tracks.path import MAX_V_REF_MPS, MIN_V_REF_MPS
from vtrack_gym.tracks.powertrain_limits import SPEED_LOOP
from vtrack_gym.tracks.speed_profiles import (
    MAX_ACCEL_MPS2,
    ConstantSpeed,
    CurvatureLimited,
    EnvelopeLimited,
    FileSpeed,
    SpeedProfile,
    check_lateral_limit,
)

PROFILE_KINDS: tuple[str, ...] = ("envelope", "curvature", "constant", "file")
"""envelope: the fastest profile inside the friction ellipse (combined lateral and longitudinal acceleration);
curvature: the same limits each axis apart (a corner entry may combine full braking with full lateral acceleration);
constant: one speed; file: the track's v_mps column."""
DEFAULT_PROFILE_KIND = "envelope"
"""Kind when none is given."""
DEFAULT_MAX_SPEED_KMH = 40.0
"""Top speed when none is given [km/h]."""
DEFAULT_MAX_LATERAL_G = 0.7
"""Lateral acceleration limit of the curvature profile when none is given [g]."""
MIN_SPEED_KMH = 3.6 * MIN_V_REF_MPS
"""Lowest top speed [km/h]: the speed profiles' floor (1 m/s) ..."""
MAX_SPEED_KMH = 3.6 * MAX_V_REF_MPS
"""... highest [km/h]: their ceiling (MAX_V_REF_MPS, 100 m/s)."""
MAX_LATERAL_G = MAX_ACCEL_MPS2 / GRAVITY_MPS2
"""Largest lateral acceleration limit [g] (the profiles' 30 m/s^2)."""

_PARAMETERS = ("kind", "max_speed_kmh", "max_lateral_g")


def speed_profile_from_limits(kind: str = DEFAULT_PROFILE_KIND, max_speed_kmh: float | None = None,
                              max_lateral_g: float | None = None, *, vehicle: Any = None,
                              names: Mapping[str, str] | None = None,
                              throttle_authority: float | str | None = SPEED_LOOP) -> SpeedProfile:
    """The profile of ``kind`` (``PROFILE_KINDS``, default ``envelope``) within ``max_speed_kmh`` [km/h] and
    ``max_lateral_g`` [g] (``None``: the defaults, 40 km/h and 0.7 g).

    An ``envelope`` profile speeds up as the driven car's powertrain allows at ``throttle_authority``
    (``EnvelopeLimited.throttle_authority``; default ``SPEED_LOOP``: what the env's PD-FLC can hold, bound by the
    env to its car; ``1.0``: the car's full throttle, for an agent that drives the throttle itself; ``None``: the
    fixed 2 m/s^2 of earlier versions) and never beyond the car's top speed at that authority (a warning names it).

    ``ValueError`` for an unknown kind, a limit outside its range (given in km/h and g) or a limit ``kind`` does
    not use; with ``vehicle`` (``VehicleParams``) also for a lateral limit above that car's steady-state limit
    (a ``UserWarning`` above 90 % of it; :func:`check_profile_for_car`). ``names`` maps a parameter name to how
    the caller's user spells it (e.g. ``"--max-speed-kmh"``), so the message names what the user typed.
    """
    label = {p: p for p in _PARAMETERS} | dict(names or {})
    if kind not in PROFILE_KINDS:
        raise ValueError(f"{label['kind']} must be one of {', '.join(PROFILE_KINDS)} (got {kind!r})")
    unused = {"file": ("max_speed_kmh", "max_lateral_g"), "constant": ("max_lateral_g",)}.get(kind, ())
    given = {"max_speed_kmh": max_speed_kmh, "max_lateral_g": max_lateral_g}
    for param in unused:
        if given[param] is not None:
            what = "the file's v_mps column sets the speeds" if kind == "file" else "no curves limit it"
            raise ValueError(f"{label[param]} does not apply to {label['kind']} {kind} ({what}); fix: drop "
                             f"{label[param]}, or use {label['kind']} envelope")
    speed_kmh = DEFAULT_MAX_SPEED_KMH if max_speed_kmh is None else max_speed_kmh
    lateral_g = DEFAULT_MAX_LATERAL_G if max_lateral_g is None else max_lateral_g
    if not MIN_SPEED_KMH <= speed_kmh <= MAX_SPEED_KMH:
        raise ValueError(f"{label['max_speed_kmh']} must be in [{MIN_SPEED_KMH:g}, {MAX_SPEED_KMH:g}] km/h "
                         f"(got {speed_kmh})")
    if not 0.0 < lateral_g <= MAX_LATERAL_G:
        raise ValueError(f"{label['max_lateral_g']} must be in (0, {MAX_LATERAL_G:.2f}] g (got {lateral_g})")
    if kind == "constant":
        return ConstantSpeed(speed_kmh * KMH_TO_MPS)
    if kind == "file":
        return FileSpeed()
    if kind == "envelope" and throttle_authority is not None:
        profile: Any = EnvelopeLimited(speed_kmh * KMH_TO_MPS, lateral_g * GRAVITY_MPS2, None,
                                       throttle_authority=throttle_authority)
    else:
        cls = EnvelopeLimited if kind == "envelope" else CurvatureLimited
        profile = cls(speed_kmh * KMH_TO_MPS, lateral_g * GRAVITY_MPS2)
    if vehicle is not None:
        check_profile_for_car(profile, vehicle, label["max_lateral_g"])
    return profile


def check_profile_for_car(profile: Any, vehicle: Any, field_name: str | None = None) -> None:
    """Check the lateral limit of a ``CurvatureLimited`` or ``EnvelopeLimited`` ``profile`` against ``vehicle``'s
    (``VehicleParams``) least steady-state lateral limit up to the profile's top speed
    (``vehicle.steady_state.lowest_lateral_limit_mps2``, below mu g): ``ValueError`` above it naming
    ``field_name`` (default ``<Profile>.max_lateral_accel_mps2``), the car's limit in g and m/s^2 and the car;
    ``UserWarning`` above 90 % of it. Other profiles (constant, file, ramps) pass unchecked."""
    if not isinstance(profile, (CurvatureLimited, EnvelopeLimited)):
        return
    from vtrack_gym.vehicle.steady_state import lowest_lateral_limit_mps2

    limit = lowest_lateral_limit_mps2(vehicle, profile.max_speed_mps)
    name = field_name or f"{type(profile).__name__}.max_lateral_accel_mps2"
    check_lateral_limit(profile.max_lateral_accel_mps2, limit, vehicle.name, name,
                        f"at speeds up to {profile.max_speed_mps * 3.6:.0f} km/h")
