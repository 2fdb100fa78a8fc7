"""Vehicle plant vs theory: the paper's linear model, analytic steady states, saturation, roll, grades."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.linear import (
    lateral_matrices,
    steady_state_response,
    steady_state_sideslip,
    steady_state_steer,
    understeer_gradient,
)
from vtrack_gym.vehicle.params import GRAVITY_MPS2, DesignModel, SteeringParams, VehicleParams
from vtrack_gym.vehicle.plant import Plant

DESIGN = DesignModel.from_vehicle(VehicleParams())
IDEAL_STEER = dataclasses.replace(VehicleParams(), steering=SteeringParams(time_constant_s=0.0))
N_SUB = 5  # 0.01 s control period at the default 500 Hz physics


def hold_speed_run(plant: Plant, v: float, delta: float, seconds: float) -> np.ndarray:
    """Constant road-wheel angle with the speed held near ``v`` by a proportional throttle/brake loop."""
    u = np.zeros((plant.n, 3))
    u[:, L.U_DELTA] = delta
    out = None
    for _ in range(round(seconds / 0.01)):
        err = v - plant.state[:, L.S_VX]
        u[:, L.U_THROTTLE] = np.clip(0.1 + 2.0 * err, 0.0, 1.0)
        u[:, L.U_BRAKE] = np.clip(-200.0 * err, 0.0, 500.0)
        out = plant.step(u, N_SUB)
    assert out is not None
    return out


def frictionless(params: VehicleParams) -> VehicleParams:
    """Same car without drag and rolling resistance (speed stays constant when coasting on the flat)."""
    return dataclasses.replace(
        params, tyres=dataclasses.replace(params.tyres, rolling_resistance_coeff=0.0),
        powertrain=dataclasses.replace(params.powertrain, drag_area_m2=0.0))


# Golden numbers copied from tests/data/paper-linear-model.json ("mpc_v=11.11"."A9"/"B9", rows 2 and 4)
# and ../shared/spec/paper-math.md section 1.2 (poles, steady states).
A_LAT_11 = np.array([[-12.64788899272093, -10.99217802671987], [0.10833763795459364, -22.46432696760923]])
B_LAT = np.array([91.05590941259732, 84.98205895750634])


def test_linear_matrices_match_fixture() -> None:
    a, b = lateral_matrices(DESIGN, 11.11)
    np.testing.assert_allclose(a, A_LAT_11, rtol=1e-12)
    np.testing.assert_allclose(b, B_LAT, rtol=1e-12)


@pytest.mark.parametrize(("v", "poles"), [(11.11, (-12.77, -22.34)), (33.33, (-4.64, -7.07))])
def test_linear_poles(v: float, poles: tuple[float, float]) -> None:
    a, _ = lateral_matrices(DESIGN, v)
    eig = np.sort(np.linalg.eigvals(a).real)
    np.testing.assert_allclose(np.sort(poles), eig, atol=0.006)


def test_analytic_steady_states() -> None:
    assert understeer_gradient(DESIGN) == pytest.approx(9.99e-5, rel=2e-3)
    assert steady_state_steer(DESIGN, 11.11, 1 / 100) == pytest.approx(0.02922, abs=1e-5)
    assert steady_state_steer(DESIGN, 33.33, 1 / 500) == pytest.approx(0.00604, abs=1e-5)
    assert steady_state_sideslip(DESIGN, 11.11, 1 / 100) == pytest.approx(0.01025, abs=1e-5)
    assert steady_state_sideslip(DESIGN, 33.33, 1 / 500) == pytest.approx(-0.01188, abs=1e-5)
    # The steady-state steer of the paper-math formula makes eq. (5) turn at exactly r = v kappa.
    for v, radius in ((11.11, 100.0), (33.33, 500.0)):
        vy, r = steady_state_response(DESIGN, v, steady_state_steer(DESIGN, v, 1 / radius))
        assert r == pytest.approx(v / radius, rel=1e-9)
        assert vy / v == pytest.approx(steady_state_sideslip(DESIGN, v, 1 / radius), rel=1e-9)


@pytest.mark.parametrize("v", [11.11, 33.33])
def test_linear_plant_reproduces_eq5_transient(v: float) -> None:
    """The linear plant integrates eq. (5) (all three rows): compare with an independent tight ODE solve."""
    from scipy.integrate import solve_ivp

    params = frictionless(IDEAL_STEER)
    plant = Plant(params, model="linear")
    plant.reset(v_x=v)
    delta = math.radians(0.5)
    u = np.array([[delta, 0.0, 0.0]])
    for _ in range(50):
        plant.step(u, N_SUB)
    m, iz = DESIGN.mass_kg, DESIGN.yaw_inertia_kgm2
    a1, a2 = DESIGN.cg_to_front_axle_m, DESIGN.cg_to_rear_axle_m
    cf, cr = DESIGN.front_cornering_stiffness_npr, DESIGN.rear_cornering_stiffness_npr

    def eq5(_t: float, z: np.ndarray) -> list[float]:
        vx, vy, r = z
        fyf = cf * (delta - (vy + a1 * r) / vx)
        fyr = -cr * (vy - a2 * r) / vx
        return [-fyf * math.sin(delta) / m + r * vy, (fyf + fyr) / m - r * vx, (a1 * fyf - a2 * fyr) / iz]

    sol = solve_ivp(eq5, (0.0, 0.5), [v, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14)
    got = plant.state[0, [L.S_VX, L.S_VY, L.S_R]]
    np.testing.assert_allclose(got, sol.y[:, -1], rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("v", [11.11, 33.33])
def test_nonlinear_agrees_with_linear_for_small_slip(v: float) -> None:
    """0.5 deg step steer, speed held: steady yaw rate and lateral acceleration within 3 % of eq. (5)."""
    delta = math.radians(0.5)
    plant = Plant(IDEAL_STEER, model="nonlinear")
    plant.reset(v_x=v)
    out = hold_speed_run(plant, v, delta, 8.0)
    vy_lin, r_lin = steady_state_response(DESIGN, plant.state[0, L.S_VX], delta)
    r = plant.state[0, L.S_R]
    a_y = out[0, -1, L.O_AY]
    assert r == pytest.approx(r_lin, rel=0.03)
    assert a_y == pytest.approx(r_lin * plant.state[0, L.S_VX], rel=0.03)
    assert abs(plant.state[0, L.S_VY] - vy_lin) < 0.06 * max(abs(vy_lin), 0.5)


def test_lateral_force_saturates_near_mu_g() -> None:
    """Large steer at 20 m/s: a_y saturates just below mu g (and falls past the peak slip of the front
    tyres: limit understeer), where the linear model would keep growing."""
    results = []
    for delta in (0.1, 0.2, 0.3):
        plant = Plant(IDEAL_STEER)
        plant.reset(v_x=20.0)
        out = hold_speed_run(plant, 20.0, delta, 5.0)
        results.append(out[0, -1, L.O_AY])
    tyres = VehicleParams().tyres
    mu_g = tyres.friction_mu * GRAVITY_MPS2
    # Upper bound: every wheel at its peak mu D F_z with no load-transfer loss; the degressive load
    # sensitivity costs a few percent of that at ~0.9 g of lateral load transfer.
    peak_bound = max(tyres.front_peak_d, tyres.rear_peak_d) * mu_g
    assert max(results) > 0.85 * mu_g
    assert all(0.8 * mu_g < a_y <= peak_bound for a_y in results)
    assert results[2] < results[1]  # past the front tyres' peak slip angle
    _, r_lin = steady_state_response(DESIGN, 20.0, 0.3)
    assert r_lin * 20.0 > 3 * mu_g


def test_roll_gradient_matches_documented_value() -> None:
    params = VehicleParams()
    m_s = params.chassis.mass_kg - params.roll.unsprung_mass_kg
    h_s = params.chassis.cg_height_m - params.roll.roll_centre_height_m
    gradient = m_s * h_s / (params.roll.roll_stiffness_nmpr - m_s * GRAVITY_MPS2 * h_s)  # rad per m/s^2
    for delta in (0.01, 0.03):
        plant = Plant(IDEAL_STEER)
        plant.reset(v_x=15.0)
        out = hold_speed_run(plant, 15.0, delta, 5.0)
        a_y = out[0, -1, L.O_AY]
        assert plant.state[0, L.S_ROLL] / a_y == pytest.approx(gradient, rel=0.02)
    assert math.degrees(gradient * 0.81 * GRAVITY_MPS2) < 4.0  # paper: roll below 4 deg at 0.81 g


def test_wheel_loads_at_rest_and_in_a_left_turn() -> None:
    plant = Plant()
    out = plant.step(np.zeros((1, 3)), N_SUB)
    fz = out[0, -1, L.O_FZFL:]
    weight = VehicleParams().chassis.mass_kg * GRAVITY_MPS2
    assert fz.sum() == pytest.approx(weight, rel=1e-12)
    assert fz[0] == pytest.approx(fz[1]) and fz[2] == pytest.approx(fz[3])
    plant.reset(v_x=15.0)
    out = hold_speed_run(plant, 15.0, 0.03, 4.0)
    fz = out[0, -1, L.O_FZFL:]
    assert fz[1] > fz[0] and fz[3] > fz[2]  # left turn loads the right (outer) wheels
    assert fz.sum() == pytest.approx(weight, rel=1e-9)  # flat ground, no vertical acceleration


def test_standstill_to_40kmh_and_back_without_nan() -> None:
    plant = Plant()
    u = np.zeros((1, 3))
    v_hist = []
    for k in range(6000):  # 60 s
        t = k * 0.01
        u[0, L.U_DELTA] = 0.2 * math.sin(0.5 * t)
        if t < 30.0:
            err = 11.11 - plant.state[0, L.S_VX]
            u[0, L.U_THROTTLE], u[0, L.U_BRAKE] = min(max(0.5 * err, 0.0), 1.0), 0.0
        else:
            u[0, L.U_THROTTLE], u[0, L.U_BRAKE] = 0.0, 120.0
        out = plant.step(u, N_SUB)
        assert np.all(np.isfinite(plant.state)) and np.all(np.isfinite(out))
        v_hist.append(plant.state[0, L.S_VX])
    v = np.array(v_hist)
    assert v[:3000].max() == pytest.approx(11.11, abs=0.5)
    assert abs(v[-1]) < 0.05 and abs(plant.state[0, L.S_R]) < 0.05
    assert np.abs(plant.state[0, [L.S_VY, L.S_ROLL]]).max() < 0.05


def test_coasting_down_a_grade_accelerates_by_g_sin_theta() -> None:
    base = VehicleParams()
    plant = Plant(frictionless(base))
    plant.reset(v_x=10.0)
    grade = -0.04  # rad, downhill
    road = np.array([[grade, 0.0]])
    for _ in range(500):
        plant.step(np.zeros((1, 3)), N_SUB, road=road)
    assert plant.state[0, L.S_VX] == pytest.approx(10.0 - GRAVITY_MPS2 * math.sin(grade) * 5.0, rel=1e-9)
    # With resistances: the instantaneous deceleration equals g sin(theta) + drag + rolling resistance.
    plant = Plant(base)
    plant.reset(v_x=20.0)
    out = plant.step(np.zeros((1, 3)), 1, road=road)
    m = base.chassis.mass_kg
    drag = 0.5 * base.powertrain.air_density_kgpm3 * base.powertrain.drag_area_m2 * 20.0**2
    rr = base.tyres.rolling_resistance_coeff * m * GRAVITY_MPS2 * math.cos(grade) * math.tanh(20.0 / 0.1)
    expected = -GRAVITY_MPS2 * math.sin(grade) - (drag + rr) / m
    assert out[0, 0, L.O_AX] == pytest.approx(expected, rel=1e-9)


def test_low_speed_is_kinematic() -> None:
    """Below the blend speed the car follows the kinematic single-track model: r = v tan(delta) / l."""
    plant = Plant(frictionless(IDEAL_STEER))
    plant.reset(v_x=0.5)
    for _ in range(200):
        plant.step(np.array([[0.3, 0.0, 0.0]]), N_SUB)
    assert plant.state[0, L.S_VX] == pytest.approx(0.5, rel=1e-3)
    l = VehicleParams().chassis.wheelbase_m
    assert plant.state[0, L.S_R] == pytest.approx(plant.state[0, L.S_VX] * math.tan(0.3) / l, rel=1e-4)


def test_steering_actuator_lag_and_rate_limit() -> None:
    params = VehicleParams()
    plant = Plant(params)
    plant.reset(v_x=10.0)
    u = np.array([[0.5, 0.0, 0.0]])
    plant.step(u, N_SUB)  # 10 ms: rate-limited at 800 deg/s / 16 = 0.8727 rad/s
    assert plant.state[0, L.S_DELTA] == pytest.approx(params.steering.max_road_wheel_rate_radps * 0.01, rel=1e-9)
    u[0, L.U_DELTA] = 5.0  # beyond the limit: clipped to max road-wheel angle
    for _ in range(200):
        plant.step(u, N_SUB)
    assert plant.state[0, L.S_DELTA] == pytest.approx(params.steering.max_road_wheel_angle_rad, rel=1e-6)


def test_batched_equals_single_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    n = 200  # above the parallel threshold
    inputs = np.column_stack([rng.uniform(-0.3, 0.3, n), rng.uniform(0, 1, n), rng.uniform(0, 80, n)])
    road = np.column_stack([rng.uniform(-0.05, 0.05, n), rng.uniform(-1, 1, n)])
    batch = Plant(n=n)
    batch.state[:, L.S_VX] = rng.uniform(0.0, 35.0, n)
    start = batch.state.copy()
    for _ in range(20):
        out_b = batch.step(inputs, N_SUB, road=road).copy()
    for i in (0, 7, 123, n - 1):
        single = Plant(n=1)
        single.state[:] = start[i]
        for _ in range(20):
            out_s = single.step(inputs[i:i + 1], N_SUB, road=road[i:i + 1])
        assert np.array_equal(single.state[0], batch.state[i])
        assert np.array_equal(out_s[0], out_b[i])


def test_params_validation_names_the_field() -> None:
    from vtrack_gym.vehicle.params import ChassisParams

    with pytest.raises(ValueError, match=r"ChassisParams\.mass_kg must be > 0"):
        ChassisParams(mass_kg=-1.0)
    with pytest.raises(ValueError, match=r"cg_to_front_axle_m must be > 0"):
        ChassisParams(cg_to_front_axle_m=0.0)
    with pytest.raises(ValueError, match=r"friction_mu"):
        VehicleParams().with_friction(3.0)
    with pytest.raises(ValueError, match=r"physics_dt_s"):
        Plant(physics_dt_s=0.01)
    with pytest.raises(ValueError, match="model must be one of"):
        Plant(model="bicycle")
