"""A policy's behaviour fingerprint: its deterministic actions on fixed probe sequences of observations.

The probes are observation sequences recorded once from the package's scenarios (``PROBE_ENV_IDS``, driven by the
``lqr`` baseline with a deterministic steering dither, so lateral and heading errors of both signs appear) and
shipped with the package (``vtrack_gym/data/probe_observations.npz``, written by ``record_probes``). Each sequence
is fed to a copy of the policy from ``episode_start`` on, passing its ``state`` back as a rollout does, so
stateful policies and observers are probed too. A policy is probed twice on two copies (``copy.deepcopy``; the
policy itself is never touched, so probing changes no episode): two different answers mean it does not act
deterministically, and it is refused. Actions are clipped to the action box [-1, 1] (the envs clip them too) and
quantised to ``ACTION_QUANTUM`` before hashing, so the digest holds across machines whose floating-point results
differ in the last bits.

An env's observation layout selects the probe's entries by name (``ObservationLayout.names``); an env without a
vtrack layout is probed with observations drawn from its observation space with a fixed seed.
"""

from __future__ import annotations

import copy
import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

PROBE_FILE = Path(__file__).resolve().parents[2] / "data" / "probe_observations.npz"
"""The shipped probe sequences: ``observations`` (sequences, steps, entries) float32 and their ``names``."""
PROBE_ENV_IDS: tuple[str, ...] = ("DLC120-v0", "LateralTracking-v0", "vtrack/ISO3888-1-v1", "vtrack/Slalom-v1")
"""The scenarios the probe sequences are recorded on."""
PROBE_WINDOWS: tuple[int, ...] = (0, 150, 400)
"""First control step of each recorded window (one sequence per scenario and window)."""
PROBE_STEPS = 30
"""Control steps per probe sequence."""
ACTION_QUANTUM = 2.0**-24
"""Resolution of a probed action (the action box is [-1, 1]): actions closer than this may hash alike."""


class ProbeError(ValueError):
    """The policy cannot be probed (cannot be copied, fails on the probes, or acts differently twice)."""


def probe_observations(env: Any = None) -> np.ndarray:
    """The probe sequences (sequences, steps, entries) float32 in ``env``'s observation layout (the package's
    default layout ``OBS`` without an env)."""
    with np.load(PROBE_FILE, allow_pickle=False) as data:
        observations, names = data["observations"], [str(n) for n in data["names"]]
    layout = _layout_of(env)
    if layout is None:
        return _sampled(env, observations.shape[:2])
    column = {n: i for i, n in enumerate(names)}
    missing = [n for n in layout.names if n not in column]
    if missing:
        raise ProbeError(f"the probe observations have no entry {missing[0]!r} of this env's layout")
    return np.ascontiguousarray(observations[:, :, [column[n] for n in layout.names]])


def layout_names(env: Any) -> tuple[str, ...] | None:
    """The observation entries ``env``'s probes are laid out by (the default layout's without an env), None for
    an env without a vtrack observation layout (probed with sampled observations)."""
    layout = _layout_of(env)
    return None if layout is None else tuple(layout.names)


def _layout_of(env: Any) -> Any:
    """``env``'s vtrack ``ObservationLayout`` (``OBS`` without an env), or None for another kind of env."""
    from vtrack_gym.envs.observation import OBS, ObservationLayout

    if env is None:
        return OBS
    layout = getattr(getattr(env, "unwrapped", env), "observation_layout", None)
    return layout if isinstance(layout, ObservationLayout) else None


def _sampled(env: Any, shape: tuple[int, ...]) -> np.ndarray:
    """Observations drawn from ``env``'s Box observation space with a fixed seed (unbounded entries within +-10)."""
    import gymnasium as gym

    space = getattr(env, "observation_space", None)
    if not isinstance(space, gym.spaces.Box):
        raise ProbeError(f"an env without a vtrack observation layout needs a Box observation space to be probed "
                         f"(got {type(space).__name__})")
    low = np.clip(np.nan_to_num(space.low.astype(np.float64)), -10.0, 10.0)
    high = np.clip(np.nan_to_num(space.high.astype(np.float64)), -10.0, 10.0)
    draws = np.random.default_rng(20261204).uniform(0.0, 1.0, (*shape, *space.shape))
    return (low + draws * (high - low)).astype(space.dtype)


def behaviour_digest(policy: Any, env: Any = None, faithful: Callable[[Any], bool] | None = None) -> str:
    """SHA-256 hex digest of ``policy``'s quantised actions on the probe sequences in ``env``'s layout;
    ``ProbeError`` when it cannot be probed (see the module docstring). ``faithful(copy)``: False when a copy
    differs from the policy (a class whose pickling leaves state out), which is then refused too."""
    probes = probe_observations(env)
    first, second = (_actions(_copy(policy, faithful), probes) for _ in range(2))
    if not np.array_equal(first, second):
        raise ProbeError("it acts differently on the same probe observations twice (not deterministic with "
                         "deterministic=True)")
    digest = hashlib.sha256(f"probes{probes.shape}:actions{first.shape}:".encode())
    digest.update(first.tobytes())
    return digest.hexdigest()


def _copy(policy: Any, faithful: Callable[[Any], bool] | None) -> Any:
    try:
        copied = copy.deepcopy(policy)
    except Exception as exc:  # any refusal to copy: the policy cannot be probed without touching it
        raise ProbeError(f"it cannot be copied to probe its behaviour ({type(exc).__name__}: {str(exc)[:120]})") \
            from None
    if faithful is not None and not faithful(copied):
        raise ProbeError("a copy of it holds other state than it does (its class copies or pickles itself "
                         "without all of its state), so a copy's behaviour is not its own")
    return copied


def _actions(policy: Any, probes: np.ndarray) -> np.ndarray:
    """Quantised actions (int64, sequences x steps x action entries) of ``policy`` on ``probes``."""
    out = []
    for sequence in probes:
        state, start = None, np.ones(1, dtype=bool)
        for obs in sequence:
            try:
                action, state = policy.predict(obs.copy(), state=state, episode_start=start, deterministic=True)
            except Exception as exc:  # a policy that fails on the probes cannot be told apart by them
                raise ProbeError(f"its predict failed on the probe observations ({type(exc).__name__}: "
                                 f"{str(exc)[:120]})") from None
            start = np.zeros(1, dtype=bool)
            out.append(np.array(action, dtype=np.float64).ravel())   # a copy: a policy may reuse its array
    widths = {a.size for a in out}
    if len(widths) != 1:
        raise ProbeError(f"its actions on the probes have different sizes ({sorted(widths)})")
    return _quantised(np.stack(out)).reshape(len(probes), probes.shape[1], -1)


def _quantised(action: Any) -> np.ndarray:
    """``action`` (any shape) clipped to [-1, 1] and rounded to ``ACTION_QUANTUM``, flat (int64; NaN as a value no
    action takes)."""
    a = np.asarray(action, dtype=np.float64).ravel()
    q = np.round(np.clip(a, -1.0, 1.0) / ACTION_QUANTUM)
    return np.where(np.isnan(a), np.iinfo(np.int64).min, q).astype(np.int64)


def record_probes(path: Path = PROBE_FILE) -> np.ndarray:
    """Record the probe sequences from ``PROBE_ENV_IDS`` and write them to ``path``; returns the observations.

    Each scenario is driven by the ``lqr`` baseline plus a dither of 0.15 * sin(2 pi 0.8 t) (t [s]) on the steering
    command, seed 0; a window of ``PROBE_STEPS`` steps is kept from each of ``PROBE_WINDOWS``. A maintainer's
    step (``python -m vtrack_gym.evaluation.identity.probes``): the probes are data, and every policy hash depends on
    them.
    """
    import gymnasium as gym

    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.envs.observation import OBS

    sequences = []
    for env_id in PROBE_ENV_IDS:
        env = gym.make(env_id)
        policy = make_policy("lqr", env)
        obs, _ = env.reset(seed=0)
        seen = [obs]
        period = env.unwrapped.control_period_s
        for k in range(max(PROBE_WINDOWS) + PROBE_STEPS):
            action, _ = policy.predict(obs)
            dither = 0.15 * np.sin(2.0 * np.pi * 0.8 * k * period)
            obs, _, terminated, truncated, _ = env.step(np.clip(np.asarray(action, float) + dither, -1.0, 1.0))
            if terminated or truncated:
                raise RuntimeError(f"{env_id}: the probe drive ended at step {k}; choose other windows")
            seen.append(obs)
        env.close()
        sequences += [np.asarray(seen[w:w + PROBE_STEPS], dtype=np.float32) for w in PROBE_WINDOWS]
    observations = np.stack(sequences)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, observations=observations, names=np.array(OBS.names))
    return observations


if __name__ == "__main__":
    print(f"wrote {record_probes().shape} to {PROBE_FILE}")
