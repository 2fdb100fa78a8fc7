"""A policy's identity is what can be read of it exactly plus how it acts on fixed probe sequences of observations:
for each state shape below, a steering gain of 1.0 (completes DLC120-v0) and 0.3 (spins out) are two leaderboard
rows, scored through ``vtrack_gym.evaluate`` into one store, the board keeping each run's latest rows.

Six shapes that a state reading alone got wrong (a ``config`` dataclass, a ``weights_hash`` attribute, a torch
module's plain attribute, a dict subclass's attribute, a ``random.Random`` subclass, a class's own ``__reduce__``)
and two whose state holds no trace of the gain at all (a gain read from a file at each decision, a gain held by
a class made at run time under one name)."""

from __future__ import annotations

import dataclasses
import random
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.observation import OBS
from vtrack_gym.evaluation.identity.fingerprint import IncompleteFingerprint, named_policy_hash, policy_hash
from vtrack_gym.evaluation.storage.store import ResultStore


def lqr_law() -> Any:
    """The package's LQR steering law (the gain scales its command)."""
    return vtrack_gym.make_policy("lqr", gym.make("DLC120-v0"))


def scaled(law: Any, k: float, obs: Any, state: Any) -> tuple[np.ndarray, Any]:
    action, _ = law.predict(obs)
    return np.clip(k * np.asarray(action, dtype=np.float32), -1.0, 1.0), state


@dataclasses.dataclass(frozen=True)
class Declared:
    name: str = "my-controller"


class WithConfig:
    """A declared ``config`` that does not hold the gain."""

    def __init__(self, k: float) -> None:
        self.config, self.k, self.law = Declared(), k, lqr_law()

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return scaled(self.law, self.k, obs, state)


class WithWeightsHash(WithConfig):
    """A declared ``weights_hash`` that does not cover the gain."""

    weights_hash = "3e099a1a4e22" * 5

    def __init__(self, k: float) -> None:
        super().__init__(k)
        del self.config


def torch_policy(k: float) -> Any:
    import torch

    class Scale(torch.nn.Module):
        """A module whose gain is a plain attribute (no parameter, no buffer)."""

        def __init__(self, k: float) -> None:
            super().__init__()
            self.k = k

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            return self.k * x

    class TorchScaled:
        def __init__(self) -> None:
            self.net, self.law = Scale(k), lqr_law()

        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            action, _ = self.law.predict(obs)
            out = self.net(torch.as_tensor(np.asarray(action, dtype=np.float32))).detach().numpy()
            return np.clip(out, -1.0, 1.0), state

    return TorchScaled()


class DictPolicy(dict):
    """A dict subclass (no items) whose gain is an attribute."""

    def __init__(self, k: float) -> None:
        super().__init__()
        self.k, self.law = k, lqr_law()

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return scaled(self.law, self.k, obs, state)


class RandomPolicy(random.Random):
    """A ``random.Random`` subclass holding the gain (its pickling keeps only the generator state)."""

    def __init__(self, k: float = 1.0) -> None:
        super().__init__(0)
        self.k, self.law = k, lqr_law()

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return scaled(self.law, self.k, obs, state)


class OwnReduce:
    """A class whose own ``__reduce__`` leaves the gain out."""

    def __init__(self, k: float = 1.0) -> None:
        self.k, self.law = k, lqr_law()

    def __reduce__(self):
        return (OwnReduce, ())

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return scaled(self.law, self.k, obs, state)


class FromFile:
    """Reads its gain from a file at each decision: its state is the same path for every gain."""

    def __init__(self, path: Path) -> None:
        self.path, self.law = str(path), lqr_law()

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return scaled(self.law, float(Path(self.path).read_text()), obs, state)


class ClassGain:
    """Its gain is a class attribute of a class made at run time, always under this one name."""

    k = 1.0

    def __init__(self) -> None:
        self.law = lqr_law()

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return scaled(self.law, self.k, obs, state)


def make(shape: str, k: float, tmp_path: Path) -> Any:
    if shape == "file":
        gain_file = tmp_path / "gain.txt"
        gain_file.write_text(repr(k))
        return FromFile(gain_file)
    if shape == "class":
        return type("ClassGain", (ClassGain,), {"k": k, "__qualname__": "ClassGain"})()
    return {"config": WithConfig, "weights_hash": WithWeightsHash, "torch": torch_policy, "dict": DictPolicy,
            "random": RandomPolicy, "reduce": OwnReduce}[shape](k)


SHAPES = ("config", "weights_hash", "torch", "dict", "random", "reduce", "file", "class")


@pytest.mark.parametrize("shape", SHAPES)
def test_two_gains_are_two_rows_of_the_board(shape: str, tmp_path: Path) -> None:
    store = tmp_path / "board.sqlite"
    for k in (1.0, 0.3):
        vtrack_gym.evaluate(make(shape, k, tmp_path), "DLC120-v0", store=store)
    rows = ResultStore(store).rows()
    assert len({r["policy_hash"] for r in rows}) == 2
    board = vtrack_gym.leaderboard(store, "custom")
    assert len(board) == 2
    assert sorted(r["termination"] for r in rows) == ["completed", "spin_out"]


def test_one_policy_is_one_hash_and_probing_leaves_it_untouched() -> None:
    """Equal policies hash alike (in every instance); the probes run on copies, so the policy's own state (here a
    counter of decisions) is not changed by taking its fingerprint."""

    class Counting(WithConfig):
        def __init__(self, k: float) -> None:
            super().__init__(k)
            self.decisions = 0

        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            self.decisions += 1
            return super().predict(obs, state, episode_start, deterministic)

    policy = Counting(1.0)
    assert policy_hash(policy) == policy_hash(Counting(1.0)) != policy_hash(Counting(0.3))
    assert policy.decisions == 0


def test_a_stateful_policy_is_probed_along_sequences() -> None:
    """The probes are sequences fed with the policy's ``state`` passed back from ``episode_start`` on: two
    policies that act alike on a first observation and differ only in how their memory decays (a class attribute
    of a class made at run time: no state difference) are two hashes."""

    class Integrating:
        leak = 1.0

        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            fresh = state is None or bool(np.asarray(episode_start).any())
            total = (0.0 if fresh else self.leak * state) + 10.0 * float(np.asarray(obs)[OBS.E_Y])
            return np.array([np.clip(total, -1.0, 1.0)], dtype=np.float32), total

    def variant(leak: float) -> Any:
        return type("Integrating", (Integrating,), {"leak": leak, "__qualname__": "Integrating"})()

    full, leaky = variant(1.0), variant(0.5)
    obs = np.full(OBS.size, 0.01, dtype=np.float32)
    assert np.array_equal(full.predict(obs)[0], leaky.predict(obs)[0])
    assert policy_hash(full) != policy_hash(leaky)
    assert policy_hash(full) == policy_hash(variant(1.0))


def test_a_declared_identity_is_checked_against_the_behaviour() -> None:
    """A policy whose state cannot be read keeps its declared identity (here a ``weights_hash``) only together
    with its behaviour: the same declaration acting otherwise is another hash; nothing declared and nothing
    readable is refused unless named, and a name is also checked against the behaviour."""
    import threading

    class Locked(WithWeightsHash):
        def __init__(self, k: float) -> None:
            super().__init__(k)
            self.lock = threading.Lock()

        def __deepcopy__(self, memo):
            clone = Locked.__new__(Locked)
            clone.__dict__.update({**self.__dict__, "lock": threading.Lock()})
            return clone

    assert policy_hash(Locked(1.0)) == policy_hash(Locked(1.0)) != policy_hash(Locked(0.3))

    class Undeclared(Locked):
        weights_hash = None

    with pytest.raises(IncompleteFingerprint, match="policy_id"):
        policy_hash(Undeclared(1.0))
    assert named_policy_hash(Undeclared(1.0), "mine") != named_policy_hash(Undeclared(0.3), "mine")
    assert named_policy_hash(Undeclared(1.0), "mine") == named_policy_hash(Undeclared(1.0), "mine")


def test_a_policy_acting_differently_twice_on_the_same_probes_needs_a_name() -> None:
    import threading

    class Noisy:
        def __init__(self) -> None:
            self.lock = threading.Lock()          # unreadable state: the behaviour would have to identify it

        def __deepcopy__(self, memo):
            return Noisy()

        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return np.array([random.uniform(-1.0, 1.0)], dtype=np.float32), state

    class DeclaredNoisy(Noisy):
        weights_hash = "abc"

    with pytest.raises(IncompleteFingerprint, match="acts differently on the same probe observations twice"):
        policy_hash(DeclaredNoisy())


def test_the_shipped_probes_are_the_default_layout_and_excite_the_errors() -> None:
    from vtrack_gym.evaluation.identity.probes import PROBE_ENV_IDS, PROBE_STEPS, PROBE_WINDOWS, probe_observations

    probes = probe_observations()
    assert probes.shape == (len(PROBE_ENV_IDS) * len(PROBE_WINDOWS), PROBE_STEPS, OBS.size)
    assert probes.dtype == np.float32 and np.isfinite(probes).all()
    e_y = probes[:, :, OBS.E_Y]
    assert (np.abs(e_y).max(axis=1) > 1e-3).all() and e_y.min() < 0.0 < e_y.max()   # every sequence steers


@pytest.mark.slow
def test_the_shipped_probes_are_what_the_recorder_writes(tmp_path: Path) -> None:
    """The probe file is data recorded from the package's scenarios; re-recording gives it back (to float32
    rounding across machines)."""
    from vtrack_gym.evaluation.identity.probes import probe_observations, record_probes

    fresh = record_probes(tmp_path / "probes.npz")
    np.testing.assert_allclose(fresh, probe_observations(), rtol=1e-5, atol=1e-6)
