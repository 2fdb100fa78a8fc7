"""``BatchSim``: N cars on their tracks behind the PD-FLC speed loop, stepped by one compiled call.

The single env, the Gymnasium vector env and the SB3 adapter are thin front-ends over this class, so they
share every number. ``BatchSim`` holds the state and calls the kernels; the scenario's parts do the rest in their
own modules: the paths and their packed tables (``track_bank.TrackBank``), the per-episode draws
(``randomisation``), sensor noise and actuator delay (``disturbances``) and the success verdict
(``criteria``). Each car has its own random generator (seeded like Gymnasium seeds sub-envs), so car ``i`` of a
batch seeded with ``seed`` reproduces a single env seeded with ``seed + i`` bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from vtrack_gym.envs.config import EnvConfig, ResetOptions
from vtrack_gym.envs.criteria import CarsView
from vtrack_gym.envs.disturbances import ActuatorDelay, SensorNoise
from vtrack_gym.envs.latency import CommandSchedule
from vtrack_gym.envs.observation import NOISY_INDICES
from vtrack_gym.envs.pdflc import PDFLCConfig, speed_loop_throttle_authority
from vtrack_gym.envs.scenarios import Scenario
from vtrack_gym.envs.schema import REWARD_TERMS, SIGNAL_ROW
from vtrack_gym.envs.speed import bind_to_car, check_tables_for_powertrain, speed_part
from vtrack_gym.envs.track_bank import TrackBank
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import VehicleParams
from vtrack_gym.vehicle.plant import Plant
from vtrack_gym.vehicle.threads import use_parallel

TERMINATION_NAMES: tuple[str, ...] = ("", "completed", "off_road", "spin_out", "wheel_lift", "invalid_state")
"""``info["termination"]`` for each kernel termination code ("" = still running)."""


def _kernels():
    from vtrack_gym.envs import kernels

    return kernels


def scenario_tracks(scenario: Scenario, vehicle: VehicleParams) -> tuple:
    """The reference paths a scenario's cars drive on: its reference-line part applied to its track source for the
    driven car (the one place the env reads ``Scenario.reference``)."""
    return scenario.reference.paths(scenario.track, vehicle)


def throttle_authority(config: EnvConfig) -> float:
    """The throttle fraction a profile bound to this env's car may count on: the PD-FLC's steady authority in the
    ``steer`` mode (the speed loop drives the pedals), 1.0 (full throttle) in the longitudinal control modes (the
    agent drives them)."""
    return speed_loop_throttle_authority(config.speed_controller) if config.control == "steer" else 1.0


def car_speed(scenario: Scenario, config: EnvConfig) -> Any:
    """The scenario's speed part for the env's car and who drives the pedals (``speed.bind_to_car``): a profile
    with a ``throttle_authority`` bound to ``config.vehicle``'s powertrain at ``throttle_authority(config)``, from
    rest when the scenario starts its cars at rest."""
    return bind_to_car(scenario.speed, config.vehicle, throttle_authority(config),
                       at_rest=not scenario.start.at_speed)


class BatchSim:
    """N independent cars (one per sub-env) on the scenario's track(s)."""

    def __init__(self, scenario: Scenario, config: EnvConfig, n: int) -> None:
        k = _kernels()
        self.config = config
        self.n = n
        # a speed profile's lateral limit within this car's own (ValueError above it, a warning near it); an entry
        # speed within (0, 200] km/h (ValueError naming the car)
        speed = car_speed(scenario, config)
        speed_part(speed).check_for_car(config.vehicle)
        self.tracks = TrackBank(scenario_tracks(scenario, config.vehicle), speed, config.vehicle)
        check_tables_for_powertrain(speed, self.tracks, config.vehicle, throttle_authority(config))
        self.paths = self.tracks.paths
        if scenario.time_limit_s is None:
            scenario = replace(scenario, time_limit_s=self.tracks.time_limit_s())
        self.scenario = scenario
        self.plant = Plant(config.vehicle, n=n, model=config.model, physics_dt_s=config.physics_dt_s,
                           numerics=config.numerics)
        self.n_sub = config.n_substeps
        self.layout = config.layout
        self.inputs = np.zeros((n, L.N_INPUT))
        self.road = np.zeros((n, L.N_ROAD))
        self.outputs = np.zeros((n, self.n_sub, L.N_OUTPUT))
        self.car = np.zeros((n, k.N_CAR))  # per-car scalars; the attributes below are column views
        self.progress = self.car[:, k.CAR_PROGRESS]
        self.v_ref = self.car[:, k.CAR_V_REF]
        self.prev_action = self.car[:, k.CAR_PREV_ACTION]
        self.reward = self.car[:, k.CAR_REWARD]
        self.min_fz = self.car[:, k.CAR_MIN_FZ]
        self.follow = self.car[:, k.CAR_FOLLOW]
        self.demand = self.car[:, k.CAR_DEMAND]
        """Each car's longitudinal demand in [-1, 1] (the longitudinal control modes; ``envs.control``) (view)."""
        self.obs = np.zeros((n, self.layout.size), dtype=np.float32)
        self.err = np.zeros((n, k.ERR_COLS))
        self.station_m = self.err[:, k.E_S]
        """Station of each car's projection on its path [m] (view)."""
        self.lateral_error_m = self.err[:, k.E_EY]
        """Each car's lateral error e_y [m] (view)."""
        self.term = np.zeros(n, dtype=np.int64)
        self.actions = np.zeros(n)
        self.sig = np.zeros((n, k.N_SIG))  # info signals and reward terms (envs.schema.SIGNAL_ROW)
        self.terms = self.sig[:, k.SIG_REWARD:k.SIG_REWARD + k.N_TERMS]
        self.veh_track = np.zeros(n, dtype=np.int64)
        self.steps = np.zeros(n, dtype=np.int64)
        self.max_steps = round(scenario.time_limit_s / config.control_period_s)
        self.rngs: list[np.random.Generator] = [np.random.default_rng() for _ in range(n)]
        self.last_options: list[ResetOptions] = [ResetOptions() for _ in range(n)]
        low, high = self.layout.bounds()
        self.noise = SensorNoise(n, config.noise_std, NOISY_INDICES, low, high)
        self.delay = ActuatorDelay(n, config.control_period_s)
        self.latency = CommandSchedule(n, self.n_sub, config.physics_dt_s, self.car[:, k.CAR_SCHEDULED])
        """Compute latency: each car's commands take effect after their decision's delay (``envs.latency``)."""
        self.max_steer_rad = config.vehicle.steering.max_road_wheel_angle_rad  # road-wheel angle of action 1 [rad]
        self.control = config.control
        """The control mode (``envs.control``): what ``step``'s actions drive."""
        self.steer_command = np.zeros(n)
        """``steer_rate_accel``: each car's integrated steering command (fraction of the road-wheel limit)."""
        self.rate_step = (config.vehicle.steering.max_road_wheel_rate_radps * config.control_period_s
                          / self.max_steer_rad)
        """Command change of a full-rate action over one control period (``steer_rate_accel``)."""
        self.arrays = self._bundle(k, scenario, config)
        self._step_kernel = k.step_parallel if use_parallel(n) else k.step_serial
        if config.numerics == "fast":  # the SIMD plant (vehicle.numerics); the same per-car env code around it
            from vtrack_gym.envs import fast_step

            self._step_kernel = fast_step.step_parallel if use_parallel(n) else fast_step.step_serial
        self._step_compiled = None  # the kernel's compiled entry point for ``self.arrays`` (see _run_kernel)
        self._observe = k.observe_indices
        self.criterion = scenario.success.resolve(self.paths)
        self.verdicts = self.criterion.start(self.paths, config.vehicle, n)
        """The criterion's per-car state (its own NamedTuple of arrays)."""
        self._cars = self._cars_view(k)
        self._extras = self.criterion.per_step
        self.finish_speed = self.tracks.finish_speeds()
        """Per path: the profile's speed at the finish line of a closed path with a standing start, else NaN."""
        self._hold_finish = bool(np.any(np.isfinite(self.finish_speed)))
        self._codes = (k.T_COMPLETED, k.SIG_V_REF)
        """Whether a step has more to do than the kernel: a per-step criterion, a delay or noise (see reset_car)."""

    def _bundle(self, k, scenario: Scenario, config: EnvConfig):
        """The kernels' ``SimArrays`` of this batch (its arrays are modified in place, never rebound)."""
        from vtrack_gym.envs.pdflc import control_surface
        from vtrack_gym.envs.pdflc_kernel import pdflc_gains

        pd = config.speed_controller
        # PD-FLC gains per car (GA tuning evaluates one individual per car); the surface is shared.
        self.pd_gains = np.tile(pdflc_gains(pd, config.control_period_s), (self.n, 1))
        self.pd_mem = np.zeros((self.n, 3))
        cfg = k.pack_cfg(k.StepConstants.of(scenario, config), self.layout, config.reward)
        return k.SimArrays(
            states=self.plant.state, inputs=self.inputs, road=self.road, params=self.plant.param_rows,
            models=self.plant.models, outputs=self.outputs, work=self.plant.workspace, tables=self.tracks.tables,
            tmeta=self.tracks.meta, veh_track=self.veh_track, car=self.car, cfg=cfg, obs=self.obs, err=self.err,
            term=self.term, actions=self.actions, sig=self.sig,
            pd_mem=self.pd_mem, pd_gains=self.pd_gains,
            pd_surface=np.ascontiguousarray(control_surface(pd.method, pd.surface_resolution)),
            cmds=self.latency.cmds, scratch=np.zeros((self.n, k.N_SCRATCH)))

    def _cars_view(self, k) -> CarsView:
        """The named views a success criterion reads (live: the arrays are updated in place)."""
        st = self.plant.state
        return CarsView(self.veh_track, self.steps, self.term, self.station_m, self.lateral_error_m, st[:, L.S_VX],
                        self.v_ref, self.sig[:, k.SIG_AY], st[:, L.S_X], st[:, L.S_Y], st[:, L.S_PSI],
                        k.T_COMPLETED, k.T_OFF_ROAD)

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
        """``options.actuator_delay_s`` in control periods (``ValueError`` unless a whole number of them)."""
        return self.delay.steps_of(options.actuator_delay_s)

    def reset_car(self, i: int, options: ResetOptions) -> None:
        """Put car ``i`` at the start of a (possibly new) track with the given scenario knobs."""
        self.delay_steps_of(options)  # refuse a bad delay before changing anything
        sc, rng = self.scenario, self.rngs[i]
        given = options
        options = sc.randomisation.draw(options, rng, self.config.control_period_s)
        track = int(rng.integers(len(self.tracks))) if len(self.tracks) > 1 else 0
        self.veh_track[i] = track
        v_ref, follow = self._reference_speed(track, options, rng)
        self.follow[i] = 1.0 if follow else 0.0
        v0 = sc.start.initial_speed_mps(v_ref, rng)
        self.v_ref[i] = v_ref
        self.car[i, _kernels().CAR_INV_VSET] = self._inverse_set_speed(track, v_ref, follow)
        params = self._car_params(options)
        self.plant.set_vehicle_params(i, params)
        self.criterion.reset_car(self.verdicts, i, params)
        x0, y0, psi0 = self.tracks.start_pose(track)
        off = options.initial_lateral_offset_m
        self.plant.reset(i, x=x0 - off * np.sin(psi0), y=y0 + off * np.cos(psi0),
                         psi=psi0 + options.initial_heading_error_rad, v_x=v0)
        self._reset_outputs(i, params)
        self.last_options[i] = given  # an autoreset draws the randomised knobs afresh
        self.inputs[i] = 0.0
        self.steps[i] = 0
        self.prev_action[i] = 0.0
        self.demand[i] = 0.0
        self.steer_command[i] = 0.0
        self.noise.set_scale(i, options.sensor_noise)
        self.delay.set_delay(i, options.actuator_delay_s)
        self.latency.reset_car(i)
        self._extras = self.criterion.per_step or self.noise.active or self.delay.active
        self.pd_mem[i] = (0.0, 0.0, 1.0)  # fresh: the first derivative of the speed error is 0
        self.term[i] = 0

    def _reference_speed(self, track: int, options: ResetOptions, rng: np.random.Generator) -> tuple[float, bool]:
        """The episode's reference speed at the start [m/s] and whether it follows the track's profile."""
        if options.target_speed_mps is not None:
            return options.target_speed_mps, False
        part = speed_part(self.scenario.speed)
        v = part.start_speed_mps(self.tracks.peak_curvature(track), self.tracks.speed_tables[track], rng)
        return v, bool(part.follows_profile)

    def _inverse_set_speed(self, track: int, v_ref: float, follow: bool) -> float:
        """1 / the held set speed [s/m] when the car holds a set speed its track's speed table does not (a reset
        option, a randomised set speed: the time error is then against s / v_set), else 0 (the table's time law)."""
        table = self.tracks.speed_tables[track].v_mps
        held = not follow and np.isinf(self.tracks.meta[track, _kernels().TM_RELEASE_S])
        return 1.0 / v_ref if held and not np.all(table == v_ref) else 0.0

    def _car_params(self, options: ResetOptions) -> VehicleParams:
        """The env's car with the episode's mass, friction and steering-rate knobs."""
        params: VehicleParams = self.config.vehicle
        if options.mass_scale != 1.0:
            params = params.with_mass_scale(options.mass_scale)
        if options.friction_mu is not None:
            params = params.with_friction(options.friction_mu)
        if options.steering_rate_scale != 1.0:
            params = params.with_steering_rate_scale(options.steering_rate_scale)
        return params

    def _reset_outputs(self, i: int, params: VehicleParams) -> None:
        """Reset-time outputs: at rest on flat ground (no accelerations, static wheel loads of these params)."""
        from vtrack_gym.vehicle.packing import static_wheel_loads_n

        fz_front, fz_rear = static_wheel_loads_n(params)
        self.outputs[i] = 0.0
        self.outputs[i, :, L.O_FZFL:L.O_FZFR + 1] = fz_front
        self.outputs[i, :, L.O_FZRL:L.O_FZRR + 1] = fz_rear
        self.min_fz[i] = min(fz_front, fz_rear)
        self.road[i] = 0.0

    def observe_after_reset(self, idx: np.ndarray) -> None:
        """Project freshly reset cars (global search) and fill their observation rows."""
        self._observe(idx.astype(np.int64), self.arrays)

    def __getstate__(self) -> dict:
        """Pickled without the kernel's compiled entry point (a numba closure; looked up again at the next step),
        with the column views kept views of their blocks (``_array_views``)."""
        from vtrack_gym._array_views import encode

        return encode({**self.__dict__, "_step_compiled": None})

    def __setstate__(self, state: dict) -> None:
        from vtrack_gym._array_views import decode

        self.__dict__.update(decode(state))

    # ------------------------------------------------------------------ step
    def step(self, actions: np.ndarray, quiet: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every car one control period. ``actions`` (n,) are finite, clipped to [-1, 1]; ``quiet`` (bool
        (n,)) marks cars whose step will be discarded (no sensor noise is drawn for them).

        In the longitudinal control modes ``actions`` is (n, 2): steering (or its rate) and the demand.

        Returns (reward (n,), terminated (n,), truncated (n,)); observations are in ``self.obs``.
        """
        if self.control != "steer":
            self.demand[:] = actions[:, 1]
            actions = self._steering(actions[:, 0])
        self.actions[:] = actions
        cmd = self.delay.delayed(self.actions) if self.delay.active else self.actions
        self.inputs[:, L.U_DELTA] = cmd * self.max_steer_rad
        self._run_kernel()
        if self._hold_finish:
            for i in np.flatnonzero(self.term == self._codes[0]):
                self._finish_reference(int(i))
        self.steps += 1
        if self.criterion.per_step:
            self.criterion.observe_step(self.verdicts, self._cars)
        terminated = self.term != 0
        truncated = (self.steps >= self.max_steps) & ~terminated
        if self.noise.active:
            self.noise.apply(self.obs, self.rngs, quiet)
        return self.reward.copy(), terminated, truncated

    def _steering(self, first: np.ndarray) -> np.ndarray:
        """The steering commands (fractions of the road-wheel limit) of the actions' first entries: as given, or in
        ``steer_rate_accel`` the integrated rates ``c + rate * rate_step`` clipped to [-1, 1]."""
        if self.control != "steer_rate_accel":
            return first
        np.clip(self.steer_command + first * self.rate_step, -1.0, 1.0, out=self.steer_command)
        return self.steer_command.copy()

    def step_one(self, action: float, latency_s: float | None = None,
                 demand: float | None = None) -> tuple[float, int, bool]:
        """Fast path for a single car (n = 1): returns (reward, termination code, truncated). ``latency_s`` [s]:
        the decision's compute, delaying its command (``envs.latency``; ``None``: latency off). ``demand``: the
        longitudinal demand of the longitudinal control modes (``action`` is then the steering or its rate)."""
        if demand is not None:
            self.demand[0] = demand
            if self.control == "steer_rate_accel":
                action = float(self._steering(np.array([action]))[0])
        self.actions[0] = action
        extras = self._extras
        cmd = self.delay.delayed(self.actions)[0] if extras and self.delay.active else action
        if latency_s is None:
            self.inputs[0, L.U_DELTA] = cmd * self.max_steer_rad
        else:
            self.inputs[0, L.U_DELTA] = self.latency.schedule(0, int(self.steps[0]), cmd * self.max_steer_rad,
                                                              latency_s)
        self._run_kernel()
        steps = int(self.steps[0]) + 1
        self.steps[0] = steps
        if extras and self.criterion.per_step:
            self.criterion.observe_step(self.verdicts, self._cars)
        code = int(self.term[0])
        if self._hold_finish and code == self._codes[0]:
            self._finish_reference(0)
        if extras and self.noise.active:
            self.noise.apply(self.obs, self.rngs)
        return float(self.reward[0]), code, code == 0 and steps >= self.max_steps

    def _finish_reference(self, i: int) -> None:
        """Car ``i`` has completed its lap on a closed path whose profile starts standing: its station reads the
        next lap's start, so its reference speed (and the info signal) is the profile's finish speed instead."""
        v = self.finish_speed[int(self.veh_track[i])]
        if np.isfinite(v):
            self.v_ref[i] = v
            self.sig[i, self._codes[1]] = v

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

    def success(self) -> np.ndarray:
        """Each car's verdict if its episode ended now (bool (n,)), by the scenario's success criterion."""
        return self.criterion.verdict(self.verdicts, self._cars)

    def safety(self, i: int | None = None) -> tuple[Any, Any]:
        """``info["cost"]`` and ``info["edge_margin_m"]`` [m] of the last step (``envs.schema.SAFETY_SIGNALS``) of
        every car ((n,) float64 each), or floats of car ``i``; 0.0 and inf right after a reset."""
        if i is not None:
            return (0.0, math.inf) if self.steps[i] == 0 else self.criterion.safety_of(self.verdicts, self._cars, i)
        cost, margin = self.criterion.safety(self.verdicts, self._cars)
        fresh = self.steps == 0
        cost = np.where(fresh, 0.0, cost)
        margin = np.where(fresh, np.inf, margin)
        return cost, margin

    def success_metrics(self, i: int) -> dict[str, float]:
        """The success criterion's leaderboard figures of car ``i``'s episode so far (e.g. ``cones_hit``)."""
        return self.criterion.metrics(self.verdicts, i, int(self.veh_track[i]))

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
