"""Soak test (not a CI test): millions of vehicle-steps of random and scripted policies on the native vector env.

    python benchmarks/soak.py                      # 10M vehicle-steps (default), N = 256 cars
    python benchmarks/soak.py --steps 2000000 --num-envs 256 --threads 1
    python benchmarks/soak.py --replay '{"policy": "random", ...}'   # re-run one reported failure on a single env

Every ``--segment`` control steps the next policy takes over (``random`` and the ``make_policy`` baselines in turn)
and the cars are re-randomised in ``--groups`` groups, each group with its own reset options (friction 0.3-1.2,
mass x0.7-1.5, target speed 5-40 m/s, sensor noise 0-2, actuator delay 0-80 ms). Finished cars are reset at once
(partial reset with the same group options, so no autoreset with default options). With ``--full-ranges`` every
reset option of ``ResetOptions.RANGES`` is drawn over its whole declared range instead (each edge a quarter of the
draws). After every step it checks:

* ``nonfinite``: NaN/inf in observations, rewards or any ``info`` array
* ``obs_out_of_box``: an observation outside ``observation_space``
* ``speed_jump``: |delta v_x| > 1.5 m/s in one 10 ms control step (true speed, not the noisy observation)
* ``roll``: |roll| > 0.3 rad
* ``termination``: a termination name outside completed/off_road/spin_out/wheel_lift (e.g. ``invalid_state``)
* ``wheel_loads_first_step``: for a sample of freshly reset cars, the first step is taken with zero steering and
  the four F_z must sum to m (g cos(atan(grade)) + a_z,road) within 1 % (m includes mass_scale)
* ``wheel_loads_at_rest``: per segment, LateralTracking-v0 cars from standstill with random mass_scale: after one
  zero-steer step sum F_z = m (g cos(atan(grade)) + a_z,road) within 0.1 %
* ``reset_wheel_loads``: the reset info's F_z must sum to m g within 5 % (the static loads; see
  tests/test_fuzz_env.py::test_reset_info_reports_static_wheel_loads)
* ``exception``: anything raised by the env or a policy

Each failure is printed once per check kind (up to ``--max-reports``) as a JSON reproducer for ``--replay``: the
car's seed, options, policy, episode number (within its seeded stream) and step. Cars are independent and the
``random`` policy is a hash of (seed, car seed, step), so a single env seeded the same way reproduces a car.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from typing import Any

import gymnasium as gym
import numpy as np

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.baselines.registry import make_policy
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import GRAVITY_MPS2 as G

ENV_ID = "LateralTrackingRandom-v0"
DOCUMENTED_TERMINATIONS = {"", "completed", "off_road", "spin_out", "wheel_lift"}
SPEED_JUMP_MPS = 1.5
ROLL_LIMIT_RAD = 0.3
SCRIPTED = ("smc", "mpc", "lqr", "stanley", "pure_pursuit")


def random_options(rng: np.random.Generator) -> dict[str, float]:
    """One group's reset options (ranges of the soak brief)."""
    return {
        "friction_mu": round(float(rng.uniform(0.3, 1.2)), 4),
        "mass_scale": round(float(rng.uniform(0.7, 1.5)), 4),
        "target_speed_mps": round(float(rng.uniform(5.0, 40.0)), 3),
        "sensor_noise": round(float(rng.choice([0.0, 0.5, 1.0, 2.0])), 3),
        "actuator_delay_s": round(float(rng.choice([0.0, 0.01, 0.03, 0.05, 0.08])), 3),
        "initial_lateral_offset_m": round(float(rng.uniform(-0.5, 0.5)), 3),
    }


def full_range_options(rng: np.random.Generator, control_period_s: float) -> dict[str, float]:
    """One group's reset options drawn over every declared range of ``ResetOptions.RANGES`` (``--full-ranges``):
    each option at its low edge, its high edge (a quarter of the draws each) or uniform inside; the actuator delay
    a whole number of control periods."""
    from vtrack_gym.envs.config import ResetOptions

    options = {}
    for name, (lo, hi) in ResetOptions.RANGES.items():
        pick = rng.uniform()
        value = lo if pick < 0.25 else hi if pick < 0.5 else float(rng.uniform(lo, hi))
        if name == "actuator_delay_s":
            value = round(value / control_period_s) * control_period_s
        options[name] = float(value)
    return options


def hash_actions(run_seed: int, car_seeds: np.ndarray, steps: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    """The ``random`` policy: a deterministic hash of (run seed, car seed, step in episode) -> [-amp, amp]."""
    x = np.sin(12.9898 * steps + 78.233 * (car_seeds % 100003) + 0.618 * (run_seed % 1009)) * 43758.5453
    return (2.0 * (x - np.floor(x)) - 1.0) * amplitude


class Soak:
    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.n = args.num_envs
        self.envs = gym.make_vec(ENV_ID, num_envs=self.n, vectorization_mode="vector_entry_point")
        self.sim = self.envs.unwrapped.sim
        self.space = self.envs.single_observation_space
        self.mass0 = self.envs.unwrapped.config.vehicle.chassis.mass_kg
        self.rest_env = gym.make_vec("LateralTracking-v0", num_envs=4, vectorization_mode="vector_entry_point")
        self.counts: Counter[str] = Counter()
        self.reports: dict[str, list[dict[str, Any]]] = {}
        self.steps_done = 0
        self.episodes = 0
        self.terminations: Counter[str] = Counter()
        self.checked_first_steps = 0
        self.policies = [p for p in args.policies.split(",") if p]

    # ------------------------------------------------------------------ bookkeeping
    def fail(self, kind: str, car: int | None, detail: str, **extra: Any) -> None:
        self.counts[kind] += 1
        reports = self.reports.setdefault(kind, [])
        if len(reports) >= self.args.max_reports:
            return
        rep: dict[str, Any] = {"check": kind, "detail": detail, **extra}
        if car is not None:
            rep.update({"policy": self.policy_name, "run_seed": self.run_seed, "car": int(car),
                        "seed": int(self.car_seed[car]), "options": self.car_opts[car],
                        "amplitude": float(self.amp[car]), "episode": int(self.car_episode[car]),
                        "step": int(self.ep_step[car])})
        reports.append(rep)
        tqdm_write(f"FAILURE {json.dumps(rep)}")

    # ------------------------------------------------------------------ segments
    def start_segment(self, seg: int) -> None:
        args = self.args
        self.policy_name = self.policies[seg % len(self.policies)]
        self.run_seed = args.seed * 1_000_003 + seg
        rng = np.random.default_rng(self.run_seed)
        self.policy = None if self.policy_name == "random" else make_policy(self.policy_name, self.envs)
        self.state = None
        self.group = np.arange(self.n) % args.groups
        period = self.envs.unwrapped.config.control_period_s
        self.group_opts = [full_range_options(rng, period) if args.full_ranges else random_options(rng)
                           for _ in range(args.groups)]
        self.car_opts = [self.group_opts[g] for g in self.group]
        self.car_seed = self.run_seed * 10_000 + np.arange(self.n)
        self.car_episode = np.zeros(self.n, dtype=np.int64)
        self.ep_step = np.zeros(self.n, dtype=np.int64)
        self.amp = rng.choice([1.0, 0.3, 0.05], size=self.n)
        self.mass = np.array([self.mass0 * o["mass_scale"] for o in self.car_opts])
        self.obs = np.zeros((self.n, self.space.shape[0]), dtype=np.float32)
        self.episode_start = np.zeros(self.n, dtype=bool)
        self.just_reset = np.zeros(self.n, dtype=bool)
        seeds = [int(s) for s in self.car_seed]
        for g in range(args.groups):
            self.reset_cars(self.group == g, seeds=seeds)
        self.check_at_rest(rng)

    def reset_cars(self, mask: np.ndarray, seeds: list[int] | None = None) -> None:
        """Partial reset of ``mask`` cars group by group with their group's options (seeded on a segment start)."""
        for g in np.unique(self.group[mask]):
            m = mask & (self.group == g)
            obs, info = self.envs.reset(seed=seeds, options={**self.group_opts[g], "reset_mask": m})
            self.obs[m] = obs[m]
            idx = np.flatnonzero(m)
            fz = info["fz_n"][idx].sum(axis=1)
            bad = np.abs(fz - self.mass[idx] * G) > 0.05 * self.mass[idx] * G
            for i in idx[bad][:1]:
                self.ep_step[i] = 0
                self.fail("reset_wheel_loads", int(i), f"reset info sum F_z = {fz[idx == i][0]:.1f} N, "
                          f"m g = {self.mass[i] * G:.1f} N")
            self.counts["reset_wheel_loads"] += int(bad.sum()) - min(int(bad.sum()), 1)
        self.ep_step[mask] = 0
        self.episode_start |= mask
        self.just_reset |= mask

    def check_at_rest(self, rng: np.random.Generator) -> None:
        """LateralTracking-v0 starts at rest: one zero-steer step, wheel loads = weight (per mass scale)."""
        env = self.rest_env
        scales = rng.uniform(0.7, 1.5, size=env.num_envs)
        for i, s in enumerate(scales):
            mask = np.zeros(env.num_envs, dtype=bool)
            mask[i] = True
            env.reset(seed=int(rng.integers(2**31)), options={"mass_scale": float(s),
                                                               "friction_mu": float(rng.uniform(0.3, 1.2)),
                                                               "reset_mask": mask})
        road = env.unwrapped.sim.road.copy()
        _, _, _, _, info = env.step(np.zeros((env.num_envs, 1)))
        mass = self.mass0 * scales
        expected = mass * (G * np.cos(np.arctan(road[:, 0])) + road[:, 1])
        fz = info["fz_n"].sum(axis=1)
        for i in np.flatnonzero(np.abs(fz - expected) > 1e-3 * expected):
            self.counts["wheel_loads_at_rest"] += 1
            self.reports.setdefault("wheel_loads_at_rest", []).append(
                {"check": "wheel_loads_at_rest", "mass_scale": float(scales[i]), "sum_fz": float(fz[i]),
                 "expected": float(expected[i])})

    # ------------------------------------------------------------------ one step
    def step(self) -> None:
        n = self.n
        if self.policy is None:
            action = hash_actions(self.run_seed, self.car_seed, self.ep_step, self.amp)[:, None]
        else:
            action, self.state = self.policy.predict(self.obs, state=self.state, episode_start=self.episode_start)
            action = np.asarray(action, dtype=np.float64).reshape(n, 1)
        sample = self.just_reset & (self.car_seed % self.args.wheel_load_sample == 0)
        action[sample] = 0.0
        road = self.sim.road.copy()
        v_prev = self.sim.plant.state[:, L.S_VX].copy()
        self.episode_start = np.zeros(n, dtype=bool)
        obs, reward, term, trunc, info = self.envs.step(action)
        self.ep_step += 1
        self.steps_done += n
        self.obs = obs
        fresh = self.just_reset
        self.just_reset = np.zeros(n, dtype=bool)

        finite = np.isfinite(obs).all(axis=1) & np.isfinite(reward)
        for key, value in info.items():
            if key.startswith("_") or key == "termination":
                continue
            finite &= np.isfinite(value).reshape(n, -1).all(axis=1)
        for i in np.flatnonzero(~finite):
            self.fail("nonfinite", i, "NaN/inf in observation, reward or info")
        inside = ((obs >= self.space.low) & (obs <= self.space.high)).all(axis=1)
        for i in np.flatnonzero(~inside & finite):
            j = int(np.flatnonzero((obs[i] < self.space.low) | (obs[i] > self.space.high))[0])
            self.fail("obs_out_of_box", i, f"obs[{j}] = {obs[i, j]} outside the box")
        dv = np.abs(info["v_mps"] - v_prev)
        for i in np.flatnonzero(dv > SPEED_JUMP_MPS):
            self.fail("speed_jump", i, f"|dv_x| = {dv[i]:.3f} m/s in one step ({v_prev[i]:.2f} -> "
                      f"{info['v_mps'][i]:.2f})")
        for i in np.flatnonzero(np.abs(info["roll_rad"]) > ROLL_LIMIT_RAD):
            self.fail("roll", i, f"|roll| = {abs(info['roll_rad'][i]):.3f} rad")
        names = info["termination"]
        for i in np.flatnonzero(term):
            if names[i] not in DOCUMENTED_TERMINATIONS:
                self.fail("termination", i, f"termination {names[i]!r}")
        checked = sample & fresh
        if checked.any():
            idx = np.flatnonzero(checked)
            expected = self.mass[idx] * (G * np.cos(np.arctan(road[idx, 0])) + road[idx, 1])
            fz = info["fz_n"][idx].sum(axis=1)
            self.checked_first_steps += idx.size
            for k in np.flatnonzero(np.abs(fz - expected) > 0.01 * expected):
                self.fail("wheel_loads_first_step", idx[k], f"sum F_z = {fz[k]:.1f} N, expected {expected[k]:.1f}")

        done = term | trunc
        if done.any():
            self.terminations.update(str(names[i]) if term[i] else "time_limit" for i in np.flatnonzero(done))
            self.episodes += int(done.sum())
            self.car_episode[done] += 1
            self.reset_cars(done)


def tqdm_write(text: str) -> None:
    from tqdm.auto import tqdm

    tqdm.write(text, file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    from tqdm.auto import tqdm

    t0 = time.perf_counter()
    soak = Soak(args)
    seg = 0
    with tqdm(total=args.steps, unit="veh-step", unit_scale=True, desc="soak", mininterval=1.0) as bar:
        while soak.steps_done < args.steps:
            try:
                soak.start_segment(seg)
                for _ in range(args.segment):
                    if soak.steps_done >= args.steps:
                        break
                    before = soak.steps_done
                    soak.step()
                    bar.update(soak.steps_done - before)
                    bar.set_postfix_str(f"{soak.policy_name} fails={sum(soak.counts.values())}", refresh=False)
            except Exception as exc:
                soak.fail("exception", None, f"{type(exc).__name__}: {exc}", policy=soak.policy_name,
                          run_seed=soak.run_seed, segment=seg)
            seg += 1
    wall = time.perf_counter() - t0
    summary = {
        "vehicle_steps": soak.steps_done,
        "wall_s": round(wall, 1),
        "vehicle_steps_per_s": round(soak.steps_done / wall),
        "num_envs": args.num_envs,
        "segments": seg,
        "episodes_finished": soak.episodes,
        "terminations": dict(soak.terminations),
        "first_steps_wheel_load_checked": soak.checked_first_steps,
        "failures": dict(soak.counts),
    }
    print(json.dumps(summary, indent=2))
    if soak.reports:
        print("reproducers (python benchmarks/soak.py --replay '<line>'):")
        for reports in soak.reports.values():
            for rep in reports:
                print(json.dumps(rep))
    hard = {k: v for k, v in soak.counts.items() if v}
    print(f"\nsoak: {soak.steps_done:,} vehicle-steps in {wall:.0f} s ({soak.steps_done / wall:,.0f}/s), "
          f"{soak.episodes:,} episodes; failures: {hard or 'none'}")
    return 1 if hard else 0


def replay(spec: dict[str, Any]) -> int:
    """Re-run one reported car on a single env: same seed, options, policy and (for random) hash actions."""
    env = gym.make(ENV_ID)
    policy = None if spec["policy"] == "random" else make_policy(spec["policy"], env)
    obs, info = env.reset(seed=spec["seed"], options=spec["options"])
    if spec["episode"] == 0 and spec["step"] == 0:
        print(json.dumps({"step": 0, "reset_fz_n": info["fz_n"].tolist(), "min_fz_n": info["min_fz_n"]}))
        return 0
    for episode in range(spec["episode"] + 1):
        state, start, step = None, np.ones(1, dtype=bool), 0
        while True:
            if policy is None:
                a = hash_actions(spec["run_seed"], np.array([spec["seed"]]), np.array([step]),
                                 np.array([spec["amplitude"]]))
            else:
                a, state = policy.predict(obs, state=state, episode_start=start)
            if step == 0 and spec["seed"] % spec.get("wheel_load_sample", 8) == 0:
                a = np.zeros(1)
            start = np.zeros(1, dtype=bool)
            v_prev = info["v_mps"]
            obs, reward, term, trunc, info = env.step(np.asarray(a, dtype=np.float64).reshape(1))
            step += 1
            if episode == spec["episode"] and step == spec["step"]:
                print(json.dumps({"step": step, "obs_finite": bool(np.isfinite(obs).all()), "reward": reward,
                                  "v_prev": v_prev, "v": info["v_mps"], "roll": info["roll_rad"],
                                  "fz_n": info["fz_n"].tolist(), "termination": info["termination"]}, indent=2))
                return 0
            if term or trunc:
                obs, info = env.reset(options=spec["options"])
                break
    print("the reported step was not reached", file=sys.stderr)
    return 1


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=10_000_000, help="vehicle-steps to run (default 10M)")
    p.add_argument("--num-envs", type=int, default=256, help="cars in the vector env (default 256)")
    p.add_argument("--segment", type=int, default=6000, help="control steps per policy segment (default 6000 = 60 s)")
    p.add_argument("--groups", type=int, default=8, help="option groups per segment (default 8)")
    p.add_argument("--policies", default="random," + ",".join(SCRIPTED),
                   help="comma-separated: random and make_policy names (default: random + 5 baselines)")
    p.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    p.add_argument("--threads", type=int, default=1, help="numba threads for the parallel kernel (default 1)")
    p.add_argument("--wheel-load-sample", type=int, default=8,
                   help="check the first-step wheel loads of every k-th car seed (default 8)")
    p.add_argument("--max-reports", type=int, default=5, help="reproducers printed per check kind (default 5)")
    p.add_argument("--replay", default=None, help="JSON reproducer printed by a previous run")
    p.add_argument("--full-ranges", action="store_true",
                   help="draw every reset option over its whole declared range (edges included) instead of the "
                        "default ranges above")
    args = p.parse_args(argv)
    if args.replay:
        return replay(json.loads(args.replay))
    if args.steps < 1 or args.num_envs < 1 or args.segment < 1 or args.groups < 1:
        p.error("--steps, --num-envs, --segment and --groups must be >= 1")
    import numba

    numba.set_num_threads(max(1, min(args.threads, numba.config.NUMBA_NUM_THREADS)))
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
