"""``BatchSim``: N cars on their tracks behind the PD-FLC speed loop, stepped by one compiled call.

The single env, the Gymnasium vector env and the SB3 adapter are thin front-ends over this class, so they
share every number. Each car has its own random generator (seeded like Gymnasium seeds sub-envs), so car
``i`` of a batch seeded with ``seed`` reproduces a single env seeded with ``seed + i`` bit for bit.
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np

from vtrack_gym.envs.config import EnvConfig, ResetOptions, ScenarioConfig
from vtrack_gym.envs.observation import NOISY_INDICES
from vtrack_gym.envs.pdflc import PDFLCConfig
from vtrack_gym.envs.scenarios import MANEUVER_TRACK_NAMES, MAX_EPISODE_S, maneuver_path
from vtrack_gym.envs.schema import REWARD_TERMS, SIGNAL_ROW
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



def _kernels():
    from vtrack_gym.envs import kernels

    return kernels


MIN_TRACK_LENGTH_FACTOR = 4.0
"""A user's track is at least this x the scenario's ``end_margin_m`` long (20 m by default): a 3 m road would
count as completed at the first step."""


def scenario_tracks(scenario: ScenarioConfig, vehicle_width_m: float) -> tuple:
    """The paths a scenario drives on, with the scenario's constant half width if it sets one (built-in tracks are
    built once per process; a CSV file is read at every call, a ``tracks.Path`` is used as is)."""
    from dataclasses import replace

    if scenario.is_builtin:
        paths = _builtin_tracks(scenario.track, vehicle_width_m, scenario.procedural_seed, scenario.procedural_length_m,
                                scenario.procedural_bank_size)
    else:
        from vtrack_gym.tracks import load_track

        paths = (load_track(scenario.track, closed=scenario.track_closed, smoothing_m=scenario.track_smoothing_m),)
        min_length_m = MIN_TRACK_LENGTH_FACTOR * scenario.end_margin_m
        if paths[0].length_m < min_length_m:
            raise ValueError(f"track {paths[0].name!r} is {paths[0].length_m:.3g} m long: a track needs at least "
                             f"{min_length_m:g} m ({MIN_TRACK_LENGTH_FACTOR:g} x end_margin_m, the distance before "
                             "an open road's end at which it counts as completed)")
    if scenario.half_width_m is not None:
        paths = tuple(replace(p, half_width_m=scenario.half_width_m, widths_m=None) for p in paths)
    return paths


@lru_cache(maxsize=8)
def _builtin_tracks(track: str, vehicle_width_m: float, procedural_seed: int, procedural_length_m: float,
                    bank_size: int) -> tuple:
    """The built-in paths of a scenario (cached)."""
    import vtrack_gym.tracks as tracks

    if track == "handling_course":
        return (tracks.handling_course(),)
    if track == "double_lane_change":
        return (tracks.double_lane_change(vehicle_width_m=vehicle_width_m),)
    if track in MANEUVER_TRACK_NAMES:
        return (maneuver_path(track, vehicle_width_m),)
    if track == "training_mix":
        from vtrack_gym.tracks.training_mix import training_bank

        return training_bank(procedural_seed, bank_size, vehicle_width_m)
    # Half the bank twisty (radii down to 18 m), half highway-like (down to 120 m), so that every target speed
    # of the range has drivable tracks (see BatchSim.reset_car's speed cap).
    return tuple(tracks.procedural_track_from_config(
        procedural_seed + k,
        tracks.ProceduralTrackConfig(length_m=procedural_length_m,
                                     max_curvature_per_m=PROCEDURAL_MAX_CURVATURE[k % 2],
                                     max_dkappa_per_m2=PROCEDURAL_MAX_DKAPPA[k % 2]))
        for k in range(bank_size))


def _speed_tables(paths: tuple, scenario: ScenarioConfig) -> tuple:
    """One ``tracks.SpeedTable`` per path: the scenario's profile, or its constant target speed."""
    from vtrack_gym.tracks.speed_profiles import ConstantSpeed, speed_table

    profile = scenario.speed_profile if scenario.speed_profile is not None else ConstantSpeed(
        scenario.target_speed_mps)
    return tuple(speed_table(p, profile) for p in paths)


def _criterion(success: str, path) -> str:
    """The success criterion of a scenario on one of its paths (``auto`` resolved; ``gates`` needs gates)."""
    if success == "auto" or (success == "gates" and not path.gates):
        return "gates" if path.gates else ("lap" if path.closed else "end")
    return success


CIRCLE_MIN_PEAK_G = 0.5
"""``circle`` criterion: a car whose peak |a_y| stays below this share of mu g never reached its grip limit."""
TIME_LIMIT_FACTOR = 1.5
TIME_LIMIT_MARGIN_S = 30.0


def _time_limit_s(tables: tuple, paths: tuple) -> float:
    """A scenario's derived time limit [s]: ``TIME_LIMIT_FACTOR`` x the longest profile lap time (v linear between
    rows) + ``TIME_LIMIT_MARGIN_S`` (the standstill start and the PD-FLC lag). ValueError naming the lap time and
    the fix if it exceeds ``MAX_EPISODE_S``."""
    def lap_s(t) -> float:
        v = t.v_mps
        return float(np.sum(2.0 * t.ds_m / (v[1:] + v[:-1])))

    laps = [lap_s(t) for t in tables]
    k = int(np.argmax(laps))
    limit = TIME_LIMIT_FACTOR * laps[k] + TIME_LIMIT_MARGIN_S
    if limit > MAX_EPISODE_S:
        length = float(tables[k].length_m)
        raise ValueError(f"track {paths[k].name!r}: the speed profile takes {laps[k]:.4g} s for its {length:.4g} m "
                         f"(mean {length / laps[k]:.3g} m/s), so the derived time limit {TIME_LIMIT_FACTOR} x lap + "
                         f"{TIME_LIMIT_MARGIN_S:.0f} s = {limit:.4g} s exceeds the maximum "
                         f"{MAX_EPISODE_S:.0f} s of simulated time; fix: raise the profile's speeds "
                         "(--max-speed-kmh, the file's speed column) or drive a shorter track")
    return limit


class BatchSim:
    """N independent cars (one per sub-env) on the scenario's track(s)."""

    def __init__(self, scenario: ScenarioConfig, config: EnvConfig, n: int) -> None:
        from vtrack_gym.envs.pdflc import control_surface
        from vtrack_gym.envs.pdflc_kernel import pdflc_gains

        self.config = config
        self.n = n
        self.paths = scenario_tracks(scenario, config.vehicle.chassis.body_width_m)
        self.speed_tables = _speed_tables(self.paths, scenario)
        if scenario.max_episode_s is None:
            scenario = replace(scenario, max_episode_s=_time_limit_s(self.speed_tables, self.paths))
        self.scenario = scenario
        profiled = scenario.speed_profile is not None
        self.tables = np.ascontiguousarray(np.concatenate([
            np.column_stack([p.table, t.v_mps ** 2, p.half_widths_rows()]) for p, t in zip(
                self.paths, self.speed_tables, strict=True)]))
        counts = np.array([p.table.shape[0] for p in self.paths], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        k = _kernels()
        self.tmeta = np.column_stack([  # columns TM_START, TM_N, TM_DS, TM_LEN, TM_CLOSED, TM_HALF_WIDTH, TM_PROFILE
            starts, counts, [p.ds_m for p in self.paths], [p.length_m for p in self.paths],
            [1.0 if p.closed else 0.0 for p in self.paths], [p.half_width_m for p in self.paths],
            [1.0 if profiled else 0.0] * len(self.paths)]).astype(np.float64)

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
        self.follow = self.car[:, k.CAR_FOLLOW]
        self.v_ref[:] = scenario.target_speed_mps
        self.obs = np.zeros((n, self.layout.size), dtype=np.float32)
        self.err = np.zeros((n, k.ERR_COLS))
        self.term = np.zeros(n, dtype=np.int64)
        self.rows = np.zeros((n, k.N_ENV_COLS))
        self.actions = np.zeros(n)
        self.sig = np.zeros((n, k.N_SIG))  # info signals and reward terms (envs.schema.SIGNAL_ROW)
        self.terms = self.sig[:, k.SIG_REWARD:k.SIG_REWARD + k.N_TERMS]
        self.veh_track = np.zeros(n, dtype=np.int64)
        self.steps = np.zeros(n, dtype=np.int64)
        self.noise_scale = np.zeros(n)
        self.delay_steps = np.zeros(n, dtype=np.int64)
        self.delay_buffer = np.zeros((n, 1))
        self.max_steps = round(scenario.max_episode_s / config.control_period_s)
        self.cfg = k.pack_cfg(k.StepConstants.of(scenario, config), self.layout, config.reward)
        # PD-FLC gains per car (GA tuning evaluates one individual per car); the surface is shared.
        self.pd_gains = np.tile(pdflc_gains(pd, config.control_period_s), (n, 1))
        self.rngs: list[np.random.Generator] = [np.random.default_rng() for _ in range(n)]
        self.last_options: list[ResetOptions] = [ResetOptions() for _ in range(n)]
        self._noise_std = np.asarray(config.noise_std)
        self._noisy = np.asarray(NOISY_INDICES, dtype=np.intp)
        low, high = self.layout.bounds()
        self._noisy_low = np.asarray(low, dtype=np.float32)[self._noisy]
        self._noisy_high = np.asarray(high, dtype=np.float32)[self._noisy]
        self.any_noise = False
        self.any_delay = False
        self.max_steer_rad = config.vehicle.steering.max_road_wheel_angle_rad  # road-wheel angle of action 1 [rad]
        # The attributes above are the arrays of this bundle: modify them in place, never rebind them.
        self.arrays = k.SimArrays(
            states=self.plant.state, inputs=self.inputs, road=self.road, params=self.plant.param_rows,
            models=self.plant.models, outputs=self.outputs, work=self.plant._work, tables=self.tables,
            tmeta=self.tmeta, veh_track=self.veh_track, car=self.car, cfg=self.cfg, obs=self.obs, err=self.err,
            term=self.term, rows=self.rows, actions=self.actions, sig=self.sig, pd_mem=self.pd_mem,
            pd_gains=self.pd_gains, pd_surface=self.pd_surface)
        self._step_kernel = k.step_parallel if n >= PARALLEL_THRESHOLD else k.step_serial
        self._step_compiled = None  # the kernel's compiled entry point for ``self.arrays`` (see _run_kernel)
        self._observe = k.observe_indices
        # Success verdicts: cone gates left by the body so far (only paths with gates are checked).
        self.gate_hit = np.zeros(n, dtype=bool)
        self._gated = tuple(k for k, p in enumerate(self.paths) if p.gates)
        c = config.vehicle.chassis
        from vtrack_gym.tracks.dlc import car_outline

        lon, lat = car_outline(0.0, 0.0, 0.0, c.body_length_m, c.body_width_m, c.cg_to_front_end_m)
        self._corner_lon, self._corner_lat = lon.ravel(), lat.ravel()  # body-outline points (corners and sides)
        self._gate_row = np.zeros(k.N_COLS)
        from vtrack_gym.tracks.kernels import gate_rows

        self._gate_data = {t: (self.paths[t], gate_rows(self.paths[t].gates),
                               min(g.s_start_m for g in self.paths[t].gates) - c.body_length_m,
                               max(g.s_end_m for g in self.paths[t].gates) + c.body_length_m)
                           for t in self._gated}
        # ``circle`` criterion: left the lateral band; reference speed at the grip-limit speed; peak |a_y| [m/s^2]
        # while still in the band and over the whole circle; the least peak that shows the car reached its limit
        self.circle_left = np.zeros(n, dtype=bool)
        self.circle_reached = np.zeros(n, dtype=bool)
        self.circle_steady_a_y = np.zeros(n)
        self.circle_peak_a_y = np.zeros(n)
        self.circle_min_peak_a_y = np.zeros(n)
        self.criteria = tuple(_criterion(scenario.success, p) for p in self.paths)
        self._by_gates = np.array([c == "gates" for c in self.criteria], dtype=bool)  # per track
        self._by_circle = np.array([c == "circle" for c in self.criteria], dtype=bool)
        self._checked = bool(self._gated) or bool(self._by_circle.any())

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

    def delay_steps_of(self, options: ResetOptions) -> int:
        """``options.actuator_delay_s`` in control periods; ``ValueError`` naming the option unless it is a whole
        number of control periods (within 1e-9 of one; the delay is applied exactly, never rounded)."""
        period = self.config.control_period_s
        ratio = options.actuator_delay_s / period
        steps = round(ratio)
        if abs(ratio - steps) > 1e-9:
            raise ValueError(f"reset option 'actuator_delay_s' must be a whole number of control periods "
                             f"({period * 1e3:g} ms; e.g. 0, {period:g}, {2 * period:g} s) "
                             f"(got {options.actuator_delay_s!r})")
        return steps

    def reset_car(self, i: int, options: ResetOptions) -> None:
        """Put car ``i`` at the start of a (possibly new) track with the given scenario knobs."""
        self.delay_steps_of(options)  # refuse a bad delay before changing anything
        sc, rng = self.scenario, self.rngs[i]
        given = options
        options = self._randomised(options, rng)
        self.veh_track[i] = int(rng.integers(len(self.paths))) if len(self.paths) > 1 else 0
        follow = False
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
        elif sc.speed_profile is not None:  # the profile's speed at the start (updated from it every step)
            v_ref = float(self.speed_tables[self.veh_track[i]].v_mps[0])
            follow = True
        else:
            v_ref = sc.target_speed_mps
        self.follow[i] = 1.0 if follow else 0.0
        v0 = v_ref if sc.initial_speed_mps > 0.0 else 0.0
        if sc.standstill_start_fraction > 0.0 and rng.random() < sc.standstill_start_fraction:
            v0 = 0.0
        self.v_ref[i] = v_ref

        params: VehicleParams = self.config.vehicle
        if options.mass_scale != 1.0:
            params = params.with_mass_scale(options.mass_scale)
        if options.friction_mu is not None:
            params = params.with_friction(options.friction_mu)
        if options.steering_rate_scale != 1.0:
            params = params.with_steering_rate_scale(options.steering_rate_scale)
        self.plant.set_vehicle_params(i, params)
        self.circle_min_peak_a_y[i] = CIRCLE_MIN_PEAK_G * params.tyres.friction_mu * GRAVITY_MPS2

        start = self.tables[int(self.tmeta[self.veh_track[i], 0])]
        x0, y0, psi0 = start[0], start[1], start[2]
        off = options.initial_lateral_offset_m
        self.plant.reset(i, x=x0 - off * np.sin(psi0), y=y0 + off * np.cos(psi0),
                         psi=psi0 + options.initial_heading_error_rad, v_x=v0)
        # Reset-time outputs: at rest on flat ground (no accelerations, static wheel loads of these params).
        from vtrack_gym.vehicle.packing import static_wheel_loads_n

        fz_front, fz_rear = static_wheel_loads_n(params)
        self.outputs[i] = 0.0
        self.outputs[i, :, L.O_FZFL:L.O_FZFR + 1] = fz_front
        self.outputs[i, :, L.O_FZRL:L.O_FZRR + 1] = fz_rear
        self.min_fz[i] = min(fz_front, fz_rear)
        self.road[i] = 0.0
        self.last_options[i] = given  # an autoreset draws the randomised knobs afresh
        self.inputs[i] = 0.0
        self.steps[i] = 0
        self.prev_action[i] = 0.0
        self.noise_scale[i] = options.sensor_noise
        self.any_noise = bool(self.noise_scale.any())
        delay = self.delay_steps_of(options)
        self.delay_steps[i] = delay
        if delay + 1 > self.delay_buffer.shape[1]:
            grown = np.zeros((self.n, delay + 1))
            grown[:, : self.delay_buffer.shape[1]] = self.delay_buffer
            self.delay_buffer = grown
        self.delay_buffer[i] = 0.0
        self.any_delay = bool(self.delay_steps.any())
        self.pd_mem[i] = (0.0, 0.0, 1.0)  # fresh: the first derivative of the speed error is 0
        self.term[i] = 0
        self.gate_hit[i] = False
        self.circle_left[i] = False
        self.circle_reached[i] = False
        self.circle_steady_a_y[i] = 0.0
        self.circle_peak_a_y[i] = 0.0

    def _randomised(self, options: ResetOptions, rng: np.random.Generator) -> ResetOptions:
        """``options`` with the scenario's domain randomisation drawn for every knob they leave at its default and
        the caller did not give (``ResetOptions.explicit``; ``ScenarioConfig.friction_range`` ...); unchanged (and
        no draw) for a scenario without ranges."""
        sc = self.scenario
        changes: dict[str, float] = {}

        def free(name: str, default: float | None) -> bool:
            return name not in options.explicit and getattr(options, name) == default

        if sc.friction_range is not None and free("friction_mu", None):
            changes["friction_mu"] = float(rng.uniform(*sc.friction_range))
        if sc.mass_scale_range is not None and free("mass_scale", 1.0):
            changes["mass_scale"] = float(rng.uniform(*sc.mass_scale_range))
        if sc.sensor_noise_range is not None and free("sensor_noise", 0.0):
            changes["sensor_noise"] = float(rng.uniform(*sc.sensor_noise_range))
        if sc.max_actuator_delay_s > 0.0 and free("actuator_delay_s", 0.0):
            period = self.config.control_period_s
            steps = int(rng.integers(0, int(sc.max_actuator_delay_s / period + 1e-9) + 1))
            changes["actuator_delay_s"] = steps * period
        if sc.steering_rate_scale_range is not None and free("steering_rate_scale", 1.0):
            changes["steering_rate_scale"] = float(rng.uniform(*sc.steering_rate_scale_range))
        if sc.initial_lateral_offset_range_m is not None and free("initial_lateral_offset_m", 0.0):
            changes["initial_lateral_offset_m"] = float(rng.uniform(*sc.initial_lateral_offset_range_m))
        if sc.initial_heading_error_range_rad is not None and free("initial_heading_error_rad", 0.0):
            changes["initial_heading_error_rad"] = float(rng.uniform(*sc.initial_heading_error_range_rad))
        return replace(options, **changes) if changes else options

    def observe_after_reset(self, idx: np.ndarray) -> None:
        """Project freshly reset cars (global search) and fill their observation rows."""
        self._observe(idx.astype(np.int64), self.arrays)

    # ------------------------------------------------------------------ step
    def step(self, actions: np.ndarray, quiet: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every car one control period. ``actions`` (n,) are finite, clipped to [-1, 1]; ``quiet`` (bool
        (n,)) marks cars whose step will be discarded (no sensor noise is drawn for them).

        Returns (reward (n,), terminated (n,), truncated (n,)); observations are in ``self.obs``.
        """
        self.actions[:] = actions
        cmd = self._delayed(self.actions) if self.any_delay else self.actions
        self.inputs[:, L.U_DELTA] = cmd * self.max_steer_rad
        self._run_kernel()
        self.steps += 1
        if self._checked:
            self._check_verdicts()
        terminated = self.term != 0
        truncated = (self.steps >= self.max_steps) & ~terminated
        if self.any_noise:
            self._add_noise(quiet)
        return self.reward.copy(), terminated, truncated

    def step_one(self, action: float) -> tuple[float, int, bool]:
        """Fast path for a single car (n = 1): returns (reward, termination code, truncated)."""
        self.actions[0] = action
        cmd = self._delayed(self.actions)[0] if self.any_delay else action
        self.inputs[0, L.U_DELTA] = cmd * self.max_steer_rad
        self._run_kernel()
        steps = int(self.steps[0]) + 1
        self.steps[0] = steps
        if self._checked:
            self._check_verdicts()
        code = int(self.term[0])
        if self.any_noise:
            self._add_noise()
        return float(self.reward[0]), code, code == 0 and steps >= self.max_steps

    def _run_kernel(self) -> None:
        """One compiled step of every car on ``self.arrays``.

        After the first call the kernel's compiled entry point for the bundle's types is called directly: numba's
        dispatcher would otherwise type the 21-array bundle on every call (~1.5 us, 6 % of a single-env step).
        Safe because the bundle is immutable and its arrays are only modified in place.
        """
        if self._step_compiled is not None:
            self._step_compiled(self.arrays)
            return
        self._step_kernel(self.arrays)
        from numba import typeof

        try:
            self._step_compiled = self._step_kernel.get_overload((typeof(self.arrays),))
        except KeyError:  # no exact overload (should not happen): keep the dispatcher
            self._step_compiled = self._step_kernel

    def _check_verdicts(self) -> None:
        """Per-step parts of the success verdicts: cone gates, and the ``circle`` band until the grip limit."""
        if self._gated:
            self._check_gates()
        if self._by_circle.any():
            k = _kernels()
            on = self._by_circle[self.veh_track] & (self.steps > 0)
            a_y = np.abs(self.sig[:, k.SIG_AY])
            self.circle_reached |= on & (self.v_ref >= self.scenario.grip_limit_speed_mps)
            self.circle_left |= on & (np.abs(self.err[:, k.E_EY]) > self.scenario.lateral_tolerance_m)
            self.circle_peak_a_y = np.where(on, np.maximum(self.circle_peak_a_y, a_y), self.circle_peak_a_y)
            steady = on & ~self.circle_left
            self.circle_steady_a_y = np.where(steady, np.maximum(self.circle_steady_a_y, a_y), self.circle_steady_a_y)

    def _check_gates(self) -> None:
        """Mark the cars whose body left a cone gate this step (body corners projected on the path, like
        ``tracks.gate_violations`` on a whole trajectory); only cars near the gates are checked (compiled)."""
        from vtrack_gym.tracks.kernels import body_outside_gates

        k = _kernels()
        st = self.plant.state
        s_car = self.err[:, k.E_S]
        for track in self._gated:
            path, gates, lo, hi = self._gate_data[track]
            sel = np.flatnonzero((self.veh_track == track) & (s_car >= lo) & (s_car <= hi) & ~self.gate_hit)
            if sel.size == 0:
                continue
            hit = np.zeros((sel.size, gates.shape[0]), dtype=np.bool_)
            body_outside_gates(path.table, path.ds_m, path.length_m, path.closed, gates, st[sel, L.S_X],
                               st[sel, L.S_Y], st[sel, L.S_PSI], s_car[sel], self._corner_lon, self._corner_lat, hit,
                               self._gate_row)
            self.gate_hit[sel] |= hit.any(axis=1)

    def success(self) -> np.ndarray:
        """Each car's verdict if its episode ended now (bool (n,)): the course completed (a lap of a closed course /
        the end of an open one, within the road) and, under the ``gates`` criterion, no cone gate left; under
        ``circle``: never outside the lateral band and the ramp run to the grip-limit speed (or the course
        completed), or left the band only at the car's own limit: the peak |a_y| in the band at least
        ``circle_limit_share`` of the episode's peak |a_y|, which is at least ``CIRCLE_MIN_PEAK_G`` mu g."""
        k = _kernels()
        done = self.term == k.T_COMPLETED
        circle = self._by_circle[self.veh_track]
        at_limit = ((self.circle_steady_a_y >= self.scenario.circle_limit_share * self.circle_peak_a_y)
                    & (self.circle_peak_a_y >= self.circle_min_peak_a_y))
        ok_circle = np.where(self.circle_left, at_limit, self.circle_reached | done)
        return np.where(circle, ok_circle, done & ~(self._by_gates[self.veh_track] & self.gate_hit))

    def _delayed(self, actions: np.ndarray) -> np.ndarray:
        """Commands delayed by ``delay_steps`` control periods (FIFO per car; zero before the first)."""
        buf = self.delay_buffer
        buf[:, 1:] = buf[:, :-1].copy()
        buf[:, 0] = actions
        return buf[np.arange(self.n), self.delay_steps]

    def _add_noise(self, quiet: np.ndarray | None = None) -> None:
        """Add each noisy car's sensor noise (drawn from its generator) to its observation, clipped to the box.

        ``quiet`` (bool (n,)) marks cars whose step is discarded (the vector env's autoreset step): they draw
        nothing, so their generator stays where a single env's would be."""
        idx = self._noisy
        lo, hi = self._noisy_low, self._noisy_high
        cars = self.noise_scale != 0.0
        if quiet is not None:
            cars &= ~quiet
        for i in np.flatnonzero(cars):
            noisy = self.obs[i, idx] + (self.noise_scale[i] * self._noise_std
                                        * self.rngs[i].standard_normal(idx.size)).astype(np.float32)
            self.obs[i, idx] = np.minimum(np.maximum(noisy, lo), hi)

    def reward_terms(self) -> dict[str, np.ndarray]:
        """The reward's terms of the last step for every car (see ``RewardConfig``; 0 right after a reset)."""
        return {name: self.terms[:, k].copy() for k, name in enumerate(REWARD_TERMS)}

    # ------------------------------------------------------------------ signals
    def time_s(self) -> np.ndarray:
        """Time since each car's reset [s] (float64, (n,))."""
        return self.steps * self.config.control_period_s

    def signals(self) -> dict[str, np.ndarray]:
        """Every scalar signal (``envs.schema.SCALAR_SIGNALS``, (n,) float64 each), the reward terms and the
        arrays ``fz_n`` (n, 4) and ``acc_substeps_mps2`` (n, n_sub, 3), for all cars (fresh arrays)."""
        columns = self.sig.T.copy()  # one copy, then contiguous rows
        out: dict[str, np.ndarray] = {"time_s": self.time_s()}
        out.update(zip(SIGNAL_ROW, columns, strict=True))
        out["fz_n"] = self.outputs[:, -1, L.O_FZFL:L.O_FZRR + 1].copy()             # FL, FR, RL, RR
        out["acc_substeps_mps2"] = self.outputs[:, :, L.O_AX:L.O_AZ + 1].copy()     # at the physics rate
        return out

