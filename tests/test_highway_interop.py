"""highway-env interop: the ``HighwayLaneKeeping`` adapter around ``lane-keeping-v0`` (vtrack_gym.interop)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("highway_env")

import gymnasium as gym
from highway_env.road.lane import SineLane
from highway_env.vehicle.dynamics import BicycleVehicle

from vtrack_gym.baselines.linear_models import error_model
from vtrack_gym.baselines.registry import available_policies, make_policy
from vtrack_gym.envs.observation import OBS
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.suite.suite_defs.highway import highway_episodes
from vtrack_gym.interop import (
    HIGHWAY_ENV_ID,
    register_highway_envs,
    resolve_env_id,
)
from vtrack_gym.interop.highway import HighwayLaneKeeping, design_model_from_bicycle
from vtrack_gym.vehicle.linear import lateral_matrices

SPEEDS = (3.0, 8.3, 20.0, 35.0)


@pytest.fixture(scope="module")
def env() -> HighwayLaneKeeping:
    e = HighwayLaneKeeping()
    yield e
    e.close()


def _bicycle(speed: float) -> BicycleVehicle:
    return BicycleVehicle(None, [0.0, 0.0], heading=0.0, speed=speed)


def _lateral_jacobian(vehicle: BicycleVehicle) -> tuple[np.ndarray, np.ndarray]:
    """d(v_y', r')/d(v_y, r) and d(v_y', r')/d delta of highway-env's NONLINEAR model at the straight-run trim."""

    def f(vy: float, r: float, delta: float) -> np.ndarray:
        vehicle.lateral_speed, vehicle.yaw_rate = vy, r
        vehicle.action = {"steering": delta, "acceleration": 0.0}
        d = vehicle.derivative_func(None, vehicle.state)
        return np.array([d[4, 0], d[5, 0]])

    h = 1e-6
    a = np.column_stack([(f(h, 0, 0) - f(-h, 0, 0)) / (2 * h), (f(0, h, 0) - f(0, -h, 0)) / (2 * h)])
    b = (f(0, 0, h) - f(0, 0, -h)) / (2 * h)
    return a, b


# ---------------------------------------------------------------------------------------------- (a) models
def test_design_model_uses_axle_stiffnesses(env: HighwayLaneKeeping) -> None:
    d = env.design_model
    assert d.mass_kg == BicycleVehicle.MASS
    assert d.yaw_inertia_kgm2 == BicycleVehicle.INERTIA_Z
    assert (d.cg_to_front_axle_m, d.cg_to_rear_axle_m) == (BicycleVehicle.LENGTH_A, BicycleVehicle.LENGTH_B)
    # FRICTION_FRONT/REAR are per tyre: derivative_func uses f_yf = 2 * FRICTION_FRONT * (delta_f - theta_vf)
    assert d.front_cornering_stiffness_npr == 2 * BicycleVehicle.FRICTION_FRONT
    assert d.rear_cornering_stiffness_npr == 2 * BicycleVehicle.FRICTION_REAR
    assert d.max_road_wheel_angle_rad == pytest.approx(math.pi / 3)  # lane-keeping-v0 steering_range
    assert env.control_period_s == pytest.approx(0.02)
    assert env.observation_layout is OBS


@pytest.mark.parametrize("speed", SPEEDS)
def test_lateral_matrices_match_highway_lpv(speed: float) -> None:
    """Same state (v_y, r), same order, same signs. A and B[0] equal highway-env's lateral_lpv_dynamics();
    both of our B entries equal the Jacobian of highway-env's nonlinear derivative_func."""
    design = design_model_from_bicycle(BicycleVehicle, math.pi / 3, 0.02)
    a, b = lateral_matrices(design, speed)
    vehicle = _bicycle(speed)
    a_hw, b_hw = vehicle.lateral_lpv_dynamics()
    np.testing.assert_allclose(a, a_hw, rtol=1e-12, atol=1e-12)
    assert b[0] == pytest.approx(b_hw[0, 0], rel=1e-12)
    a_nl, b_nl = _lateral_jacobian(vehicle)
    np.testing.assert_allclose(a, a_nl, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(b, b_nl, rtol=1e-6)
    # highway-env 1.12.1's lateral_lpv_structure writes the yaw row of B as FRICTION_FRONT * LENGTH_A / INERTIA_Z
    # (one tyre), half of what its own derivative_func applies (2 * FRICTION_FRONT * LENGTH_A / INERTIA_Z).
    # Accept a fixed highway-env too.
    assert b_hw[1, 0] == pytest.approx(b[1] / 2, rel=1e-12) or b_hw[1, 0] == pytest.approx(b[1], rel=1e-12)


@pytest.mark.parametrize("speed", SPEEDS)
def test_error_model_matches_highway_full_lpv(speed: float) -> None:
    """highway-env's full_lateral_lpv_dynamics() state (y, psi, v_y, r), linearised about psi = 0 on the x axis,
    is our error state on a straight reference through T: e_y = y, e_y_dot = v psi + v_y, e_phi = psi,
    e_phi_dot = r."""
    design = design_model_from_bicycle(BicycleVehicle, math.pi / 3, 0.02)
    em = error_model(design, speed)
    a_hw, b_hw = _bicycle(speed).full_lateral_lpv_dynamics()
    t = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, speed, 1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    np.testing.assert_allclose(t @ a_hw @ np.linalg.inv(t), em.a, rtol=1e-9, atol=1e-9)
    b_mapped = (t @ b_hw).ravel()
    assert b_mapped[:3] == pytest.approx(em.b[:3], rel=1e-12, abs=1e-12)
    assert b_mapped[3] in (pytest.approx(em.b[3] / 2, rel=1e-12), pytest.approx(em.b[3], rel=1e-12))


def test_action_maps_to_highway_steering(env: HighwayLaneKeeping) -> None:
    env.reset(seed=0, options={"initial_lateral_offset_m": 0.0})
    obs, *_ = env.step(np.array([0.5], dtype=np.float32))
    assert env.vehicle.action["steering"] == pytest.approx(0.5 * math.pi / 3)
    assert obs[OBS.ROAD_WHEEL_ANGLE] == pytest.approx(0.5 * math.pi / 3, rel=1e-6)
    assert obs[OBS.YAW_RATE] > 0.0  # positive (left) steering -> counter-clockwise yaw, as in vtrack
    obs, *_ = env.step(np.array([-2.0], dtype=np.float32))  # clipped to -1
    assert env.vehicle.action["steering"] == pytest.approx(-math.pi / 3)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan]))


# ------------------------------------------------------------------------------------ (b) closed loop
NMPC_ON_LINEAR_TYRES = pytest.mark.xfail(strict=True, reason="nmpc's Pacejka model caps the tyre force at mu D F_z; "
                                         "highway-env's bicycle has linear tyres: the CasADi iteration, linearised "
                                         "at the measured state, leaves the road (docs/baselines/nmpc.md)")


@pytest.mark.parametrize("name", [*available_policies(), pytest.param("nmpc:casadi", marks=NMPC_ON_LINEAR_TYRES)])
def test_baseline_keeps_highway_car_on_its_lane(env: HighwayLaneKeeping, name: str) -> None:
    if name == "mpc_osqp":
        pytest.importorskip("osqp")
    name, _, preset = name.partition(":")
    # smc/mpc: the hand-tuned presets these figures were observed with (the GA-tuned defaults: next test)
    policy = make_policy(name, env, preset=preset or ("hand" if name in ("smc", "mpc") else "default"))
    trace = rollout(policy, env, seed=0)  # highway-env's own 4 m offset to the right, whole sine lane
    assert trace.termination == "completed"
    assert trace["progress_m"][-1] > 490.0
    t, e_y = trace["time_s"], np.abs(trace["e_y_m"])
    half_width = env.reference_geometry.half_width
    assert half_width == pytest.approx(5.0)
    assert e_y.max() < half_width
    assert e_y[t >= 3.0].max() < half_width
    assert e_y[t >= 10.0].max() < 0.15  # settled: 1 mm (smc) .. 70 mm (pure_pursuit) observed


@pytest.mark.parametrize("name", ["smc", "mpc"])
def test_tuned_default_presets_keep_highway_car_on_its_lane(env: HighwayLaneKeeping, name: str) -> None:
    """The GA-tuned defaults were tuned for Case-1 tracking, not for a 4 m offset: the SMC recovers it in ~13 s
    (hand preset: ~7 s), so its settling bound here is 15 s."""
    trace = rollout(make_policy(name, env), env, seed=0)
    assert trace.termination == "completed" and trace["progress_m"][-1] > 490.0
    t, e_y = trace["time_s"], np.abs(trace["e_y_m"])
    assert e_y.max() < env.reference_geometry.half_width
    assert e_y[t >= 15.0].max() < 0.15


# ------------------------------------------------------------------------------- (c) observation sanity
def _sine_lane(env: HighwayLaneKeeping) -> SineLane:
    lane = env.highway_env.lane
    assert isinstance(lane, SineLane)
    return lane


@pytest.mark.parametrize("hw_lateral", [1.5, -1.5])
def test_e_y_sign_from_highway_lane_coordinates(env: HighwayLaneKeeping, hw_lateral: float) -> None:
    """Put the car with highway-env's OWN lane API at lateral +-1.5 m (left of the centre line in its world
    frame when positive): our e_y has the same sign, and is the perpendicular distance."""
    env.reset(seed=0)
    lane = _sine_lane(env)
    for x in (0.0, 12.5, 37.0, 60.0):  # slopes 17 deg, 0, -11 deg, ...
        env.vehicle.position = lane.position(x, hw_lateral)
        env.vehicle.heading = lane.heading_at(x)
        obs, _ = env.observe()
        slope = math.tan(lane.heading_at(x))
        assert np.sign(obs[OBS.E_Y]) == np.sign(hw_lateral)
        # highway-env's SineLane lateral is the offset along the chord normal; the perpendicular one is shorter
        assert abs(obs[OBS.E_Y]) <= abs(hw_lateral) + 1e-9
        assert obs[OBS.E_Y] == pytest.approx(hw_lateral / math.sqrt(1 + slope**2), abs=0.02)
        # geometric check: the car is on the left of the centre line's tangent (z of the cross product > 0)
        cx, cy = lane.position(x, 0.0)
        px, py = env.vehicle.position
        cross = math.cos(lane.heading_at(x)) * (py - cy) - math.sin(lane.heading_at(x)) * (px - cx)
        assert np.sign(cross) == np.sign(obs[OBS.E_Y])
        assert abs(obs[OBS.E_PHI]) < 0.02


def test_reset_offset_and_native_start(env: HighwayLaneKeeping) -> None:
    obs, info = env.reset(seed=0, options={"initial_lateral_offset_m": 2.0, "start_station_m": 30.0})
    assert obs[OBS.E_Y] == pytest.approx(2.0, abs=1e-6)
    assert obs[OBS.E_PHI] == pytest.approx(0.0, abs=1e-9)
    _, lat = _sine_lane(env).local_coordinates(env.vehicle.position)
    assert lat > 2.0  # highway-env's chord-normal lateral: same sign, longer
    assert info["station_m"] == pytest.approx(30.0, abs=0.01)
    # highway-env's own initial state: 4 m to the right (lateral -4) of its straight entry lane
    obs, _ = env.reset(seed=0, options={"start": "highway"})
    assert obs[OBS.E_Y] == pytest.approx(-4.0, abs=1e-6)
    assert obs[OBS.E_PHI] == pytest.approx(0.0, abs=1e-9)
    assert obs[OBS.CURVATURE] == 0.0
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"friction_mu": 0.5})
    with pytest.raises(ValueError, match=r"\[-4.5, 4.5\]"):
        env.reset(options={"initial_lateral_offset_m": 6.0})


def _highway_arc_geometry(lane: SineLane) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Independent reference from highway-env's own lane API: chord abscissa, arc length (polyline of
    lane.position), curvature d heading_at / d s (finite differences)."""
    x = np.arange(-20.0, 560.0, 0.05)
    pts = np.array([lane.position(xi, 0.0) for xi in x])
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))))
    s -= np.interp(0.0, x, s)
    heading = np.array([lane.heading_at(xi) for xi in x])
    return x, s, np.gradient(heading, s)


def test_observation_matches_geometry_and_finite_differences(env: HighwayLaneKeeping) -> None:
    policy = make_policy("stanley", env)
    obs, info = env.reset(seed=0, options={"initial_lateral_offset_m": 1.0, "initial_heading_error_rad": 0.1})
    _, s_tab, k_tab = _highway_arc_geometry(_sine_lane(env))
    dt = env.control_period_s
    rows, stations, psis = [obs], [info["station_m"]], [info["psi_rad"]]
    for _ in range(400):
        action, _ = policy.predict(obs)
        obs, _, terminated, truncated, info = env.step(action)
        assert not (terminated or truncated)
        rows.append(obs)
        stations.append(info["station_m"])
        psis.append(info["psi_rad"])
    o = np.array(rows, dtype=np.float64)
    s = np.array(stations)
    # curvature, its arc-length derivative and the preview against highway-env's own lane geometry
    np.testing.assert_allclose(o[:, OBS.CURVATURE], np.interp(s, s_tab, k_tab), atol=2e-5)
    dk_tab = np.gradient(k_tab, s_tab)
    np.testing.assert_allclose(o[:, OBS.CURVATURE_RATE], np.interp(s, s_tab, dk_tab), atol=2e-6)
    d = OBS.preview_distances(o[:, OBS.V_X])
    np.testing.assert_allclose(o[:, OBS.preview], np.interp(s[:, None] + d, s_tab, k_tab), atol=2e-5)
    assert np.abs(o[:, OBS.CURVATURE]).max() == pytest.approx(5 * (2 * np.pi / 100) ** 2, rel=0.02)
    # rates: central differences of the observed errors and of highway-env's heading
    mid = slice(1, -1)
    ey_dot_fd = (o[2:, OBS.E_Y] - o[:-2, OBS.E_Y]) / (2 * dt)
    ephi_dot_fd = (np.unwrap(o[2:, OBS.E_PHI]) - np.unwrap(o[:-2, OBS.E_PHI])) / (2 * dt)
    r_fd = (np.array(psis[2:]) - np.array(psis[:-2])) / (2 * dt)
    scale = np.abs(o[:, OBS.E_Y_DOT]).max()
    assert np.abs(ey_dot_fd - o[mid, OBS.E_Y_DOT]).max() < 0.03 * scale + 2e-3
    assert np.abs(ephi_dot_fd - o[mid, OBS.E_PHI_DOT]).max() < 0.03 * np.abs(o[:, OBS.E_PHI_DOT]).max() + 2e-3
    assert np.abs(r_fd - o[mid, OBS.YAW_RATE]).max() < 0.03 * np.abs(o[:, OBS.YAW_RATE]).max() + 2e-3
    # yaw_rate_ref = kappa s_dot and s_dot = d station / dt
    s_dot_fd = (s[2:] - s[:-2]) / (2 * dt)
    np.testing.assert_allclose(o[mid, OBS.YAW_RATE_REF], o[mid, OBS.CURVATURE] * s_dot_fd, atol=2e-3)
    # constant speed (no longitudinal control in lane-keeping-v0), body-frame lateral speed from highway-env
    np.testing.assert_allclose(o[:, OBS.V_X], 8.3, rtol=1e-6)
    np.testing.assert_allclose(o[:, OBS.TARGET_SPEED], 8.3, rtol=1e-6)
    assert o[-1, OBS.V_Y] == pytest.approx(env.vehicle.lateral_speed, rel=1e-5, abs=1e-6)


def test_reference_follows_highway_lane_switch() -> None:
    """start='highway': the reference is the lane highway-env rewards; at its switch to the sine lane e_y jumps."""
    env = HighwayLaneKeeping(start="highway")
    policy = make_policy("stanley", env)
    obs, _ = env.reset(seed=0)
    hw = env.highway_env
    ours, theirs, e_y = [], [], []
    for _ in range(300):
        action, _ = policy.predict(obs)
        obs, _, terminated, _, info = env.step(action)
        ours.append(env.reference_geometry.lane)
        theirs.append(hw.lane)
        e_y.append(info["e_y_m"])
        assert not terminated
    env.close()
    # highway-env switches lanes at the start of its next step: our reference is one step ahead of hw.lane
    assert all(o is t for o, t in zip(ours[:-1], theirs[1:], strict=True))
    k = next(i for i, lane in enumerate(ours) if isinstance(lane, SineLane))
    assert 2.0 < k * env.control_period_s < 4.5
    assert abs(e_y[k - 1]) < 0.1 and 7.0 < e_y[k] < 9.0  # the entry lane does not line up with the sine lane


# ---------------------------------------------------------------------------------- evaluation plumbing
def test_registered_id_rollout_and_suite() -> None:
    register_highway_envs()
    assert resolve_env_id("highway-env:lane-keeping-v0") == HIGHWAY_ENV_ID
    assert resolve_env_id("DLC120-v0") == "DLC120-v0"
    episodes = highway_episodes()
    assert [ep.seed for ep in episodes] == [0, 1, 2] and len(highway_episodes((0,))) == 1
    env = gym.make(HIGHWAY_ENV_ID)  # through Gymnasium's passive env checker
    from vtrack_gym.evaluation.scoring.metrics import evaluate_trace

    trace = rollout(make_policy("stanley", env), env, seed=episodes[2].seed, options=episodes[2].options,
                    max_steps=300)
    path = env.unwrapped.current_path  # what the benchmark's cone check and trajectory plot read
    assert path.gates == () and path.table.shape[1] == 2
    assert trace.termination == "max_steps"
    assert trace.acc_physics_mps2.shape == (300 * 5, 3)
    assert trace.physics_rate_hz == pytest.approx(250.0)
    metrics = evaluate_trace(trace)
    assert math.isfinite(metrics["comfort_a_v_mps2"]) and math.isfinite(metrics["rms_e_y_m"])
    assert metrics["min_fz_n"] == pytest.approx(9.81 / 4)
    env.close()


def test_missing_highway_env_gives_install_hint(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "highway_env", None)
    with pytest.raises(ImportError, match=r"pip install vtrack_gym\[highway\]"):
        HighwayLaneKeeping()


def test_registration_does_not_import_highway_env() -> None:
    code = ("import sys, gymnasium as gym, vtrack_gym; from vtrack_gym.interop import register_highway_envs, "
            "HIGHWAY_ENV_ID; import vtrack_gym.interop.highway; register_highway_envs(); "
            "assert HIGHWAY_ENV_ID in gym.registry; assert 'highway_env' not in sys.modules, 'eager import'")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_highway_suite_scores_and_draws_through_the_benchmark_command(tmp_path: Path) -> None:
    """``vtrack benchmark --suite highway`` (it crashed: the circle metrics and the trajectory figure assumed a
    ``tracks.Path``): rows stored, the board printed, the figures written (in the run's own folder under --figures)."""
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = tmp_path / "board.sqlite"
    assert main(["benchmark", "--suite", "highway", "--quick", "--policies", "lqr", "--store", str(store),
                 "--figures", str(tmp_path / "figures")]) == 0
    rows = ResultStore(store).rows(suite="highway[quick]")  # one seed: stored apart from the standard board
    assert len(rows) == 1 and rows[0]["metrics"]["success"] == 1.0
    assert sorted(p.name.split("_")[-1] for p in (tmp_path / "figures").rglob("*.png")) == \
        ["signals.png", "trajectories.png"]
