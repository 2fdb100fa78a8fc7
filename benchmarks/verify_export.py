"""Does a weights-only agent act as its SB3 checkpoint does? Max |numpy action - SB3 deterministic action|.

Loads an SB3 checkpoint (default ``<run-dir>/best_model.zip``; ``--model model.zip`` for the final one; SB3's
pickle-based format: only for runs you made yourself) and the weights-only export to compare (default
``<run-dir>/best_agent.json``, e.g. the shipped ``vtrack_gym/baselines/shipped/ppo.json`` after
``vtrack train ... --run-dir runs/ppo_bc``), drives 64 cars of
``LateralTrackingRandom-v0`` for 200 steps with the numpy policy and prints the largest difference between the two
policies' actions on all visited observations (SB3 fed with the observations normalised by the export's own
statistics).
Run: ``python benchmarks/verify_export.py --run-dir runs/ppo_bc [--agent vtrack_gym/baselines/shipped/ppo.json]``,
``python benchmarks/verify_export.py --run-dir runs/sac_bc --model model.zip --agent
vtrack_gym/baselines/shipped/sac.json``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run-dir", type=Path, required=True)
    parser.add_argument("--agent", type=Path, default=None, help="weights-only agent (default: best_agent.json)")
    parser.add_argument("--model", default="best_model.zip", help="SB3 checkpoint in --run-dir (default: %(default)s)")
    args = parser.parse_args()
    from stable_baselines3 import PPO, SAC, TD3

    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv
    from vtrack_gym.baselines.numpy_policy import load_agent

    agent_path = args.agent or args.run_dir / "best_agent.json"
    policy = load_agent(agent_path)
    cls = {"ppo": PPO, "sac": SAC, "td3": TD3}[policy.spec["algo"]]
    model = cls.load(args.run_dir / args.model, device="cpu")
    arrays = np.load(agent_path.with_suffix(".npz"), allow_pickle=False)
    venv = TrackingSB3VecEnv("LateralTrackingRandom-v0", num_envs=64)
    venv.seed(5)
    obs = [venv.reset()]
    for _ in range(200):
        obs.append(venv.step(policy.predict(obs[-1])[0])[0])
    venv.close()
    x = np.concatenate(obs).astype(np.float32)
    eps, clip = policy.spec["obs_norm"]["eps"], float(arrays["clip_obs"][0])
    normalised = np.clip((x - arrays["obs_mean"]) / np.sqrt(arrays["obs_var"] + eps), -clip, clip)
    sb3_actions, _ = model.predict(normalised, deterministic=True)
    numpy_actions, _ = policy.predict(x)
    print(f"{agent_path}: {len(x)} observations, max |numpy - SB3| = "
          f"{float(np.max(np.abs(sb3_actions - numpy_actions))):.3g}")


if __name__ == "__main__":
    main()
