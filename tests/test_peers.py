"""Classic peers (LQR, Stanley, pure pursuit, OSQP MPC) and the shared linear models, in the linear closed loop."""

from __future__ import annotations

import math

import numpy as np
import pytest
from linear_closed_loop import DESIGN, LinearPlant, curve_entry, dlc_proxy, simulate, straight

from vtrack_gym.baselines.linear_models import (
    curvature_preview_operator,
    error_model,
    lateral_matrices,
    sideslip_gain,
    steady_state_sideslip,
    steady_state_steer,
    understeer_gradient,
    zoh,
)
from vtrack_gym.baselines.lqr import LQR, LQR_PRESETS, LQRConfig, lqr_gain, lqr_table
from vtrack_gym.baselines.mpc_osqp import OSQP_MPC_PRESETS, OSQPMPC, OSQPMPCConfig, condensed_qp
from vtrack_gym.baselines.pure_pursuit import PURE_PURSUIT_PRESETS, PurePursuit, PurePursuitConfig
from vtrack_gym.baselines.stanley import STANLEY_PRESETS, Stanley, StanleyConfig
from vtrack_gym.envs.observation import OBS


# ------------------------------------------------------------------------------------------ linear models
def test_steady_state_helpers_match_paper_math() -> None:
    assert understeer_gradient(DESIGN) == pytest.approx(9.99e-5, rel=2e-3)            # 1.2
    assert steady_state_steer(DESIGN, 11.11, 0.01) == pytest.approx(0.02922, abs=1e-5)
    assert steady_state_steer(DESIGN, 33.33, 0.002) == pytest.approx(0.00604, abs=1e-5)
    assert steady_state_sideslip(DESIGN, 11.11, 0.01) == pytest.approx(0.01025, abs=1e-5)
    assert steady_state_sideslip(DESIGN, 33.33, 0.002) == pytest.approx(-0.01188, abs=1e-5)
    # they are the equilibrium of the linear model: -A^-1 B delta_ss gives r = v kappa and v_y = v beta_ss
    for v, k in ((11.11, 0.01), (33.33, 0.002)):
        a, b = lateral_matrices(DESIGN, v)
        vy, r = -np.linalg.solve(a, b * steady_state_steer(DESIGN, v, k))
        assert r == pytest.approx(v * k, rel=1e-9)
        assert vy / v == pytest.approx(steady_state_sideslip(DESIGN, v, k), rel=1e-9)


def test_open_loop_poles() -> None:
    # paper-math 1.2: -12.77 / -22.34 at 11.11 m/s; -4.64 / -7.07 at 33.33 m/s
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(lateral_matrices(DESIGN, 11.11)[0]).real),
                               [-22.34, -12.77], atol=0.01)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(lateral_matrices(DESIGN, 33.33)[0]).real),
                               [-7.07, -4.64], atol=0.01)


def test_error_model_equals_lateral_model() -> None:
    """A4, B4, E4, F4 = paper-math 2.2 after v_y = e_y_dot - v e_phi, r = e_phi_dot + psi_ref_dot."""
    v = 17.0
    em = error_model(DESIGN, v)
    a, b = lateral_matrices(DESIGN, v)
    rng = np.random.default_rng(0)
    x, delta, rate, acc = rng.normal(size=4), 0.03, 0.2, 0.1
    vy, r = x[1] - v * x[2], x[3] + rate
    dvy, dr = a @ [vy, r] + b * delta
    expected = [x[1], dvy + v * (r - rate), x[3], dr - acc]
    np.testing.assert_allclose(em.a @ x + em.b * delta + em.e * rate + em.f * acc, expected, rtol=1e-12)


def test_zoh_multiple_columns_and_errors() -> None:
    em = error_model(DESIGN, 10.0)
    _, bd = zoh(em.a, np.column_stack((em.b, em.e)), 0.01)
    _, b1 = zoh(em.a, em.b, 0.01)
    assert bd.shape == (4, 2)
    np.testing.assert_allclose(bd[:, 0], b1)
    with pytest.raises(ValueError, match="sample_time_s"):
        zoh(em.a, em.b, 0.0)
    with pytest.raises(ValueError, match="v_x"):
        error_model(DESIGN, 0.0)


def test_curvature_preview_operator() -> None:
    v = 12.0
    dists = OBS.preview_distances(v)
    s0 = 3.0
    prof = curve_entry(10.0, 80.0, t_start=0.5, t_ramp=2.0)    # smooth ramp over 20 m
    p = np.concatenate(([prof.kappa(s0)], [prof.kappa(s0 + d) for d in dists], [prof.dkappa(s0)]))
    q = np.linspace(0.0, 30.0, 61)
    kap, dkap = curvature_preview_operator(OBS, v, q)
    np.testing.assert_allclose(kap @ p, [prof.kappa(s0 + x) for x in q], atol=5e-5)      # 1.2 m spacing
    np.testing.assert_allclose(dkap @ p, [prof.dkappa(s0 + x) for x in q], atol=1.5e-4)
    np.testing.assert_allclose(kap[0] @ p, p[0])
    np.testing.assert_allclose(dkap[0] @ p, p[-1])
    far, dfar = curvature_preview_operator(OBS, v, [dists[-1] + 5.0])
    assert far[0] @ p == pytest.approx(p[-2]) and dfar[0] @ p == 0.0


# -------------------------------------------------------------------------------------------------- LQR
def test_lqr_gain_is_dare_optimal() -> None:
    from scipy.linalg import solve_discrete_are

    cfg = LQR_PRESETS["default"]
    k = lqr_gain(DESIGN, 20.0, cfg, 0.01)
    em = error_model(DESIGN, 20.0)
    ad, bd = zoh(em.a, em.b, 0.01)
    q = np.diag([cfg.q_e_y, cfg.q_e_y_dot, cfg.q_e_phi, cfg.q_e_phi_dot])
    p = solve_discrete_are(ad, bd[:, None], q, np.array([[cfg.r_delta]]))
    assert np.max(np.abs(np.linalg.eigvals(ad - np.outer(bd, k)))) < 1.0
    np.testing.assert_allclose(k, (bd @ p @ ad) / (cfg.r_delta + bd @ p @ bd), rtol=1e-9)
    speeds, table = lqr_table(DESIGN, cfg, 0.01)
    j = 30
    v = speeds[j]
    kj = lqr_gain(DESIGN, float(v), cfg, 0.01)
    ff = DESIGN.wheelbase_m + understeer_gradient(DESIGN) * v * v - kj[2] * sideslip_gain(DESIGN, float(v))
    np.testing.assert_allclose(table[j], np.concatenate((-kj, [ff])), rtol=1e-9)


def test_lqr_feedforward_removes_steady_state_error() -> None:
    pol = LQR(DESIGN)
    res = simulate(pol, 11.11, curve_entry(11.11, 100.0), 10.0)
    assert abs(res.final("e_y")) < 2e-4
    assert res.final("delta") == pytest.approx(0.02922, abs=2e-5)
    no_ff = simulate(LQR(DESIGN, LQRConfig(feedforward=False)), 11.11, curve_entry(11.11, 100.0), 10.0)
    assert abs(no_ff.final("e_y")) > 10 * abs(res.final("e_y"))


def test_lqr_lead_uses_preview() -> None:
    pol = LQR(DESIGN, LQRConfig(feedforward_lead_s=0.1, q_e_y=0.0, q_e_y_dot=0.0, q_e_phi=0.0, q_e_phi_dot=0.0))
    plant = LinearPlant(10.0, curve_entry(10.0, 50.0, t_start=0.0, t_ramp=2.0))
    obs = plant.observation()
    lead = OBS.preview_distances(10.0)[0]          # 0.1 s ahead = the first preview sample
    a, _ = pol.predict(obs)
    expected = plant.profile.kappa(lead) * (DESIGN.wheelbase_m + understeer_gradient(DESIGN) * 100.0)
    assert float(a[0]) * pol.max_steer_rad == pytest.approx(expected, rel=1e-5)


# ---------------------------------------------------------------------------------------------- Stanley
def test_stanley_signs_and_steady_state() -> None:
    pol = Stanley(DESIGN, StanleyConfig(yaw_damping_s=0.0))
    obs = LinearPlant(10.0, straight(), e_y0=0.5).observation()
    a, _ = pol.predict(obs)
    assert a[0] < 0.0                                  # left of the path -> steer right
    expected = -math.atan(pol.config.gain_k * 0.5 / (pol.config.softening_mps + 10.0))
    assert float(a[0]) * pol.max_steer_rad == pytest.approx(expected, rel=1e-5)
    res = simulate(Stanley(DESIGN), 33.33, curve_entry(33.33, 500.0), 10.0)
    assert abs(res.final("e_y")) < 2e-4


# ----------------------------------------------------------------------------------------- pure pursuit
def test_pure_pursuit_exact_on_a_steady_circle() -> None:
    """On the linear model's steady state on a circle, kappa_cmd = kappa and delta = delta_ss."""
    v, radius = 15.0, 120.0
    k = 1.0 / radius
    plant = LinearPlant(v, curve_entry(v, radius, t_start=-10.0))   # already on the circle
    beta = steady_state_sideslip(DESIGN, v, k)
    plant.x[1], plant.x[2], plant.x[3] = -beta, v * beta, v * k     # e_phi = -beta_ss, v_y, r
    pol = PurePursuit(DESIGN)
    a, _ = pol.predict(plant.observation())
    # v_y = v beta exactly, so the course angle is atan(beta) and e_phi = -beta: a tiny residual angle
    assert float(a[0]) * pol.max_steer_rad == pytest.approx(steady_state_steer(DESIGN, v, k), rel=2e-3)


def test_pure_pursuit_lookahead_and_straight_line_geometry() -> None:
    pol = PurePursuit(DESIGN, PurePursuitConfig(use_course_angle=False, understeer_compensation=False))
    assert pol.lookahead(0.0) == 4.0 and pol.lookahead(10.0) == 8.0 and pol.lookahead(100.0) == 40.0
    obs = LinearPlant(10.0, straight(), e_y0=1.0).observation()
    a, _ = pol.predict(obs)
    # goal on the straight path 8 m from the CG: (sqrt(63), -1): kappa = 2 * (-1) / 64
    assert float(a[0]) * pol.max_steer_rad == pytest.approx(math.atan(DESIGN.wheelbase_m * -2.0 / 64.0), rel=1e-6)


# --------------------------------------------------------------------------------------------- OSQP MPC
def test_osqp_matches_unconstrained_qp_when_constraints_inactive() -> None:
    cfg = OSQPMPCConfig(rate_limit=False, speed_update_tol_mps=0.0)
    pol = OSQPMPC(DESIGN, cfg)
    v = float(np.geomspace(1.0, 45.0, 60)[40])        # a grid speed: no interpolation error
    plant = LinearPlant(v, curve_entry(v, 300.0, t_start=0.2), e_y0=0.02)
    obs = plant.observation()
    a, state = pol.predict(obs)
    qp = condensed_qp(DESIGN, v, cfg)
    lay = OBS
    z = np.concatenate(([obs[lay.E_Y], obs[lay.E_Y_DOT], obs[lay.E_PHI], obs[lay.E_PHI_DOT], obs[lay.CURVATURE]],
                        obs[lay.preview], [obs[lay.CURVATURE_RATE], obs[lay.ROAD_WHEEL_ANGLE]]))
    u_star = np.linalg.solve(qp.p, -qp.mq @ z)
    assert np.all(np.abs(u_star) < 0.6)
    assert float(a[0]) * pol.max_steer_rad == pytest.approx(u_star[0], abs=2e-6)
    np.testing.assert_allclose(state[0, 2:2 + cfg.control_horizon], u_star, atol=1e-4)


def test_osqp_respects_angle_and_rate_constraints() -> None:
    pol = OSQPMPC(DESIGN)
    rate = DESIGN.max_road_wheel_rate_radps * pol.config.sample_time_s
    res = simulate(pol, 11.11, straight(), 3.0, e_y0=3.0)
    d = res.delta
    assert np.max(np.abs(d)) <= DESIGN.max_road_wheel_angle_rad + 1e-9
    assert np.max(np.abs(np.diff(d))) <= rate + 1e-6
    assert np.isclose(np.max(np.abs(np.diff(d))), rate, atol=1e-4)       # the rate limit is active
    assert abs(res.e_y[-1]) < 0.3


def test_osqp_p_updates_only_when_speed_changes() -> None:
    pol = OSQPMPC(DESIGN)
    calls = []
    real = pol._solver.update

    def spy(**kwargs: object) -> None:
        calls.append(sorted(kwargs))
        return real(**kwargs)

    pol._solver.update = spy
    obs = LinearPlant(20.0, straight(), e_y0=0.1).observation()
    state = None
    for v in (20.0, 20.01, 20.02, 25.0):
        obs[OBS.V_X] = v
        _, state = pol.predict(obs, state, episode_start=True)
    p_updates = [c for c in calls if "Px" in c]
    assert len(p_updates) == 2                         # 20.0 (from the setup speed) and 25.0
    assert all("Ax" not in c for c in calls)           # A is never touched


def test_osqp_config_validation() -> None:
    with pytest.raises(ValueError, match=r"OSQPMPCConfig\.control_horizon"):
        OSQPMPCConfig(control_horizon=0)
    with pytest.raises(ValueError, match=r"OSQPMPCConfig\.r_delta"):
        OSQPMPCConfig(r_delta=0.0)


# ------------------------------------------------------------------------------- default closed loops
CASES = {"R100": (11.11, lambda: curve_entry(11.11, 100.0), 8.0),
         "R500": (33.33, lambda: curve_entry(33.33, 500.0), 8.0),
         "DLC": (33.33, dlc_proxy, 7.0)}
# max|e_y| [m] measured with the default presets in this linear closed loop (ideal actuator, 10 ms control)
BOUNDS = {
    "lqr": {"R100": 0.012, "R500": 0.008, "DLC": 0.03},           # measured 7.8 / 4.7 / 20.3 mm
    "stanley": {"R100": 0.005, "R500": 0.025, "DLC": 0.08},       # measured 2.6 / 18.0 / 63.0 mm
    "pure_pursuit": {"R100": 0.12, "R500": 0.10, "DLC": 0.45},   # measured 83.9 / 69.4 / 373 mm
    "mpc_osqp": {"R100": 0.004, "R500": 0.008, "DLC": 0.035},     # measured 1.1 / 4.9 / 25.9 mm
}
FACTORIES = {"lqr": lambda: LQR(DESIGN, LQR_PRESETS["default"]),
             "stanley": lambda: Stanley(DESIGN, STANLEY_PRESETS["default"]),
             "pure_pursuit": lambda: PurePursuit(DESIGN, PURE_PURSUIT_PRESETS["default"]),
             "mpc_osqp": lambda: OSQPMPC(DESIGN, OSQP_MPC_PRESETS["default"])}


@pytest.mark.parametrize("name", list(FACTORIES))
@pytest.mark.parametrize("case", list(CASES))
def test_default_presets_track(name: str, case: str) -> None:
    v, profile, t_end = CASES[case]
    res = simulate(FACTORIES[name](), v, profile(), t_end)
    assert res.max_abs_e_y() < BOUNDS[name][case]
    if case != "DLC":
        assert abs(res.final("e_y")) < 2e-3


@pytest.mark.parametrize("name", list(FACTORIES))
def test_default_presets_remove_an_offset(name: str) -> None:
    for v in (11.11, 33.33):
        res = simulate(FACTORIES[name](), v, straight(), 6.0, e_y0=0.5)
        assert abs(res.e_y[-1]) < 0.03
        assert np.max(np.abs(res.delta)) < 0.3
