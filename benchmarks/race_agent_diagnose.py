"""What a race agent does when its race fails: the last second before a spin-out or leaving the road.

    python benchmarks/race_agent_diagnose.py AGENT [--circuits rc-24,rc-25,...] [--laps 2] [--seed 0]

``AGENT``: a policy name or an agent file. For each circuit (default the race split's validation circuits; never the
held-out ones unless named) one race from a standing start; for a failed one, the state over the last second
before the end, sampled every 0.1 s: speed v_x [m/s] against the reference speed at the car's station
(``target_speed``: the car's full-grip limit along the centre line) and 1 s ahead (``v_ref_preview_5``), the
centre-line curvature [1/m], the steering command and the longitudinal demand (actions, [-1, 1]), the yaw rate
against v_x * kappa [rad/s], the sideslip v_y / v_x [rad], e_y [m], and the number of sign changes of the steering
command's step-to-step change over that second (steering oscillation). Also the peak of v_x / target_speed over the
race (above 1: faster than the car's limit for the centre line at that point).
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import vtrack_gym
from vtrack_gym.tracks.race_circuits import RACE_SPLIT, race_circuit

COLUMNS = ("v_x", "target_speed", "v_ref_preview_5", "curvature", "yaw_rate", "v_y", "e_y")


def race(policy_name: str, circuit: str, laps: int, seed: int) -> tuple[dict, np.ndarray, np.ndarray, list[str], float]:
    """One race: (its last info, every observation (T, n), every action (T, 2), the observation names, the control
    period [s])."""
    env = gym.make("vtrack/Race-v0", track=race_circuit(circuit), laps=laps)
    policy = vtrack_gym.make_policy(policy_name, env)
    obs, info = env.reset(seed=seed)
    seen, acts = [], []
    while True:
        action = np.asarray(policy.predict(obs)[0], dtype=np.float32)
        seen.append(obs)
        acts.append(action)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            base = env.unwrapped
            return (info, np.asarray(seen), np.asarray(acts), list(base.observation_layout.names),
                    float(base.control_period_s))


def last_second(obs: np.ndarray, acts: np.ndarray, names: list[str], period_s: float) -> None:
    """Print the state every 0.1 s over the last second of a race."""
    idx = {n: names.index(n) for n in COLUMNS}
    n = int(round(1.0 / period_s))
    print("    t_to_end_s  v_x  v_ref  v_ref_1s  kappa  steer  demand  yaw_rate  v_x*kappa  sideslip  e_y")
    for k in range(max(0, len(obs) - n), len(obs), max(1, n // 10)):
        o, a = obs[k], acts[k]
        v = float(o[idx["v_x"]])
        print(f"    {(len(obs) - k) * period_s:9.2f} {v:5.1f} {o[idx['target_speed']]:6.1f} "
              f"{o[idx['v_ref_preview_5']]:8.1f} {o[idx['curvature']]:7.4f} {a[0]:6.2f} {a[1]:7.2f} "
              f"{o[idx['yaw_rate']]:8.3f} {v * o[idx['curvature']]:10.3f} {o[idx['v_y']] / max(v, 1.0):9.3f} "
              f"{o[idx['e_y']]:5.2f}")
    steer = acts[-n:, 0]
    flips = int(np.sum(np.diff(np.sign(np.diff(steer))) != 0))
    print(f"    steering-change sign flips in the last second: {flips} (of {len(steer) - 2} possible)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("agent")
    parser.add_argument("--circuits", default=",".join(RACE_SPLIT["validation"]))
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    for circuit in args.circuits.split(","):
        info, obs, acts, names, period = race(args.agent, circuit, args.laps, args.seed)
        v, ref = obs[:, names.index("v_x")], obs[:, names.index("target_speed")]
        over = float(np.max(v / np.maximum(ref, 1.0)))
        print(f"{circuit}: {info['termination'] or 'time limit'}, laps {info['laps_completed']}, "
              f"{float(info['progress_m']):.0f} m, peak v_x / target_speed {over:.2f}")
        if info["termination"] != "completed":
            last_second(obs, acts, names, period)


if __name__ == "__main__":
    main()
