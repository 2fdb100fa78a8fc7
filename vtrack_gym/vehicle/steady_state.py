"""Steady-state cornering of the nonlinear plant, from the plant's own equations (no time simulation).

Roll and lateral load transfer at a steady lateral acceleration a_y (flat road, left turn, a_y > 0):

    K phi = m_s h_s (a_y cos phi + g sin phi)                                  (roll equilibrium, solved for phi)
    T = [m_s a_y (h_rc + h_s cos phi) + m_s g h_s sin phi + m_u a_y h_u] / t   (total transfer, moments about the
      = m a_y h / t + m_s h_s (a_y (cos phi - 1) + g sin phi) / t               road centre line)

with T = sum over the axles of (F_z,outer - F_z,inner) / 2 [N], K the total roll stiffness, m_s, h_s the sprung
mass and its CG height above the roll axis, h the whole car's CG height. The second term is the sideways shift of
the rolled sprung mass's CG (h_s sin phi towards the outside): real physics that the rigid-body value m a_y h / t
leaves out. In the linear range it adds the constant share ``roll_shift_share`` = (m_s h_s)^2 g /
((K - m_s g h_s) m h) (6.0 % on the paper's car) and vanishes for a rigid suspension (K -> infinity).

Cornering equilibria on a circle of radius R: the kernel's derivative (``kernels.state_derivative``) is zero in
every dynamic state except the steady advance along the circle (v_x, v_y, r constant, or growing with a
tangential acceleration ``accel_mps2`` at constant sideslip), the roll at rest, the load-transfer lags at the
accelerations they filter. Unknowns: sideslip beta, road-wheel angle delta, throttle, roll phi, lagged a_x, a_y.
``grip_limit`` returns the equilibrium of highest speed (continuation in speed, then a constrained maximisation
of the speed, ``scipy.optimize``): the plant's steady-state lateral-acceleration limit on that radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams

_RESIDUAL_TOL = 1e-9       # [m/s^2] largest scaled residual of an accepted equilibrium
LIMIT_CURVE_RADII_M = tuple(float(r) for r in np.geomspace(10.0, 400.0, 16))
"""Radii [m] on which :func:`lateral_limit_curve` solves the grip limit (about 9 to 50 m/s for a passenger car)."""
FULL_THROTTLE = 0.999      # an equilibrium at this throttle or more is power-limited, not grip-limited


def steady_roll_rad(params: VehicleParams, a_y_mps2: float) -> float:
    """Steady roll angle phi [rad] at lateral acceleration ``a_y_mps2`` [m/s^2]: the root of
    K phi = m_s h_s (a_y cos phi + g sin phi) (Newton; unique since K > m_s g h_s)."""
    k = params.roll.roll_stiffness_nmpr
    msh = params.sprung_mass_kg * (params.chassis.cg_height_m - params.roll.roll_centre_height_m)
    phi = msh * a_y_mps2 / (k - msh * GRAVITY_MPS2)
    for _ in range(50):
        f = k * phi - msh * (a_y_mps2 * math.cos(phi) + GRAVITY_MPS2 * math.sin(phi))
        step = f / (k - msh * (GRAVITY_MPS2 * math.cos(phi) - a_y_mps2 * math.sin(phi)))
        phi -= step
        if abs(step) < 1e-15:
            break
    return phi


def rigid_lateral_transfer_n(params: VehicleParams, a_y_mps2: float) -> float:
    """Rigid-body lateral load transfer m a_y h / t [N] (h the whole car's CG height)."""
    c = params.chassis
    return c.mass_kg * a_y_mps2 * params.total_cg_height_m / c.track_width_m


def lateral_transfer_n(params: VehicleParams, a_y_mps2: float) -> float:
    """Total steady lateral load transfer [N] (sum over the axles of (F_z,outer - F_z,inner) / 2): the rigid-body
    value plus the sideways shift of the rolled sprung mass (module docstring)."""
    phi = steady_roll_rad(params, a_y_mps2)
    msh = params.sprung_mass_kg * (params.chassis.cg_height_m - params.roll.roll_centre_height_m)
    shift = msh * (a_y_mps2 * (math.cos(phi) - 1.0) + GRAVITY_MPS2 * math.sin(phi))
    return rigid_lateral_transfer_n(params, a_y_mps2) + shift / params.chassis.track_width_m


def roll_shift_share(params: VehicleParams) -> float:
    """Linear-range share of the lateral load transfer above m a_y h / t from the rolled body's CG shift [-]:
    (m_s h_s)^2 g / ((K - m_s g h_s) m h)."""
    msh = params.sprung_mass_kg * (params.chassis.cg_height_m - params.roll.roll_centre_height_m)
    k = params.roll.roll_stiffness_nmpr
    return msh * msh * GRAVITY_MPS2 / ((k - msh * GRAVITY_MPS2) * params.chassis.mass_kg * params.total_cg_height_m)


@dataclass(frozen=True)
class CorneringEquilibrium:
    """A steady (or quasi-steady) state of the plant on a circle, left turn."""

    radius_m: float
    speed_mps: float             # path speed sqrt(v_x^2 + v_y^2)
    accel_mps2: float            # tangential (path) acceleration the state was solved for, 0 = steady
    sideslip_rad: float          # beta = atan(v_y / v_x)
    road_wheel_angle_rad: float
    throttle: float              # [0..1]
    roll_rad: float
    a_x_mps2: float              # body-frame accelerations (what the plant reports)
    a_y_mps2: float
    wheel_loads_n: tuple[float, float, float, float]   # F_z fl, fr, rl, rr

    @property
    def path_lateral_accel_mps2(self) -> float:
        """Centripetal acceleration V^2 / R [m/s^2]."""
        return self.speed_mps ** 2 / self.radius_m


class _Residual:
    """The equilibrium equations of one car on one circle, scaled to m/s^2."""

    def __init__(self, params: VehicleParams, radius_m: float, accel_mps2: float) -> None:
        from vtrack_gym.vehicle.kernels import state_derivative
        from vtrack_gym.vehicle.packing import pack_params

        if not (math.isfinite(radius_m) and radius_m > 0.0):
            raise ValueError(f"radius_m must be > 0 m (got {radius_m})")
        if not (math.isfinite(accel_mps2) and accel_mps2 >= 0.0):
            raise ValueError(f"accel_mps2 must be >= 0 m/s^2 (got {accel_mps2})")
        self.derivative = state_derivative
        self.p = pack_params(params)
        self.radius_m = radius_m
        self.accel = accel_mps2
        self.scale_r = params.chassis.wheelbase_m
        self.scale_roll = params.roll.roll_inertia_kgm2 / (self.p[L.P_MS] * self.p[L.P_HS])
        self.scale_lag = params.low_speed.load_transfer_lag_s

    def state(self, v: float, z: np.ndarray) -> np.ndarray:
        beta, delta, _, phi, ax, ay = z
        x = np.zeros(L.N_STATE)
        x[L.S_VX], x[L.S_VY], x[L.S_R] = v * math.cos(beta), v * math.sin(beta), v / self.radius_m
        x[L.S_ROLL], x[L.S_DELTA], x[L.S_AXL], x[L.S_AYL] = phi, delta, ax, ay
        # a relaxed tyre's lagged slip angles sit at the slip angles themselves in a steady state
        x[L.S_ALF] = delta - math.atan2(x[L.S_VY] + self.p[L.P_A1] * x[L.S_R], x[L.S_VX])
        x[L.S_ALR] = -math.atan2(x[L.S_VY] - self.p[L.P_A2] * x[L.S_R], x[L.S_VX])
        return x

    def __call__(self, z: np.ndarray, v: float) -> np.ndarray:
        dx, _ = self.derivative(self.state(v, z), z[1], z[2], 0.0, self.p)
        beta, a = z[0], self.accel
        return np.array([dx[L.S_VX] - a * math.cos(beta), dx[L.S_VY] - a * math.sin(beta),
                         (dx[L.S_R] - a / self.radius_m) * self.scale_r, dx[L.S_ROLL_RATE] * self.scale_roll,
                         dx[L.S_AXL] * self.scale_lag, dx[L.S_AYL] * self.scale_lag])

    def feasible(self, z: np.ndarray) -> bool:
        return 0.0 <= z[2] <= 1.0 and abs(z[1]) <= self.p[L.P_DELTA_MAX]

    def result(self, v: float, z: np.ndarray) -> CorneringEquilibrium:
        _, out = self.derivative(self.state(v, z), z[1], z[2], 0.0, self.p)
        return CorneringEquilibrium(self.radius_m, float(v), self.accel, float(z[0]), float(z[1]), float(z[2]),
                                    float(z[3]), float(out[L.O_AX]), float(out[L.O_AY]),
                                    tuple(float(f) for f in out[L.O_FZFL:L.O_FZRR + 1]))  # type: ignore[arg-type]


def _solve(res: _Residual, v: float, z0: np.ndarray) -> np.ndarray | None:
    from scipy.optimize import fsolve

    z, _, ier, _ = fsolve(res, z0, args=(v,), full_output=True, xtol=1e-13)
    ok = ier == 1 and float(np.max(np.abs(res(z, v)))) < _RESIDUAL_TOL and res.feasible(z)
    return z if ok else None


def _first_guess(params: VehicleParams, radius_m: float, v: float) -> np.ndarray:
    a_y = v * v / radius_m
    return np.array([0.0, params.chassis.wheelbase_m / radius_m, 0.05, steady_roll_rad(params, a_y), 0.0, a_y])


def cornering_equilibrium(params: VehicleParams, radius_m: float, speed_mps: float,
                          accel_mps2: float = 0.0) -> CorneringEquilibrium:
    """The plant's steady state at ``speed_mps`` [m/s] on a circle of ``radius_m`` [m] (left turn), reached by
    continuation from a slow speed; ``ValueError`` if none exists (above the grip limit)."""
    res = _Residual(params, radius_m, accel_mps2)
    v0 = min(5.0, speed_mps)
    z = _solve(res, v0, _first_guess(params, radius_m, v0))
    if z is None:
        raise ValueError(f"no cornering equilibrium at {v0:.3f} m/s on R = {radius_m} m")
    for v in np.linspace(v0, speed_mps, max(2, math.ceil((speed_mps - v0) / 0.25) + 1))[1:]:
        z = _solve(res, float(v), z)
        if z is None:
            raise ValueError(f"no cornering equilibrium at {speed_mps:.3f} m/s on R = {radius_m} m "
                             f"(lost at {v:.3f} m/s: above the plant's grip limit)")
    return res.result(speed_mps, z)


def grip_limit(params: VehicleParams, radius_m: float, accel_mps2: float = 0.0) -> CorneringEquilibrium:
    """The equilibrium of highest speed on a circle of ``radius_m`` [m]: the plant's steady-state (``accel_mps2``
    = 0) or quasi-steady (speed growing at ``accel_mps2`` [m/s^2]) lateral-acceleration limit on that radius.

    Continuation in speed (steps halved down to 1 mm/s where the equilibrium is lost), then the speed maximised
    over the equilibrium manifold (SLSQP, throttle in [0, 1], |delta| within the steering limit)."""
    from scipy.optimize import minimize

    res = _Residual(params, radius_m, accel_mps2)
    v, step = 5.0, 0.5
    z = _solve(res, v, _first_guess(params, radius_m, v))
    if z is None:
        raise ValueError(f"no cornering equilibrium at {v} m/s on R = {radius_m} m")
    while step > 1e-3:
        z_next = _solve(res, v + step, z)
        if z_next is None:
            step *= 0.5
        else:
            v, z = v + step, z_next
    d_max = res.p[L.P_DELTA_MAX]
    bounds = [(v - 1.0, None), (-0.5, 0.5), (-d_max, d_max), (0.0, 1.0), (-0.5, 0.5), (None, None), (None, None)]
    opt = minimize(lambda w: -w[0], np.concatenate([[v], z]), method="SLSQP", bounds=bounds,
                   constraints=[{"type": "eq", "fun": lambda w: res(w[1:], w[0])}],
                   options={"ftol": 1e-14, "maxiter": 500})
    w = opt.x
    if opt.success and float(np.max(np.abs(res(w[1:], w[0])))) < _RESIDUAL_TOL and w[0] >= v:
        v, z = float(w[0]), w[1:]
    return res.result(v, z)


@lru_cache(maxsize=32)
def lateral_limit_curve(params: VehicleParams) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The car's steady-state lateral limit against speed: (speeds [m/s], path lateral accelerations V^2 / R
    [m/s^2]) of :func:`grip_limit` on ``LIMIT_CURVE_RADII_M``, increasing in speed. Radii whose highest equilibrium
    is at full throttle (power-limited: the car cannot go faster there, whatever its grip) are left out, so the
    curve ends at the fastest grip-limited radius. Cached per car."""
    speeds, accels = [], []
    for radius in LIMIT_CURVE_RADII_M:
        try:
            eq = grip_limit(params, radius)
        except ValueError:                      # no equilibrium even at the continuation's start speed
            continue
        if eq.throttle < FULL_THROTTLE:
            speeds.append(eq.speed_mps)
            accels.append(eq.path_lateral_accel_mps2)
    if len(speeds) < 2:
        raise ValueError(f"no grip-limited cornering equilibria for {params.name!r} on radii "
                         f"{LIMIT_CURVE_RADII_M[0]:g}-{LIMIT_CURVE_RADII_M[-1]:g} m")
    order = np.argsort(speeds)
    return tuple(float(speeds[i]) for i in order), tuple(float(accels[i]) for i in order)


def lateral_limit_mps2(params: VehicleParams, speed_mps: float | np.ndarray) -> float | np.ndarray:
    """The car's steady-state lateral-acceleration limit [m/s^2] at ``speed_mps`` [m/s]: linear in speed between
    the points of :func:`lateral_limit_curve`, held at its end values outside it."""
    speeds, accels = lateral_limit_curve(params)
    out = np.interp(speed_mps, speeds, accels)
    return float(out) if np.ndim(out) == 0 else out


def lowest_lateral_limit_mps2(params: VehicleParams, max_speed_mps: float) -> float:
    """The least steady-state lateral limit [m/s^2] of the car at any speed up to ``max_speed_mps`` [m/s] (the
    limit falls with speed: drive force for drag, load transfer): the lateral acceleration a speed profile capped
    at ``max_speed_mps`` may ask for at most."""
    speeds, accels = lateral_limit_curve(params)
    grid = np.append(np.asarray(speeds)[np.asarray(speeds) < max_speed_mps], max_speed_mps)
    return float(np.min(np.interp(grid, speeds, accels)))


__all__ = ["CorneringEquilibrium", "cornering_equilibrium", "grip_limit", "lateral_limit_curve", "lateral_limit_mps2",
           "lateral_transfer_n", "lowest_lateral_limit_mps2", "rigid_lateral_transfer_n", "roll_shift_share",
           "steady_roll_rad"]
