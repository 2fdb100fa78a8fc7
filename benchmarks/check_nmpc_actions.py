"""Are the compiled NMPCs' actions bit-identical to another checkout's? (a refactor check, not a timing)

Records, in a fresh process per checkout (``PYTHONPATH`` = the checkout, its own kernel cache), the closed-loop
actions and state rows of ``nmpc`` (steer) and ``nmpc_coupled`` (steer_accel) on DLC120-v0 and LateralTracking-v0
(seed 0, whole episodes): the inline preparation, the deferred one (``defer_preparation`` set, ``prepare()`` after
each ``predict``, as the harness runs a policy under measured latency; the latency itself is left off, since it
makes the episode depend on the wall clock), three Gauss-Newton steps a decision (``sqp_iterations=3``) and a
batch of three cars on the vector env. Then compares them element by element (``np.array_equal``, NaN never expected) and exits 1 on any
difference.

Run: ``python benchmarks/check_nmpc_actions.py --against DIR`` (this checkout against ``DIR``, e.g. the main
branch's); ``--only deferred`` (or ``inline``) records only those episodes (and no batch).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ENV_IDS = ("DLC120-v0", "LateralTracking-v0")
CASES: tuple[tuple[str, str, dict], ...] = (
    ("nmpc", "steer", {}), ("nmpc", "steer", {"sqp_iterations": 3}),
    ("nmpc_coupled", "steer_accel", {}), ("nmpc_coupled", "steer_accel", {"sqp_iterations": 3}))
"""(policy, control mode, config overrides)."""


def _episode(name: str, control: str, overrides: dict, env_id: str, defer: bool) -> dict[str, list]:
    """Actions and state rows of one closed-loop episode, seed 0 (``defer``: ``prepare()`` after each decision,
    as the harness runs a two-phase policy under measured latency)."""
    import gymnasium as gym

    import vtrack_gym  # noqa: F401  (registers the ids)
    from vtrack_gym.baselines.registry import make_policy

    env = gym.make(env_id, control=control)
    policy = make_policy(name, env, **overrides)
    policy.defer_preparation = defer
    obs, _ = env.reset(seed=0)
    state, out = None, {"actions": [], "states": []}
    while True:
        action, state = policy.predict(obs, state=state)
        if policy.defer_preparation:
            policy.prepare()
        out["actions"].append(np.array(action, dtype=np.float64).ravel())
        out["states"].append(state.copy())
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            return out


def _batch(name: str, control: str, env_id: str, steps: int = 300) -> dict[str, list]:
    """Actions and state rows of three cars stepped together (the vector env, seeds 0, 1, 2; ``steps`` steps)."""
    import gymnasium as gym

    from vtrack_gym.baselines.registry import make_policy

    envs = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", control=control)
    policy = make_policy(name, gym.make(env_id, control=control))
    obs, _ = envs.reset(seed=[0, 1, 2])
    state, out = None, {"actions": [], "states": []}
    for _ in range(steps):
        action, state = policy.predict(obs, state=state)
        out["actions"].append(np.array(action, dtype=np.float64).ravel())
        out["states"].append(state.copy())
        obs, *_ = envs.step(action)
    return out


def record(path: Path, only: str = "both") -> None:
    """Every case's arrays into ``path`` (npz); ``only``: ``inline`` or ``deferred`` episodes alone."""
    arrays: dict[str, np.ndarray] = {}
    modes = {"both": (False, True), "inline": (False,), "deferred": (True,)}[only]
    for name, control, overrides in CASES:
        for env_id in ENV_IDS:
            for defer in modes:
                tag = f"{name}|{control}|{sorted(overrides.items())}|{env_id}|{'deferred' if defer else 'inline'}"
                run = _episode(name, control, overrides, env_id, defer)
                arrays[tag + "|actions"] = np.vstack(run["actions"])
                arrays[tag + "|states"] = np.vstack(run["states"])
        for env_id in ENV_IDS if only != "deferred" else ():
            if not overrides:
                run = _batch(name, control, env_id)
                arrays[f"{name}|batch|{env_id}|actions"] = np.vstack(run["actions"])
                arrays[f"{name}|batch|{env_id}|states"] = np.vstack(run["states"])
    np.savez(path, **arrays)


def run(checkout: Path, out: Path, tag: str, only: str) -> None:
    """``record(out, only)`` in a fresh process importing the package from ``checkout``."""
    env = {**os.environ, "PYTHONPATH": str(checkout), "OMP_NUM_THREADS": "1",
           "NUMBA_CACHE_DIR": os.environ.get("NUMBA_CACHE_DIR", "/tmp/numba_check") + f"-{tag}"}
    subprocess.run([sys.executable, __file__, "--record", str(out), "--only", only], env=env, check=True,
                   cwd=checkout)


def compare(a: Path, b: Path) -> int:
    """Print each case's verdict; the number of differing arrays."""
    with np.load(a) as fa, np.load(b) as fb:
        keys = sorted(set(fa.files) | set(fb.files))
        bad = 0
        for key in keys:
            same = key in fa.files and key in fb.files and fa[key].shape == fb[key].shape \
                and np.array_equal(fa[key], fb[key])
            bad += not same
            print(f"{'identical' if same else 'DIFFERENT'}  {key}  "
                  f"{fa[key].shape if key in fa.files else '-'}")
    return bad


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", type=Path, help="the other checkout (e.g. the main branch)")
    ap.add_argument("--only", choices=("both", "inline", "deferred"), default="both")
    ap.add_argument("--record", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.record is not None:
        record(args.record, args.only)
        return
    here = Path(__file__).resolve().parent.parent
    with tempfile.TemporaryDirectory() as tmp:
        a, b = Path(tmp) / "a.npz", Path(tmp) / "b.npz"
        run(args.against.resolve(), a, "a", args.only)
        run(here, b, "b", args.only)
        bad = compare(a, b)
    print(f"{'all identical' if not bad else f'{bad} arrays differ'}: {here} against {args.against}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
