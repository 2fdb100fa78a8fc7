"""Reference speed along a path, v_ref(s): constant, curvature-limited, a slow ramp, or the path's own speed column.

A profile is a frozen parameter dataclass; :func:`speed_table` evaluates it on a path's rows and returns a
:class:`SpeedTable` (one speed per table row, the same s grid) with the queries ``v_ref(s)`` and ``preview``.
Between rows v^2 is interpolated linearly, so a ramp of constant acceleration a is exact everywhere
(v^2 linear in s with slope 2a), and a limit that holds at the rows holds in between.

``CurvatureLimited`` is the usual two-pass profile: the lateral limit v <= sqrt(a_lat / |kappa|) (capped at
the maximum speed), then a forward pass (v_{i+1}^2 <= v_i^2 + 2 a_accel ds) and a backward pass
(v_i^2 <= v_{i+1}^2 + 2 a_decel ds). It limits each axis apart, so a corner entry may combine the full lateral
with the full braking acceleration: more grip than the car has when the lateral limit is near the car's own.
``EnvelopeLimited`` runs the same passes inside a friction ellipse (combined acceleration). Either profile's lateral
limit is checked against the driven car's own steady-state limit (``vehicle.steady_state``; feasibility is judged
against that limit, which lies below mu g: Pacejka peak factors D < 1, load transfer, drive force) where the env
meets its car (``speed_limits.check_profile_for_car``). On a closed loop the passes
start at the slowest point of the lateral limit, which no pass can lower, and run once around, so the profile is
consistent across the wrap.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Protocol, runtime_checkable

import numpy as np

from vtrack_gym._ranges import OPTIONAL, documented, ranged, validate
from vtrack_gym.tracks.interpolation import interp_linear
from vtrack_gym.tracks.path import MAX_V_REF_MPS, MIN_V_REF_MPS, Path
from vtrack_gym.tracks.powertrain_limits import check_powertrain_fields

MAX_ACCEL_MPS2 = 30.0      # upper bound of every acceleration parameter (3 g) [m/s^2]
KAPPA_FLOOR_PER_M = 1e-9   # |kappa| below this is a straight for the lateral limit [1/m]
SUBSTEPS = 16              # curvature samples per row interval for the lateral limit
G_FOR_MESSAGES_MPS2 = 9.81  # g, to state accelerations in g in messages (the value of vehicle.params.GRAVITY_MPS2)


@runtime_checkable
class SpeedProfile(Protocol):
    """A speed profile: reference speed [m/s] at every row of a path's table."""

    def row_speeds(self, path: Path) -> np.ndarray: ...


@documented
@dataclass(frozen=True)
class ConstantSpeed:
    """v_ref(s) = v_mps [m/s] everywhere (``MIN_V_REF_MPS`` = 1 m/s to ``MAX_V_REF_MPS`` = 100 m/s)."""

    v_mps: float = ranged(ge=MIN_V_REF_MPS, le=MAX_V_REF_MPS, unit="m/s")

    def __post_init__(self) -> None:
        validate(self)

    def row_speeds(self, path: Path) -> np.ndarray:
        """Reference speed at every row of ``path`` [m/s]."""
        return np.full(path.n_samples, float(self.v_mps))


@documented
@dataclass(frozen=True)
class CurvatureLimited:
    """Fastest profile within the limits: speed <= ``max_speed_mps`` [m/s], lateral acceleration v^2 |kappa| <=
    ``max_lateral_accel_mps2`` [m/s^2], longitudinal acceleration <= ``max_accel_mps2`` and deceleration <=
    ``max_decel_mps2`` [m/s^2] (see the module docstring for the passes). ``max_speed_mps`` is at least
    ``MIN_V_REF_MPS`` (1 m/s); tight curves may still ask for less locally."""

    max_speed_mps: float = ranged(ge=MIN_V_REF_MPS, le=MAX_V_REF_MPS, unit="m/s")
    max_lateral_accel_mps2: float = ranged(gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2")
    max_accel_mps2: float = ranged(2.0, gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2")
    max_decel_mps2: float = ranged(3.0, gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2")

    def __post_init__(self) -> None:
        validate(self)

    def lateral_limit(self, kappa_per_m: np.ndarray) -> np.ndarray:
        """min(max_speed, sqrt(a_lat / |kappa|)) [m/s] for curvatures kappa [1/m]."""
        k = np.maximum(np.abs(np.asarray(kappa_per_m, dtype=float)), KAPPA_FLOOR_PER_M)
        return np.minimum(self.max_speed_mps, np.sqrt(self.max_lateral_accel_mps2 / k))

    def row_speeds(self, path: Path) -> np.ndarray:
        """Reference speed at every row of ``path`` [m/s].

        The lateral limit at a row uses the largest |kappa| on the two row intervals next to it (sampled
        ``SUBSTEPS`` times per interval), so that with v^2 linear between rows the limit holds between rows too,
        where the interpolated curvature may exceed both ends slightly.
        """
        def passes(v2: np.ndarray, _k_interval: np.ndarray) -> None:
            _passes(v2, path.ds_m, self.max_accel_mps2, self.max_decel_mps2)

        return _two_pass_speeds(path, self.lateral_limit, passes)


def _interval_curvature(path: Path) -> np.ndarray:
    """Largest |kappa| [1/m] on each of the n - 1 row intervals of ``path`` (``SUBSTEPS`` samples each, ends
    included)."""
    n = path.n_samples
    s_fine = np.arange((n - 1) * SUBSTEPS + 1) * (path.ds_m / SUBSTEPS)
    s_fine[-1] = min(s_fine[-1], path.length_m)
    k_fine = np.abs(path.sample(s_fine).kappa)
    return np.maximum(k_fine[:-1].reshape(n - 1, SUBSTEPS).max(axis=1), k_fine[SUBSTEPS::SUBSTEPS])


def _two_pass_speeds(path: Path, lateral_limit: Callable[[np.ndarray], np.ndarray],
                     passes: Callable[[np.ndarray, np.ndarray], None]) -> np.ndarray:
    """Row speeds [m/s]: the lateral limit at every row (the larger |kappa| of its two intervals), then
    ``passes(v2, k_interval)`` in place on the squared speeds, ``k_interval[i]`` the largest |kappa| between rows
    i and i + 1. On a closed loop the passes run once around from the slowest point of the lateral limit."""
    k_interval = _interval_curvature(path)
    if path.closed:                                 # rows 0 and n - 1 are the same point
        k_env = np.maximum(k_interval, np.roll(k_interval, 1))          # intervals i - 1 and i of row i
        v2 = lateral_limit(k_env) ** 2
        start = int(np.argmin(v2))
        v2 = np.roll(v2, -start)
        v2 = np.append(v2, v2[0])                   # once around, from the slowest point back to it
        passes(v2, np.roll(k_interval, -start))
        v2 = np.roll(v2[:-1], start)
        v2 = np.append(v2, v2[0])
    else:
        k_env = np.maximum(np.append(k_interval, k_interval[-1]), np.insert(k_interval, 0, k_interval[0]))
        v2 = lateral_limit(k_env) ** 2
        passes(v2, k_interval)
    return np.sqrt(v2)


@documented
@dataclass(frozen=True)
class EnvelopeLimited:
    """Fastest profile inside a friction ellipse: speed <= ``max_speed_mps`` [m/s] and, everywhere along the path,
    (a_x / A_x)^2 + (a_y / A_y)^2 <= 1 with a_y = v^2 |kappa|, A_y = ``max_lateral_accel_mps2`` [m/s^2] and A_x =
    ``max_accel_mps2`` when speeding up, ``max_decel_mps2`` when braking [m/s^2]. Unlike :class:`CurvatureLimited`
    (each axis limited apart, so a corner entry may ask for full lateral and full braking acceleration at once) a
    corner is entered with the braking done and left with the throttle fed in as the lateral demand falls.

    ``vehicle_limit_mps2`` [m/s^2]: the driven car's own steady-state lateral limit (``vehicle.steady_state``,
    e.g. ``lowest_lateral_limit_mps2(car, max_speed_mps)``; ``tracks.feasibility.envelope_profile`` fills it in),
    with ``vehicle_name`` the car's name: a ``max_lateral_accel_mps2`` above it is refused (ValueError naming the
    car's limit), above ``NEAR_LIMIT_SHARE`` (90 %) of it a warning (``UserWarning``): near the limit the car has no
    margin left to correct an error. None: no check here; an env checks every ``EnvelopeLimited`` and
    ``CurvatureLimited`` profile against the car it drives anyway (``speed_limits.check_profile_for_car``).

    ``throttle_authority`` (the powertrain, ``tracks.powertrain_limits``): None (default) keeps A_x =
    ``max_accel_mps2``. A throttle fraction in (0, 1], or ``"speed_loop"`` (``SPEED_LOOP``: the throttle the env's
    PD-FLC holds, resolved by the env), makes A_x(v) the car's own forward limit at that throttle, drive force less
    drag and rolling resistance over the mass (``vehicle.longitudinal``), capped by ``max_accel_mps2`` unless that is
    None, and the speed cap the car's top speed there when lower (``speed_cap_mps``; a warning names it). ``1.0``
    is the truth for an agent that drives the throttle itself; a profile for the PD-FLC must assume the speed
    loop's authority, or the loop falls behind it. ``vehicle``: the car whose powertrain it is (``for_car`` binds
    one; an env binds its own). ``start_speed_mps`` [m/s]: the profile starts from this speed at s = 0 and speeds
    up within the same limits (a standing start; None: a flying lap, periodic on a closed loop).

    Passes (v^2 linear in s between rows, so a_x is constant on a row interval; the interval's |kappa| is its
    largest sampled value): forward, v_{i+1}^2 = v_i^2 + 2 ds A_x sqrt(1 - (v_{i+1}^2 kappa / A_y)^2) solved for
    v_{i+1}^2 (a quadratic; with a powertrain, A_x taken at the interval's faster end, where it is least: see
    ``_forward_pass``); backward the same with the deceleration. The ellipse then holds on every interval,
    between rows too (``envelope_usage`` measures it).
    """

    max_speed_mps: float = ranged(ge=MIN_V_REF_MPS, le=MAX_V_REF_MPS, unit="m/s")
    max_lateral_accel_mps2: float = ranged(gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2")
    max_accel_mps2: float | None = ranged(2.0, gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2", metadata={OPTIONAL: True})
    max_decel_mps2: float = ranged(3.0, gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2")
    vehicle_limit_mps2: float | None = ranged(None, gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2")
    vehicle_name: str = "the car"
    throttle_authority: float | str | None = None
    vehicle: Any = field(default=None, repr=False)
    start_speed_mps: float | None = ranged(None, ge=MIN_V_REF_MPS, le=MAX_V_REF_MPS, unit="m/s")

    def __post_init__(self) -> None:
        validate(self)
        check_lateral_limit(self.max_lateral_accel_mps2, self.vehicle_limit_mps2, self.vehicle_name,
                            "EnvelopeLimited.max_lateral_accel_mps2")
        check_powertrain_fields(self)

    @property
    def speed_cap_mps(self) -> float:
        """The profile's top speed [m/s]: ``max_speed_mps``, or the bound car's top speed at its throttle authority
        when lower (``powertrain_limits.capped_top_speed_mps``, which warns when it caps)."""
        if self.vehicle is None:
            return float(self.max_speed_mps)
        from vtrack_gym.tracks.powertrain_limits import powertrain_top_speed_mps

        return min(float(self.max_speed_mps), powertrain_top_speed_mps(self.vehicle, float(self.throttle_authority)))

    def for_car(self, vehicle: Any, speed_loop_authority: float, start_speed_mps: float | None = None
                ) -> EnvelopeLimited:
        """This profile bound to ``vehicle``'s powertrain (``VehicleParams``), ``SPEED_LOOP`` resolved to
        ``speed_loop_authority`` (the throttle fraction the env's speed loop holds) and, unless it has one, starting
        at ``start_speed_mps`` [m/s] (None: a flying lap); itself when it has no ``throttle_authority`` or is bound
        to a car already. What an env does with its own car and speed loop."""
        from vtrack_gym.tracks.powertrain_limits import SPEED_LOOP

        if self.throttle_authority is None or self.vehicle is not None:
            return self
        authority = speed_loop_authority if self.throttle_authority == SPEED_LOOP else self.throttle_authority
        start = self.start_speed_mps if self.start_speed_mps is not None else start_speed_mps
        return replace(self, vehicle=vehicle, throttle_authority=float(authority), start_speed_mps=start)

    def lateral_limit(self, kappa_per_m: np.ndarray) -> np.ndarray:
        """min(speed cap, sqrt(A_y / |kappa|)) [m/s] for curvatures kappa [1/m]."""
        k = np.maximum(np.abs(np.asarray(kappa_per_m, dtype=float)), KAPPA_FLOOR_PER_M)
        return np.minimum(self.speed_cap_mps, np.sqrt(self.max_lateral_accel_mps2 / k))

    def forward_accel_mps2(self) -> float | Callable[[float], float]:
        """A_x when speeding up: ``max_accel_mps2`` [m/s^2], or for a profile bound to a car ``v [m/s] ->`` the
        smaller of it and the car's powertrain limit at its throttle authority (``powertrain_limits.forward_limit``)."""
        if self.vehicle is None:
            return float(self.max_accel_mps2)
        from vtrack_gym.tracks.powertrain_limits import forward_limit

        return forward_limit(self.vehicle, float(self.throttle_authority), self.max_accel_mps2)

    def row_speeds(self, path: Path) -> np.ndarray:
        """Reference speed at every row of ``path`` [m/s] (see the class docstring)."""
        if self.throttle_authority is not None and self.vehicle is None:
            raise ValueError("EnvelopeLimited with a throttle_authority needs a car: an env binds its own "
                             "(gym.make(..., speed_profile=profile)); in Python use profile.for_car(vehicle, "
                             "authority) or tracks.feasibility.envelope_profile(vehicle, ...)")
        accel = self.forward_accel_mps2()

        def passes(v2: np.ndarray, k_interval: np.ndarray) -> None:
            _ellipse_passes(v2, k_interval, path.ds_m, self.max_lateral_accel_mps2, accel, self.max_decel_mps2)

        v = _two_pass_speeds(path, self.lateral_limit, passes)
        if self.start_speed_mps is None:
            return v
        v2 = v * v                                   # a standing (or rolling) start: one forward pass from it
        v2[0] = min(v2[0], self.start_speed_mps ** 2)
        _forward_pass(v2, _interval_curvature(path), path.ds_m, self.max_lateral_accel_mps2, accel)
        return np.sqrt(v2)


NEAR_LIMIT_SHARE = 0.9
"""Share of a car's lateral limit above which a requested lateral limit draws a warning."""


def check_lateral_limit(requested_mps2: float, vehicle_limit_mps2: float | None, vehicle_name: str,
                        field_name: str = "max_lateral_accel_mps2", where: str = "") -> None:
    """ValueError if ``requested_mps2`` [m/s^2] exceeds ``vehicle_limit_mps2`` [m/s^2], the car's own
    steady-state lateral limit, naming ``field_name``, the limit (in m/s^2 and g) and ``vehicle_name`` (``where``,
    e.g. "at speeds up to 80 km/h", follows the car's name); a ``UserWarning`` above ``NEAR_LIMIT_SHARE`` of it.
    Nothing when the car's limit is None."""
    if vehicle_limit_mps2 is None:
        return
    g = G_FOR_MESSAGES_MPS2
    text = (f"{field_name} = {requested_mps2:.3f} m/s^2 ({requested_mps2 / g:.3f} g) against the steady-state "
            f"lateral limit {vehicle_limit_mps2:.3f} m/s^2 ({vehicle_limit_mps2 / g:.3f} g) of {vehicle_name!r}"
            + (f" {where}" if where else ""))
    if requested_mps2 > vehicle_limit_mps2:
        raise ValueError(f"{text}: the car cannot corner that hard; ask for at most its limit (better "
                         f"{NEAR_LIMIT_SHARE:.0%} of it or less)")
    if requested_mps2 > NEAR_LIMIT_SHARE * vehicle_limit_mps2:
        warnings.warn(f"{text} ({requested_mps2 / vehicle_limit_mps2:.0%} of it): above {NEAR_LIMIT_SHARE:.0%} of "
                      "the limit, so the car has almost no margin left to correct a tracking error", UserWarning,
                      stacklevel=3)


def _ellipse_step(u_from: float, kappa: float, reach: float, a_lat: float) -> float:
    """Largest u = v^2 [m^2/s^2] reachable from ``u_from`` over one interval of curvature ``kappa`` [1/m] with
    u - u_from = reach sqrt(1 - (u kappa / a_lat)^2), ``reach`` = 2 ds A_x [m^2/s^2]."""
    q = (reach * max(kappa, KAPPA_FLOOR_PER_M) / a_lat) ** 2
    disc = reach * reach * (1.0 + q) - q * u_from * u_from
    return (u_from + math.sqrt(max(disc, 0.0))) / (1.0 + q)


def _ellipse_passes(v2: np.ndarray, k_interval: np.ndarray, ds_m: float, a_lat: float,
                    accel_mps2: float | Callable[[float], float], decel_mps2: float) -> None:
    """Forward (acceleration) then backward (braking) pass inside the friction ellipse, on v2 in place;
    ``accel_mps2`` a constant or a function of the speed (:func:`_forward_pass`)."""
    _forward_pass(v2, k_interval, ds_m, a_lat, accel_mps2)
    down = 2.0 * decel_mps2 * ds_m
    for i in range(v2.size - 2, -1, -1):
        v2[i] = min(v2[i], _ellipse_step(float(v2[i + 1]), float(k_interval[i]), down, a_lat))


def _forward_pass(v2: np.ndarray, k_interval: np.ndarray, ds_m: float, a_lat: float,
                  accel_mps2: float | Callable[[float], float]) -> None:
    """The forward pass on v2 in place. A speed-dependent limit ``a(v)`` [m/s^2] (non-increasing in v, as a
    powertrain's) is taken at the interval's end speed, where it is least: a first step with a(v_start) bounds the
    end speed, a second with a(that bound) gives an end speed whose constant acceleration stays within a(v) at every
    speed of the interval (a(v) >= a(bound) there)."""
    if not callable(accel_mps2):
        up = 2.0 * accel_mps2 * ds_m
        for i in range(1, v2.size):
            v2[i] = min(v2[i], _ellipse_step(float(v2[i - 1]), float(k_interval[i - 1]), up, a_lat))
        return
    for i in range(1, v2.size):
        u0, k = float(v2[i - 1]), float(k_interval[i - 1])
        if v2[i] <= u0:
            continue                                 # no speeding up asked on this interval
        bound = _ellipse_step(u0, k, 2.0 * ds_m * max(accel_mps2(math.sqrt(u0)), 0.0), a_lat)
        a_end = max(accel_mps2(math.sqrt(min(bound, float(v2[i])))), 0.0)
        v2[i] = min(v2[i], _ellipse_step(u0, k, 2.0 * ds_m * a_end, a_lat))


def envelope_usage(table: SpeedTable, path: Path, lateral_mps2: float, accel_mps2: float,
                   decel_mps2: float) -> np.ndarray:
    """(a_x / A_x)^2 + (a_y / A_y)^2 [-] on every row interval of ``table`` (its largest value over ``SUBSTEPS``
    samples): a_x the interval's constant acceleration (v^2 linear in s), A_x ``accel_mps2`` or ``decel_mps2``
    by its sign, a_y = v^2 |kappa| against ``lateral_mps2`` [m/s^2]. At most 1 everywhere: inside the ellipse."""
    v2 = table.v_mps ** 2
    a_x = np.diff(v2) / (2.0 * table.ds_m)
    limit_x = np.where(a_x >= 0.0, accel_mps2, decel_mps2)
    n = v2.size
    s_fine = np.arange((n - 1) * SUBSTEPS + 1) * (table.ds_m / SUBSTEPS)
    s_fine[-1] = min(s_fine[-1], path.length_m)
    a_y = table.v_ref(s_fine) * table.v_ref(s_fine) * np.abs(path.sample(s_fine).kappa)
    a_y_interval = np.maximum(a_y[:-1].reshape(n - 1, SUBSTEPS).max(axis=1), a_y[SUBSTEPS::SUBSTEPS])
    return (a_x / limit_x) ** 2 + (a_y_interval / lateral_mps2) ** 2


@documented
@dataclass(frozen=True)
class SpeedRamp:
    """A slow speed ramp: ``v_start_mps`` [m/s] up to s = ``s_start_m`` [m], then a constant acceleration
    ``accel_mps2`` [m/s^2] (speed linear in time, v^2 linear in s) up to ``v_end_mps`` [m/s], held after that.
    Also a ramp down when ``v_end_mps`` < ``v_start_mps`` (then ``accel_mps2`` is the deceleration's size)."""

    v_start_mps: float = ranged(gt=0.0, le=MAX_V_REF_MPS, unit="m/s")
    v_end_mps: float = ranged(gt=0.0, le=MAX_V_REF_MPS, unit="m/s")
    accel_mps2: float = ranged(gt=0.0, le=MAX_ACCEL_MPS2, unit="m/s^2")
    s_start_m: float = ranged(0.0, ge=0.0, le=1.0e6, unit="m")

    def __post_init__(self) -> None:
        validate(self)

    @property
    def ramp_length_m(self) -> float:
        """Distance over which the speed changes, |v_end^2 - v_start^2| / (2 accel) [m]."""
        return abs(self.v_end_mps ** 2 - self.v_start_mps ** 2) / (2.0 * self.accel_mps2)

    @property
    def ramp_duration_s(self) -> float:
        """Time the ramp takes at the reference speed, |v_end - v_start| / accel [s]."""
        return abs(self.v_end_mps - self.v_start_mps) / self.accel_mps2

    def speed_at(self, s_m: np.ndarray | float) -> np.ndarray:
        """Reference speed [m/s] at arc length(s) s_m [m] (not wrapped)."""
        s = np.asarray(s_m, dtype=float)
        v0, v1 = self.v_start_mps, self.v_end_mps
        frac = np.clip((s - self.s_start_m) / max(self.ramp_length_m, 1e-12), 0.0, 1.0)
        return np.sqrt(v0 * v0 + frac * (v1 * v1 - v0 * v0))

    def row_speeds(self, path: Path) -> np.ndarray:
        """Reference speed at every row of ``path`` [m/s] (exact between rows: v^2 is linear in s)."""
        return self.speed_at(path.s_m)


@documented
@dataclass(frozen=True)
class FileSpeed:
    """The path's own speed column (``Path.v_ref_mps``, e.g. a CSV ``v_mps`` column), times ``scale`` [-]; every
    resulting speed must be at least ``MIN_V_REF_MPS`` (1 m/s), else ``row_speeds`` raises ValueError."""

    scale: float = ranged(1.0, gt=0.0, le=10.0)

    def __post_init__(self) -> None:
        validate(self)

    def row_speeds(self, path: Path) -> np.ndarray:
        """Reference speed at every row of ``path`` [m/s]; ValueError if the path has no speed column."""
        if path.v_ref_mps is None:
            raise ValueError(f"track {path.name!r} has no speed column: add a 'v_mps' column to the file, or use "
                             "ConstantSpeed / CurvatureLimited")
        v = np.asarray(path.v_ref_mps, dtype=float) * float(self.scale)
        k = int(np.argmin(v))
        if v[k] < MIN_V_REF_MPS:
            raise ValueError(f"track {path.name!r}: the speed column x scale {self.scale} gives {v[k]:.3g} m/s at "
                             f"s = {k * path.ds_m:.1f} m; FileSpeed needs speeds in [{MIN_V_REF_MPS}, "
                             f"{MAX_V_REF_MPS}] m/s (fix: raise the slow speeds in the file, or use ConstantSpeed / "
                             "CurvatureLimited)")
        return v


def _passes(v2: np.ndarray, ds_m: float, accel_mps2: float, decel_mps2: float) -> None:
    """Forward (acceleration) then backward (deceleration) pass on squared speeds v2 [m^2/s^2], in place."""
    up = 2.0 * accel_mps2 * ds_m
    down = 2.0 * decel_mps2 * ds_m
    for i in range(1, v2.size):
        v2[i] = min(v2[i], v2[i - 1] + up)
    for i in range(v2.size - 2, -1, -1):
        v2[i] = min(v2[i], v2[i + 1] + down)


@dataclass(frozen=True, eq=False)
class SpeedTable:
    """Reference speed on a path's rows: ``v_mps`` (n,) [m/s] at s = i ds_m, ``closed`` wraps s like the path.
    Built by :func:`speed_table`; the array is read-only."""

    v_mps: np.ndarray = field(repr=False)
    ds_m: float
    closed: bool
    profile: SpeedProfile
    length_m: float = field(init=False)

    def __post_init__(self) -> None:
        v = np.array(self.v_mps, dtype=np.float64, copy=True)
        if v.ndim != 1 or v.size < 2 or not np.all(np.isfinite(v)) or np.any(v <= 0.0):
            raise ValueError("SpeedTable.v_mps must be a 1-D array of >= 2 finite speeds > 0 m/s")
        v.flags.writeable = False
        object.__setattr__(self, "v_mps", v)
        object.__setattr__(self, "length_m", (v.size - 1) * float(self.ds_m))

    def v_ref(self, s: np.ndarray | float) -> np.ndarray:
        """Reference speed [m/s] at arc length(s) s [m] (v^2 linear between rows; wrapped or clamped like the path)."""
        return np.sqrt(interp_linear(self.v_mps ** 2, self.ds_m, self.length_m, self.closed, s))

    def preview(self, s: np.ndarray | float, distances: np.ndarray) -> np.ndarray:
        """Reference speed [m/s] at s + d for every s (N,) [m] and preview distance d (K,) [m] -> shape (N, K)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        d = np.atleast_1d(np.asarray(distances, dtype=float))
        return self.v_ref(s[:, None] + d[None, :])


def speed_table(path: Path, profile: SpeedProfile) -> SpeedTable:
    """Evaluate ``profile`` on the rows of ``path`` -> :class:`SpeedTable`."""
    if not isinstance(profile, SpeedProfile):
        raise ValueError("speed profile must be ConstantSpeed, EnvelopeLimited, CurvatureLimited, SpeedRamp or "
                         f"FileSpeed (got {type(profile).__name__})")
    v = profile.row_speeds(path)
    if v.shape != (path.n_samples,) or not np.all(np.isfinite(v)) or np.any(v <= 0.0):
        raise ValueError(f"speed profile {profile!r} gave invalid speeds on track {path.name!r}")
    return SpeedTable(v, path.ds_m, path.closed, profile)


def as_speed_profile(spec: SpeedProfile | float | str) -> SpeedProfile:
    """A profile from a profile object, a number (constant speed [m/s]) or ``"file"`` (the track's speed column)."""
    if isinstance(spec, SpeedProfile):
        return spec
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        return ConstantSpeed(float(spec))
    if spec == "file":
        return FileSpeed()
    raise ValueError("speed_profile must be ConstantSpeed, EnvelopeLimited, CurvatureLimited, FileSpeed, a speed in "
                     f"m/s or 'file' (got {spec!r})")


POWERTRAIN_FIELDS: tuple[str, ...] = ("throttle_authority", "vehicle", "start_speed_mps")
"""``EnvelopeLimited``'s powertrain fields: left out of :func:`profile_parameters` while unset (None), so a profile
without them keeps the parameters (and the registered track ids) it had before they existed."""


def profile_parameters(profile: SpeedProfile) -> dict[str, Any]:
    """A profile's parameters as plain values (``dataclasses.asdict``), for identities and provenance: the powertrain
    fields (``POWERTRAIN_FIELDS``) only when set, a bound car by its name."""
    from dataclasses import asdict, fields, is_dataclass

    if not is_dataclass(profile):
        return {}
    out: dict[str, Any] = {}
    for f in fields(profile):
        value = getattr(profile, f.name)
        if f.name in POWERTRAIN_FIELDS and value is None:
            continue
        out[f.name] = value.name if f.name == "vehicle" else (asdict(value) if is_dataclass(value) else value)
    return out


def lateral_accel_mps2(table: SpeedTable, path: Path, s: np.ndarray) -> np.ndarray:
    """v_ref(s)^2 |kappa(s)| [m/s^2] at arc lengths s [m] (the lateral acceleration the profile asks for)."""
    return table.v_ref(s) ** 2 * np.abs(path.sample(s).kappa)


__all__ = ["MIN_V_REF_MPS", "NEAR_LIMIT_SHARE", "ConstantSpeed", "CurvatureLimited", "EnvelopeLimited", "FileSpeed",
           "SpeedProfile", "SpeedRamp", "SpeedTable", "as_speed_profile", "check_lateral_limit", "envelope_usage",
           "lateral_accel_mps2", "profile_parameters", "speed_table"]
