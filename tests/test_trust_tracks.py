"""Track content the env drives is the content a row records, and every track route keeps observations in the box.

* A track file is read once per env, and the SHA-256 a row records is that of the very bytes the env parsed
  (``Path.source_sha256``). A file edited after an env read it is never recorded under either hash: evaluating that
  env, or a ``vtrack eval --track`` whose file changes between episodes, is refused naming the file; an env made
  after the edit drives and records the new content.
* ``gym.make("vtrack/Track-v0", track=Path(...))`` checks the curvature (as the env interpolates it) and the
  curvature rate against the observation's bounds, as the CSV loader does: one check where the env receives its
  paths (file, ``Path``, built-in, procedural).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.cli import main
from vtrack_gym.evaluation.api import evaluate
from vtrack_gym.evaluation.storage.store import ResultStore
from vtrack_gym.tracks import Path as TrackPath

STEPS = 60


def write_loop(file: Path, radius_m: float) -> str:
    """A circle of ``radius_m`` as an x, y CSV; returns the SHA-256 of the bytes written."""
    t = np.linspace(0.0, 2.0 * np.pi, 120, endpoint=False)
    text = "x_m,y_m\n" + "".join(f"{radius_m * np.cos(a):.6f},{radius_m * np.sin(a):.6f}\n" for a in t)
    file.write_text(text)
    return hashlib.sha256(text.encode()).hexdigest()


class Straight:
    """Steer straight: enough to drive an episode's first steps."""

    policy_id = "straight"

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.zeros((1,), dtype=np.float32), state


def test_an_env_records_the_bytes_it_read(tmp_path: Path) -> None:
    f = tmp_path / "loop.csv"
    sha = write_loop(f, 60.0)
    env = gym.make("vtrack/Track-v0", track=str(f), max_episode_steps=STEPS)
    assert env.unwrapped.paths[0].source_sha256 == sha
    rows = evaluate(Straight(), env, seeds=[0, 1])
    assert [r.options["track_sha256"] for r in rows] == [sha, sha]
    env.close()


def test_a_file_edited_after_make_is_refused_and_a_new_env_drives_the_new_content(tmp_path: Path) -> None:
    f = tmp_path / "loop.csv"
    old = write_loop(f, 60.0)
    env = gym.make("vtrack/Track-v0", track=str(f), max_episode_steps=STEPS)
    length_before = env.unwrapped.paths[0].length_m
    new = write_loop(f, 80.0)                   # edited between make and the episodes
    env.reset(seed=0)
    assert env.unwrapped.paths[0].length_m == length_before   # the env keeps driving what it read
    store = tmp_path / "s.db"
    with pytest.raises(ValueError, match=r"track file 'loop.csv' changed while it was used.*"
                                         + old[:16] + r".*" + new[:16]):
        evaluate(Straight(), env, seeds=[0], store=store)
    assert not store.exists() or ResultStore(store, read_only=True).rows() == []
    env.close()
    fresh = gym.make("vtrack/Track-v0", track=str(f), max_episode_steps=STEPS)
    assert fresh.unwrapped.paths[0].length_m > length_before
    rows = evaluate(Straight(), fresh, seeds=[0])
    assert rows[0].options["track_sha256"] == new
    fresh.close()


def test_vtrack_eval_track_refuses_a_file_edited_between_episodes(tmp_path: Path, monkeypatch,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    import vtrack_gym.evaluation.benchmarking.benchmark as api  # the episode scorer reads score_episode from here

    f = tmp_path / "loop.csv"
    write_loop(f, 61.0)     # content of its own: ids are keyed by content, not by the file's folder
    first_sha = hashlib.sha256(f.read_bytes()).hexdigest()
    real = api.score_episode
    calls = []

    def edit_after_first(*args, **kwargs):
        result = real(*args, **kwargs)
        calls.append(1)
        if len(calls) == 1:
            write_loop(f, 81.0)        # the next episode's env reads the edited file
        return result

    monkeypatch.setattr(api, "score_episode", edit_after_first)
    store = tmp_path / "s.db"
    code = main(["eval", "--policy", "stanley", "--track", str(f), "--seeds", "0,1", "--store", str(store)])
    err = capsys.readouterr().err
    assert code == 2
    assert "track file 'loop.csv' changed while it was used" in err
    assert len(calls) == 2
    # the first episode, driven on the file as it was, is stored under those bytes (each seed is committed as it
    # ends); the episode that read the edited file is refused and nothing of it is stored
    before = ResultStore(store, read_only=True).rows()
    assert [(r["seed"], r["options"]["track_sha256"]) for r in before] == [(0, first_sha)]
    monkeypatch.setattr(api, "score_episode", real)   # unchanged file: stored under the bytes driven
    sha = hashlib.sha256(f.read_bytes()).hexdigest()
    assert main(["eval", "--policy", "stanley", "--track", str(f), "--seeds", "0,1", "--store", str(store)]) == 0
    rows = [r for r in ResultStore(store, read_only=True).rows() if r["options"]["track_sha256"] == sha]
    assert len(rows) == 2


def kinked_path(offset_m: float) -> TrackPath:
    """A 200 m straight with one point displaced sideways by ``offset_m``, fitted exactly (no smoothing)."""
    x = np.linspace(0.0, 200.0, 401)
    y = np.zeros_like(x)
    y[200] = offset_m
    return TrackPath.from_points(x, y)


@pytest.mark.parametrize("how", ["make", "make_vec"])
def test_a_kinked_path_given_directly_is_refused(how: str) -> None:
    path = kinked_path(0.3)
    with pytest.raises(ValueError, match=r"track 'path': its curvature reaches .* at s = 10\d\.\d m, beyond the 2 "
                                         r"1/m an observation holds"):
        if how == "make":
            gym.make("vtrack/Track-v0", track=path)
        else:
            gym.make_vec("vtrack/Track-v0", num_envs=2, vectorization_mode="vector_entry_point", track=path)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(offset=st.floats(0.0, 2.0), smoothing=st.sampled_from([0.0, 0.05, 0.5]), seed=st.integers(0, 2**16))
def test_a_path_given_directly_is_refused_or_observed_inside_the_space(offset: float, smoothing: float,
                                                                        seed: int) -> None:
    x = np.linspace(0.0, 200.0, 401)
    y = np.zeros_like(x)
    y[200] = offset
    try:
        path = TrackPath.from_points(x, y, smoothing_m=smoothing)
    except ValueError:
        return
    rng = np.random.default_rng(seed)
    try:
        env = gym.make("vtrack/Track-v0", track=path, max_episode_steps=400)
    except ValueError as exc:
        assert "an observation holds" in str(exc)
        return
    space = env.observation_space
    obs, _ = env.reset(seed=seed, options={"target_speed_mps": 8.0})
    for _ in range(400):
        assert space.contains(obs), obs[~((obs >= space.low) & (obs <= space.high))]
        obs, _, term, trunc, _ = env.step(rng.uniform(-0.05, 0.05, size=1).astype(np.float32))
        if term or trunc:
            break
    env.close()



@pytest.mark.parametrize("env_id", ["vtrack/DLC120-v0", "vtrack/LateralTrackingRandom-v0"])
def test_envs_pickle_after_reset_and_steps_and_continue_bit_identically(env_id: str) -> None:
    """A stepped env (single and vector) pickles and deep-copies; the copy continues exactly like the original."""
    import copy
    import pickle

    rng = np.random.default_rng(3)
    actions = rng.uniform(-0.3, 0.3, size=(40, 2, 1)).astype(np.float32)
    env = gym.make(env_id)
    env.reset(seed=5)
    vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    vec.reset(seed=5)
    for a in actions[:10]:
        env.step(a[0])
        vec.step(a)
    copies = [pickle.loads(pickle.dumps(env)), copy.deepcopy(env)]
    vec_copy = pickle.loads(pickle.dumps(vec))
    for a in actions[10:]:
        out = env.step(a[0])
        for c in copies:
            again = c.step(a[0])
            assert np.array_equal(out[0], again[0]) and out[1:4] == again[1:4]
        out_v, again_v = vec.step(a), vec_copy.step(a)
        for x, y in zip(out_v[:4], again_v[:4], strict=True):
            assert np.array_equal(x, y)


@pytest.mark.parametrize("speed", [100.0 + 1e-9, 150.0])
def test_target_speeds_past_the_observation_bound_are_refused_through_make_and_reset(speed: float,
                                                                                      tmp_path: Path) -> None:
    """A target speed the observation cannot hold (above 100 m/s; 150 m/s was once accepted) is refused where a
    user sets it: a reset option (single and vector env) and a track's speed profile."""
    from vtrack_gym.tracks.speed_profiles import ConstantSpeed

    env = gym.make("vtrack/LateralTracking-v0")
    with pytest.raises(ValueError, match=r"target_speed_mps' must be in \[1\.0, 45\.0\]"):
        env.reset(seed=0, options={"target_speed_mps": speed})
    vec = gym.make_vec("vtrack/LateralTracking-v0", num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match=r"target_speed_mps' must be in \[1\.0, 45\.0\]"):
        vec.reset(seed=0, options={"target_speed_mps": speed})
    f = tmp_path / "loop.csv"
    write_loop(f, 500.0)
    with pytest.raises(ValueError, match=r"ConstantSpeed\.v_mps must be in \[1\.0, 100\.0\] m/s"):
        gym.make("vtrack/Track-v0", track=str(f), speed_profile=ConstantSpeed(speed))
    with pytest.raises(SystemExit) as exc:   # refused while parsing, before any work
        main(["eval", "--policy", "stanley", "--track", str(f), "--speed-profile", "constant",
              "--max-speed-kmh", str(speed * 3.6), "--store", str(tmp_path / "s.db")])
    assert exc.value.code == 2
    assert not (tmp_path / "s.db").exists()
