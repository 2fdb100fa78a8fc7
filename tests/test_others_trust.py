"""Smaller trust findings: a copied track keeps the hash of the bytes it was built from, a finite but huge action
is clipped (not turned into inf) in the scoring rollout, and one figure-size limit for the HTML report and the CLI."""

from __future__ import annotations

import copy
import pickle
from pathlib import Path

import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.tracks import load_track


def _road(file: Path) -> Path:
    s = np.arange(0.0, 120.0, 2.0)
    file.write_text("x_m,y_m\n" + "\n".join(f"{v:.3f},{0.001 * v * v:.4f}" for v in s) + "\n")
    return file


def test_a_pickled_or_copied_track_keeps_its_source_hash(tmp_path: Path) -> None:
    path = load_track(_road(tmp_path / "road.csv"))
    assert path.source_sha256 is not None
    for clone in (pickle.loads(pickle.dumps(path)), copy.deepcopy(path)):
        assert clone.source_sha256 == path.source_sha256
        assert np.array_equal(clone.table, path.table)


class _Huge:
    """Steers with a finite float64 far beyond float32's range."""

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.array([1e39 if np.asarray(observation).reshape(-1)[0] >= 0.0 else -1e39]), state


def test_a_finite_huge_action_is_clipped_in_the_scoring_rollout() -> None:
    rows = vtrack_gym.evaluate(_Huge(), "DLC120-v0", seeds=[0], policy_id="huge")
    assert len(rows) == 1 and rows[0].termination != ""   # scored, not refused as an infinite action


def test_step_action_keeps_refusing_nan_and_inf() -> None:
    from vtrack_gym.evaluation.rollouts.rollout import step_action

    assert step_action(np.array([1e39]), (1,)).tolist() == [1.0]
    assert step_action(np.array([-1e300]), (1,)).tolist() == [-1.0]
    assert step_action(np.array([0.3]), (1,))[0] == np.float32(0.3)
    assert np.isnan(step_action(np.array([np.nan]), (1,))[0])
    assert np.isinf(step_action(np.array([np.inf]), (1,))[0])


def test_one_figure_size_limit_for_the_report_and_the_cli() -> None:
    from vtrack_gym.cli import leaderboard
    from vtrack_gym.evaluation.leaderboard import html_report

    assert html_report.MAX_FIGURE_BYTES == leaderboard.MAX_FIGURE_BYTES == 32 * 2**20
    guarantees = (Path(__file__).resolve().parents[1] / "docs" / "GUARANTEES.md").read_text()
    assert "32 MiB" in guarantees


VEHICLE_SWAPPER = '''
import os
from pathlib import Path

import numpy as np
import pytest
from vtrack_gym.envs import OBS


class SwapsTheCar:
    """Steers on e_y and e_phi; the first time it is built it overwrites the run's vehicle file with another car."""

    @classmethod
    def from_env(cls, env):
        target = Path(os.environ["VTRACK_TEST_VEHICLE"])
        replacement = Path(os.environ["VTRACK_TEST_REPLACEMENT"])
        if replacement.exists():
            target.write_bytes(replacement.read_bytes())
            replacement.unlink()
        return cls()

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation, dtype=np.float64)
        a = -(0.08 * obs[..., OBS.E_Y] + 0.9 * obs[..., OBS.E_PHI])
        return np.clip(a, -1.0, 1.0).astype(np.float32)[..., None], state
'''


def test_a_vehicle_file_saved_during_eval_changes_no_row(tmp_path: Path, monkeypatch) -> None:
    """``vtrack eval --vehicle FILE`` reads the file once: a save during the run (here by the policy of the first
    episode) changes neither the car of the later episodes nor what their rows record."""
    import hashlib

    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.storage.store import ResultStore
    from vtrack_gym.vehicle.catalog import _data_dir

    car = tmp_path / "my_car.json"
    car.write_bytes((_data_dir() / "suv.json").read_bytes())
    (tmp_path / "replacement.json").write_bytes((_data_dir() / "sports.json").read_bytes())
    original = hashlib.sha256(car.read_bytes()).hexdigest()[:10]
    (tmp_path / "swapper.py").write_text(VEHICLE_SWAPPER)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("VTRACK_TEST_VEHICLE", str(car))
    monkeypatch.setenv("VTRACK_TEST_REPLACEMENT", str(tmp_path / "replacement.json"))
    store = tmp_path / "s.sqlite"
    assert main(["eval", "--policy", "swapper:SwapsTheCar", "--trust-code", "--env", "DLC120-v0", "--seeds", "0-2",
                 "--vehicle", str(car), "--store", str(store)]) == 0
    assert not (tmp_path / "replacement.json").exists()          # the file was saved during the run
    labels = {r["options"].get("vehicle") for r in ResultStore(store, read_only=True).rows()}
    assert labels == {f"my_car-{original}"}


def test_yaw_acc_ref_stays_in_its_box_on_a_path_whose_curvature_alternates_every_0_1_m() -> None:
    """An accepted path (curvature rate within the loader's 10 1/m^2) driven at 40 km/h asks for a reference yaw
    acceleration above the 1000 rad/s^2 of its box: the field is saturated at its bound, and every observation
    stays inside the space."""
    import gymnasium as gym

    from vtrack_gym.envs import OBS
    from vtrack_gym.tracks import ConstantSpeed
    from vtrack_gym.tracks import Path as TrackPath
    from vtrack_gym.tracks.profiles import CurvatureProfile

    segments = [(0.1, 0.25 if i % 2 == 0 else -0.25) for i in range(3000)]   # the sign flips every 0.1 m
    path = TrackPath.from_curvature(CurvatureProfile.from_segments(-0.25, segments), 299.9)
    assert float(np.max(np.abs(path.table[:, 4]))) <= 10.0   # a curvature rate the loader accepts
    env = gym.make("vtrack/Track-v0", track=path, speed_profile=ConstantSpeed(40.0 / 3.6))
    obs, _ = env.reset(seed=0)
    peak = 0.0
    for _ in range(3000):   # from standstill up to 40 km/h, then on at that speed
        obs, _, terminated, truncated, _ = env.step(np.zeros(1, dtype=np.float32))
        assert env.observation_space.contains(obs)
        peak = max(peak, abs(float(obs[OBS.YAW_ACC_REF])))
        if terminated or truncated:
            break
    env.close()
    assert peak == 1000.0   # it would exceed the box: saturated exactly at the bound


def test_ray_with_a_track_edited_during_the_run_is_a_clear_error(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """``vtrack benchmark --tracks ... --backend ray``: the Ray worker makes the parent's env id whatever the file
    holds now, so a track edited after it was registered gives the same one-line refusal as a local run (exit 2,
    no traceback, no row of the edited content)."""
    import os

    import vtrack_gym.envs.registration as registration
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.storage.store import ResultStore

    ray = pytest.importorskip("ray")
    if ray.is_initialized():
        pytest.skip("Ray is already initialised in this process")
    tracks = tmp_path / "tracks"
    tracks.mkdir()
    road = _road(tracks / "road.csv")
    real = registration.register_track

    def register_then_edit(*args, **kwargs):  # the file is saved right after the run registered it
        found = real(*args, **kwargs)
        road.write_text(road.read_text().replace("118.000", "118.500"))
        return found

    os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    ray.init(num_cpus=1, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(registration, "register_track", register_then_edit)
            code = main(["benchmark", "--tracks", str(tracks), "--policies", "stanley", "--backend", "ray",
                         "--no-figures", "--store", str(tmp_path / "s.sqlite")])
    finally:
        ray.shutdown()
    err = capsys.readouterr().err
    assert code == 2 and "changed while it was used" in err and "Traceback" not in err
    assert ResultStore(tmp_path / "s.sqlite", read_only=True).rows() == []


def test_a_crashed_ray_worker_costs_only_its_episode(tmp_path: Path) -> None:
    """On the Ray backend a worker that dies (here ``os._exit`` in the first episode's policy factory) is a lost
    episode, not a ``WorkerCrashedError`` that loses the run: the other episodes are delivered."""
    import os

    from vtrack_gym.evaluation.benchmarking.benchmark import score_episode
    from vtrack_gym.evaluation.rollouts.parallel import EpisodeTask, run_tasks
    from vtrack_gym.evaluation.rollouts.worker_pool import LostTask
    from vtrack_gym.evaluation.suite.suites import Episode

    ray = pytest.importorskip("ray")
    if ray.is_initialized():
        pytest.skip("Ray is already initialised in this process")
    marker = str(tmp_path / "crashed")

    def make(env):  # pickled by value to the Ray worker
        from vtrack_gym.baselines.registry import make_policy

        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return make_policy("stanley", env)
        os._exit(9)

    tasks = [EpisodeTask("stanley", make, Episode("DLC120-v0", seed), "custom", score_episode) for seed in (0, 1, 2)]
    os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    ray.init(num_cpus=1, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        results = run_tasks(tasks, backend="ray")
    finally:
        ray.shutdown()
    lost = [r for r in results if isinstance(r, LostTask)]
    assert len(lost) == 1 and "died" in lost[0].reason
    assert sorted(r[0].seed for r in results if not isinstance(r, LostTask)) == sorted({0, 1, 2} - {lost[0].index})
