"""``BatchSim``: N cars on their tracks behind the PD-FLC speed loop, stepped by one compiled call.

The single env, the Gymnasium vector env and the SB3 adapter are thin front-ends over this class, so they
share every number. Each car has its own random generator (seeded like Gymnasium seeds sub-envs), so car
``i`` of a batch seeded with ``seed`` reproduces a single env seeded with ``seed + i`` bit for bit.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from vtrack_gym.envs.config import EnvConfig, ResetOptions, ScenarioConfig
from vtrack_gym.envs.pdflc import PDFLCConfig
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams
from vtrack_gym.vehicle.plant import PARALLEL_THRESHOLD, Plant

TERMINATION_NAMES: tuple[str, ...] = ("", "completed", "off_road", "spin_out", "wheel_lift", "invalid_state")
"""``info["termination"]`` for each kernel termination code ("" = still running)."""
PROCEDURAL_MAX_CURVATURE: tuple[float, float] = (1.0 / 18.0, 1.0 / 120.0)
"""Curvature bounds [1/m] of the twisty and the highway-like half of the procedural track bank: wider than the
evaluation courses need (handling course: R >= 20 m; DLC120-v0: R >= 140 m), so that a policy trained on the bank
never meets a curvature it has not seen."""
PROCEDURAL_MAX_DKAPPA: tuple[float, float] = (0.008, 0.004)
"""Curvature-rate bounds [1/m^2] of the two halves (handling course: 0.0063; DLC120-v0: 0.0020)."""
FEASIBLE_LATERAL_ACC_MPS2 = 0.85 * GRAVITY_MPS2
"""Randomised target speeds are capped at sqrt(this / peak curvature) of the drawn track [m/s^2] (DLC120-v0's
centre line peaks at 0.81 g)."""

REWARD_TERM_NAMES: tuple[str, ...] = (
    "reward_alive", "reward_tracking", "reward_heading", "reward_effort", "reward_rate", "reward_terminal")


def _kernels():
    from vtrack_gym.envs import kernels

    return kernels


@lru_cache(maxsize=8)
def scenario_tracks(scenario: ScenarioConfig, vehicle_width_m: float) -> tuple:
    """The paths a scenario drives on (built once per process and scenario)."""
    import vtrack_gym.tracks as tracks

    if scenario.track == "handling_course":
        return (tracks.handling_course(),)
    if scenario.track == "double_lane_change":
        return (tracks.double_lane_change(vehicle_width_m=vehicle_width_m),)
    # Half the bank twisty (radii down to 18 m), half highway-like (down to 120 m), so that every target speed
    # of the range has drivable tracks (see BatchSim.reset_car's speed cap).
    return tuple(tracks.procedural_track_from_config(
        scenario.procedural_seed + k,
        tracks.ProceduralTrackConfig(length_m=scenario.procedural_length_m,
                                     max_curvature_per_m=PROCEDURAL_MAX_CURVATURE[k % 2],
                                     max_dkappa_per_m2=PROCEDURAL_MAX_DKAPPA[k % 2]))
        for k in range(scenario.procedural_bank_size))


class BatchSim:
    """N independent cars (one per sub-env) on the scenario's track(s)."""

    def __init__(self, scenario: ScenarioConfig, config: EnvConfig, n: int) -> None:
        from vtrack_gym.envs.pdflc import control_surface
        from vtrack_gym.envs.pdflc_kernel import pdflc_gains

        self.scenario = scenario
        self.config = config
        self.n = n
        self.paths = scenario_tracks(scenario, config.vehicle.chassis.body_width_m)
        self.tables = np.ascontiguousarray(np.concatenate([p.table for p in self.paths]))
        counts = np.array([p.table.shape[0] for p in self.paths], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        k = _kernels()
        self.tmeta = np.column_stack([  # columns TM_START, TM_N, TM_DS, TM_LEN, TM_CLOSED, TM_HALF_WIDTH
            starts, counts, [p.ds_m for p in self.paths], [p.length_m for p in self.paths],
            [1.0 if p.closed else 0.0 for p in self.paths], [p.half_width_m for p in self.paths]]).astype(np.float64)

        self.plant = Plant(config.vehicle, n=n, model=config.model, physics_dt_s=config.physics_dt_s)
        pd = config.speed_controller
        self.pd_surface = np.ascontiguousarray(control_surface(pd.method, pd.surface_resolution))
        self.pd_mem = np.zeros((n, 3))
        self.n_sub = config.n_substeps
        self.layout = config.layout
        self.inputs = np.zeros((n, L.N_INPUT))
        self.road = np.zeros((n, L.N_ROAD))
        self.outputs = np.zeros((n, self.n_sub, L.N_OUTPUT))
        self.car = np.zeros((n, k.N_CAR))  # per-car scalars; the attributes below are column views
        self.s_prev = self.car[:, k.CAR_S_PREV]
        self.progress = self.car[:, k.CAR_PROGRESS]
        self.v_ref = self.car[:, k.CAR_V_REF]
        self.prev_action = self.car[:, k.CAR_PREV_ACTION]
        self.reward = self.car[:, k.CAR_REWARD]
        self.min_fz = self.car[:, k.CAR_MIN_FZ]
        self.v_ref[:] = scenario.target_speed_mps
        self.obs = np.zeros((n, self.layout.size), dtype=np.float32)
        self.err = np.zeros((n, 6))
        self.term = np.zeros(n, dtype=np.int64)
        self.rows = np.zeros((n, 8))
        self.veh_track = np.zeros(n, dtype=np.int64)
        self.steps = np.zeros(n, dtype=np.int64)
        self.noise_scale = np.zeros(n)
        self.delay_steps = np.zeros(n, dtype=np.int64)
        self.delay_buffer = np.zeros((n, 1))
        self.max_steps = round(scenario.max_episode_s / config.control_period_s)
        rc = config.reward
        lay = self.layout
        self.cfg = np.concatenate([
            [config.physics_dt_s, self.n_sub, lay.n_preview, lay.preview_dt_s, lay.preview_min_speed_mps,
             scenario.end_margin_m, 1.0 if pd.method == "mamdani" else 0.0,
             config.vehicle.steering.max_road_wheel_angle_rad],
            [rc.alive, rc.w_ey, rc.ey_scale_m, rc.w_ephi, rc.ephi_scale_rad, rc.w_effort, rc.w_rate,
             rc.failure_penalty, rc.completion_bonus]])
        # PD-FLC gains per car (GA tuning evaluates one individual per car); the surface is shared.
        self.pd_gains = np.tile(pdflc_gains(pd, config.control_period_s), (n, 1))
        assert self.cfg.shape == (k.N_CFG,)
        self.terms = np.zeros((n, 6))
        self.rngs: list[np.random.Generator] = [np.random.default_rng() for _ in range(n)]
        self.last_options: list[ResetOptions] = [ResetOptions() for _ in range(n)]
        self._noise_std = np.asarray(config.noise_std)
        self.any_noise = False
        self.any_delay = False
        self._one = np.zeros(1)
        self._max_steer = config.vehicle.steering.max_road_wheel_angle_rad
        self._step_kernel = k.step_parallel if n >= PARALLEL_THRESHOLD else k.step_serial
        self._observe = k.observe_indices

    # ------------------------------------------------------------------ reset
    def set_speed_controller(self, index: int | np.ndarray | slice, config: PDFLCConfig) -> None:
        """Give the selected cars other PD-FLC gains (G1..G4, filter); the method and surface stay shared."""
        from vtrack_gym.envs.pdflc_kernel import pdflc_gains

        own = self.config.speed_controller
        if config.method != own.method or config.surface_resolution != own.surface_resolution:
            raise ValueError("set_speed_controller: method and surface_resolution must match the env's "
                             f"({own.method}, {own.surface_resolution})")
        self.pd_gains[index] = pdflc_gains(config, self.config.control_period_s)

    def seed(self, index: int, seed: int | None) -> None:
        """Give car ``index`` a fresh generator (``None``: from OS entropy)."""
        self.rngs[index] = np.random.default_rng(seed)

    def reset_car(self, i: int, options: ResetOptions) -> None:
        """Put car ``i`` at the start of a (possibly new) track with the given scenario knobs."""
        sc, rng = self.scenario, self.rngs[i]
        self.veh_track[i] = int(rng.integers(len(self.paths))) if len(self.paths) > 1 else 0
        if options.target_speed_mps is not None:
            v_ref = options.target_speed_mps
        elif sc.target_speed_range_mps is not None:
            # Never ask for more lateral acceleration than the road can give (0.85 g at the track's tightest
            # curve): an infeasible episode teaches nothing but spinning out.
            lo, hi = sc.target_speed_range_mps
            start = int(self.tmeta[self.veh_track[i], 0])
            rows = self.tables[start:start + int(self.tmeta[self.veh_track[i], 1]), 3]
            kappa_peak = float(np.max(np.abs(rows)))
            if kappa_peak > 0.0:
                hi = max(lo, min(hi, float(np.sqrt(FEASIBLE_LATERAL_ACC_MPS2 / kappa_peak))))
            v_ref = float(rng.uniform(lo, hi))
        else:
            v_ref = sc.target_speed_mps
        v0 = v_ref if sc.initial_speed_mps > 0.0 else 0.0
        if sc.standstill_start_fraction > 0.0 and rng.random() < sc.standstill_start_fraction:
            v0 = 0.0
        self.v_ref[i] = v_ref

        params: VehicleParams = self.config.vehicle
        if options.mass_scale != 1.0:
            params = params.with_mass_scale(options.mass_scale)
        if options.friction_mu is not None:
            params = params.with_friction(options.friction_mu)
        self.plant.set_vehicle_params(i, params)

        start = self.tables[int(self.tmeta[self.veh_track[i], 0])]
        x0, y0, psi0 = start[0], start[1], start[2]
        off = options.initial_lateral_offset_m
        self.plant.reset(i, x=x0 - off * np.sin(psi0), y=y0 + off * np.cos(psi0), psi=psi0, v_x=v0)
        # Reset-time outputs: at rest on flat ground (no accelerations, static wheel loads of these params).
        from vtrack_gym.vehicle.packing import static_wheel_loads_n

        fz_front, fz_rear = static_wheel_loads_n(params)
        self.outputs[i] = 0.0
        self.outputs[i, :, L.O_FZFL:L.O_FZFR + 1] = fz_front
        self.outputs[i, :, L.O_FZRL:L.O_FZRR + 1] = fz_rear
        self.min_fz[i] = min(fz_front, fz_rear)
        self.road[i] = 0.0
        self.last_options[i] = options
        self.inputs[i] = 0.0
        self.steps[i] = 0
        self.prev_action[i] = 0.0
        self.noise_scale[i] = options.sensor_noise
        self.any_noise = bool(self.noise_scale.any())
        delay = round(options.actuator_delay_s / self.config.control_period_s)
        self.delay_steps[i] = delay
        if delay + 1 > self.delay_buffer.shape[1]:
            grown = np.zeros((self.n, delay + 1))
            grown[:, : self.delay_buffer.shape[1]] = self.delay_buffer
            self.delay_buffer = grown
        self.delay_buffer[i] = 0.0
        self.any_delay = bool(self.delay_steps.any())
        self.pd_mem[i] = (0.0, 0.0, 1.0)  # fresh: the first derivative of the speed error is 0
        self.term[i] = 0

    def observe_after_reset(self, idx: np.ndarray) -> None:
        """Project freshly reset cars (global search) and fill their observation rows."""
        self._observe(idx.astype(np.int64), self.plant.state, self.tables, self.tmeta, self.veh_track, self.car,
                      self.cfg, self.obs, self.road, self.err, self.rows)

    # ------------------------------------------------------------------ step
    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every car one control period. ``actions`` (n,) are finite, clipped to [-1, 1].

        Returns (reward (n,), terminated (n,), truncated (n,)); observations are in ``self.obs``.
        """
        cmd = self._delayed(actions) if self.any_delay else actions
        self.inputs[:, L.U_DELTA] = cmd * self._max_steer
        self._run_kernel(actions)
        self.steps += 1
        terminated = self.term != 0
        truncated = (self.steps >= self.max_steps) & ~terminated
        if self.any_noise:
            self._add_noise()
        return self.reward.copy(), terminated, truncated

    def step_one(self, action: float) -> tuple[float, int, bool]:
        """Fast path for a single car (n = 1): returns (reward, termination code, truncated)."""
        one = self._one
        one[0] = action
        cmd = self._delayed(one)[0] if self.any_delay else action
        self.inputs[0, L.U_DELTA] = cmd * self._max_steer
        self._run_kernel(one)
        steps = int(self.steps[0]) + 1
        self.steps[0] = steps
        code = int(self.term[0])
        if self.any_noise:
            self._add_noise()
        return float(self.reward[0]), code, code == 0 and steps >= self.max_steps

    def _run_kernel(self, actions: np.ndarray) -> None:
        self._step_kernel(self.plant.state, self.inputs, self.road, self.plant.param_rows, self.plant.models,
                          self.outputs, self.plant._work, self.tables, self.tmeta, self.veh_track, self.car, self.cfg,
                          self.obs, self.err, self.term, self.rows, actions, self.terms, self.pd_mem, self.pd_gains,
                          self.pd_surface)

    def _delayed(self, actions: np.ndarray) -> np.ndarray:
        """Commands delayed by ``delay_steps`` control periods (FIFO per car; zero before the first)."""
        buf = self.delay_buffer
        buf[:, 1:] = buf[:, :-1].copy()
        buf[:, 0] = actions
        return buf[np.arange(self.n), self.delay_steps]

    def _add_noise(self) -> None:
        for i in np.flatnonzero(self.noise_scale):
            self.obs[i, :8] += (self.noise_scale[i] * self._noise_std * self.rngs[i].standard_normal(8)).astype(
                np.float32)

    def reward_terms(self) -> dict[str, np.ndarray]:
        """The reward's terms of the last step for every car (see ``RewardConfig``)."""
        return {name: self.terms[:, k].copy() for k, name in enumerate(REWARD_TERM_NAMES)}

    # ------------------------------------------------------------------ signals
    def signals(self) -> dict[str, np.ndarray]:
        """Every signal the metrics need, for all cars (arrays of shape (n,) unless noted)."""
        st, out = self.plant.state, self.outputs
        ratio = self.config.vehicle.steering.steering_ratio
        return {
            "time_s": self.steps * self.config.control_period_s,
            "x_m": st[:, L.S_X].copy(),
            "y_m": st[:, L.S_Y].copy(),
            "z_m": self.err[:, 5].copy(),
            "psi_rad": st[:, L.S_PSI].copy(),
            "e_y_m": self.err[:, 1].copy(),
            "e_phi_rad": self.err[:, 2].copy(),
            "v_mps": st[:, L.S_VX].copy(),
            "v_y_mps": st[:, L.S_VY].copy(),
            "yaw_rate_radps": st[:, L.S_R].copy(),
            "road_wheel_angle_rad": st[:, L.S_DELTA].copy(),
            "hand_wheel_angle_rad": st[:, L.S_DELTA] * ratio,
            "steering_command_rad": self.inputs[:, L.U_DELTA].copy(),
            "roll_rad": st[:, L.S_ROLL].copy(),
            "throttle": self.inputs[:, L.U_THROTTLE].copy(),
            "brake_n": self.inputs[:, L.U_BRAKE].copy(),
            "a_x_mps2": out[:, -1, L.O_AX].copy(),
            "a_y_mps2": out[:, -1, L.O_AY].copy(),
            "a_z_mps2": out[:, -1, L.O_AZ].copy(),
            "fz_n": out[:, -1, L.O_FZFL:L.O_FZRR + 1].copy(),             # (n, 4) FL, FR, RL, RR
            "min_fz_n": self.min_fz.copy(),
            "acc_substeps_mps2": out[:, :, L.O_AX:L.O_AZ + 1].copy(),     # (n, n_sub, 3) at the physics rate
            "station_m": self.err[:, 0].copy(),
            "progress_m": self.progress.copy(),
            "target_speed_mps": self.v_ref.copy(),
        }
