"""Behaviour fingerprint of a registered env id: a fixed action sequence from fixed seeds, hashed.

The fingerprint covers every observation (float32 bytes), reward (float64), ``terminated`` / ``truncated`` flag,
``info["termination"]`` and ``info["success"]`` of two episodes: from seed 0, ``STEPS`` control steps of a fixed
action sequence (a sinusoid plus fixed pseudo-random noise: the car steers off its line and often leaves the road);
from seed 7, up to ``FOLLOW_STEPS`` steps of a fixed proportional law on e_y and e_phi defined here (so the car
follows the road far enough to reach its curves, gates and speed changes).
A registered id's behaviour never changes; a change gets the next version (``-v1``). ``tests/test_env_versions.py``
compares every registered id against ``tests/data/env_fingerprints.json``; the pin of an id that is no longer
registered stays in the file, and the test checks that making it raises Gymnasium's ``DeprecatedEnv`` naming the
id listed for it in ``vtrack_gym.envs.scenarios.DEPRECATED_IDS``.

Writing the file (only for an id that is new, never to change an existing entry)::

    python tests/env_fingerprint.py --add vtrack/NewScenario-v0
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

FINGERPRINT_FILE = Path(__file__).parent / "data" / "env_fingerprints.json"
SEQUENCE_SEED = 0
FOLLOW_SEED = 7
STEPS = 300
FOLLOW_STEPS = 3000


def action_sequence(steps: int = STEPS) -> np.ndarray:
    """The fixed steering commands (fraction of the road-wheel limit), shape (steps,)."""
    k = np.arange(steps)
    noise = np.random.default_rng(20261202).uniform(-0.03, 0.03, steps)
    return (0.08 * np.sin(2.0 * np.pi * k / 150.0) + noise).astype(np.float32)


def fingerprint(env_id: str) -> str:
    """SHA-256 of the behaviour of ``env_id``: ``action_sequence`` from seed 0, the fixed follower from seed 7."""
    import gymnasium as gym

    import vtrack_gym  # noqa: F401  (registers the ids)

    digest = hashlib.sha256()
    env = gym.make(env_id)
    try:
        layout = env.unwrapped.observation_layout
        e_y, e_phi = layout.index("e_y"), layout.index("e_phi")
        for seed, steps in ((SEQUENCE_SEED, STEPS), (FOLLOW_SEED, FOLLOW_STEPS)):
            obs, info = env.reset(seed=seed)
            digest.update(np.asarray(obs, dtype=np.float32).tobytes())
            sequence = action_sequence()
            for k in range(steps):
                if seed == SEQUENCE_SEED:
                    action = sequence[k]
                else:  # fixed follower: 0.5 rad of command per metre of e_y, 1.5 per radian of e_phi
                    action = np.clip(-0.5 * obs[e_y] - 1.5 * obs[e_phi], -1.0, 1.0)
                obs, reward, terminated, truncated, info = env.step(np.array([action], dtype=np.float32))
                digest.update(np.asarray(obs, dtype=np.float32).tobytes())
                digest.update(np.float64(reward).tobytes())
                digest.update(bytes([bool(terminated), bool(truncated), bool(info["success"])]))
                digest.update(str(info["termination"]).encode())
                if terminated or truncated:
                    break
    finally:
        env.close()
    return digest.hexdigest()


def pinned() -> dict[str, str]:
    """The pinned fingerprints, id -> hex digest."""
    return json.loads(FINGERPRINT_FILE.read_text())["fingerprints"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Pin the behaviour fingerprint of a new env id.")
    parser.add_argument("--add", nargs="+", required=True, metavar="ENV_ID", help="new ids to pin")
    args = parser.parse_args(argv)
    data = json.loads(FINGERPRINT_FILE.read_text()) if FINGERPRINT_FILE.exists() else {"fingerprints": {}}
    for env_id in args.add:
        if env_id in data["fingerprints"]:
            print(f"{env_id} is pinned already; a behaviour change needs a new version, not a new pin",
                  file=sys.stderr)
            return 2
        data["fingerprints"][env_id] = fingerprint(env_id)
    data["fingerprints"] = dict(sorted(data["fingerprints"].items()))
    FINGERPRINT_FILE.write_text(json.dumps(data, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
