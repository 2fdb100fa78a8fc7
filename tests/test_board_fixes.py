"""Evaluation and leaderboard fixes, each through a user's entry point (``vtrack_gym.evaluate``, ``cli.main``,
``ResultStore``): --out never touches a store, provenance of env objects, non-standard seed sets, canonical policy
ids, PEP 440 version order, row validation, the store checked before any rollout, ``benchmark --track`` options."""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore


def make_row(policy: str = "mpc", seed: int = 0, e_y: float = 0.1, **kw) -> ResultRow:
    fields = {"suite": "paper", "env_id": "DLC120-v0", "policy_id": policy, "policy_hash": "h", "seed": seed,
              "metrics": {"max_e_y_m": e_y}, "termination": "completed", "wall_time_per_step_s": 1e-5}
    fields.update(kw)
    return ResultRow(**fields)


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# --------------------------------------------------------------------------------------------- 1: leaderboard --out
def test_leaderboard_out_never_overwrites_the_store_or_a_database(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "s.sqlite"
    ResultStore(store).add([make_row()])
    other = tmp_path / "other.sqlite"
    ResultStore(other).add([make_row("smc")])
    before = {p: digest(p) for p in (store, other)}
    link = tmp_path / "link.md"
    link.symlink_to(store)
    for out in (store, tmp_path / "s.sqlite-wal", tmp_path / "s.sqlite-shm", tmp_path / "s.sqlite-journal",
                tmp_path / "." / "s.sqlite", link, other):
        assert main(["leaderboard", "--store", str(store), "--out", str(out)]) == 2, out
        err = capsys.readouterr().err
        assert "--out" in err and "error" in err
    assert {p: digest(p) for p in (store, other)} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.md", "other.sqlite", "s.sqlite"]
    assert main(["leaderboard", "--store", str(store), "--out", str(tmp_path / "board.md")]) == 0
    assert "| DLC120-v0 | mpc |" in (tmp_path / "board.md").read_text()


# --------------------------------------------------------------------------------------------- 2: env instances
class Straight:
    """Wheel straight ahead (SB3 predict signature): cheap, and its result does not matter here."""

    policy_id = "straight"

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.zeros(1, dtype=np.float32), state


def write_track(path: Path, bend_m: float) -> Path:
    path.write_text(f"x_m,y_m\n0,0\n40,0\n80,{bend_m:g}\n120,{bend_m:g}\n")
    return path


def test_env_instances_record_their_car_and_track(tmp_path: Path) -> None:
    import gymnasium as gym

    import vtrack_gym

    store = tmp_path / "s.sqlite"
    a, b = write_track(tmp_path / "a.csv", 3.0), write_track(tmp_path / "b.csv", -3.0)
    envs = {"default": gym.make("DLC120-v0"), "suv": gym.make("DLC120-v0", vehicle="suv"),
            "a": gym.make("vtrack/Track-v0", track=str(a)), "b": gym.make("vtrack/Track-v0", track=str(b)),
            "a8": gym.make("vtrack/Track-v0", track=str(a), speed_profile=8.0)}
    rows = {k: vtrack_gym.evaluate(Straight(), env, store=store)[0] for k, env in envs.items()}
    assert rows["default"].env_id == rows["suv"].env_id == "DLC120-v0"
    assert rows["default"].options == {} and rows["suv"].options == {"vehicle": "suv"}
    assert len({rows[k].env_id for k in ("a", "b", "a8")}) == 3
    assert rows["a"].options["track_file"] == "a.csv"
    assert rows["a"].options["track_sha256"] == hashlib.sha256(a.read_bytes()).hexdigest()
    assert rows["a8"].options["speed_profile"] == {"kind": "ConstantSpeed", "v_mps": 8.0}
    board = ResultStore(store, read_only=True).leaderboard("custom", ["max_e_y_m"])
    assert len(board) == 5 and all(e["episodes"] == 1 for e in board)
    # the same track file and profile through `vtrack eval --track` lands in the same entry as the env instance
    # (Track-v0's registered default is the per-axis profile, the CLI's default the envelope one: another entry)
    assert main(["eval", "--policy", "lqr", "--track", str(a), "--speed-profile", "curvature",
                 "--store", str(store)]) == 0
    cli_row = next(r for r in ResultStore(store).rows("custom") if r["policy_id"] == "lqr")
    assert cli_row["env_id"] == rows["a"].env_id and cli_row["options"] == rows["a"].options
    assert main(["eval", "--policy", "stanley", "--track", str(a), "--store", str(store)]) == 0
    default_row = next(r for r in ResultStore(store).rows("custom") if r["policy_id"] == "stanley")
    assert default_row["env_id"] != rows["a"].env_id
    assert default_row["options"]["speed_profile"]["kind"] == "EnvelopeLimited"


def test_env_instance_configuration_never_merges_silently(tmp_path: Path) -> None:
    import gymnasium as gym
    from gymnasium.wrappers import ClipAction

    import vtrack_gym
    from vtrack_gym.envs.tracking_env import TrackingEnv

    slow = vtrack_gym.evaluate(Straight(), gym.make("DLC120-v0", control_period_s=0.02))[0]
    assert slow.env_id == "DLC120-v0" and slow.options == {"env_config": {"control_period_s": 0.02}}
    wrapped = vtrack_gym.evaluate(Straight(), ClipAction(gym.make("DLC120-v0")))[0]
    assert wrapped.options["wrappers"][0]["name"] == "ClipAction"
    bare = vtrack_gym.evaluate(Straight(), TrackingEnv("DLC120-v0"))[0]
    assert re.search(r" \[unidentified configuration [0-9a-f]{8}\]$", bare.env_id)


# --------------------------------------------------------------------------------------------- 3: seed sets
def test_suite_labels_of_seed_sets() -> None:
    from vtrack_gym.evaluation.suite.suites import primary_metric, suite_label

    assert suite_label("robust") == "robust" and suite_label("robust", seeds=[505, 101, 202, 303, 404]) == "robust"
    assert suite_label("robust", seeds=[7]) == "robust[seeds=7]"
    assert suite_label("robust", quick=True) == "robust[quick]"
    assert suite_label("paper", quick=True) == "paper" and suite_label("paper", seeds=[0]) == "paper"
    assert suite_label("paper", seeds=[3, 0, 1, 2, 9]) == "paper[seeds=0-3,9]"
    assert primary_metric("highway[seeds=1]") == "itae"


def test_benchmark_with_other_seeds_is_ranked_apart(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "s.sqlite"
    common = ["benchmark", "--suite", "robust", "--policies", "stanley", "--no-figures", "--store", str(store)]
    assert main([*common, "--seeds", "7"]) == 0
    assert "robust[seeds=7]" in capsys.readouterr().err
    assert main([*common, "--quick"]) == 0
    assert "robust[quick]" in capsys.readouterr().err
    assert ResultStore(store).suites() == {"robust[quick]": 2, "robust[seeds=7]": 2}
    assert main(["leaderboard", "--store", str(store), "--suite", "robust"]) == 2  # no standard rows yet
    assert "robust[seeds=7]" in capsys.readouterr().err
    assert main(["leaderboard", "--store", str(store), "--suite", "robust[seeds=7]", "--format", "csv"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 3
    rows = __import__("vtrack_gym").evaluate(Straight(), "paper", seeds=[5])
    assert {r.suite for r in rows} == {"paper[seeds=5]"}


# --------------------------------------------------------------------------------------------- 4: policy ids
def test_eval_policy_spellings_share_one_id(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "s.sqlite"
    spellings = [["--policy", "lqr"], ["--policy", "lqr:"], ["--policy", "lqr:default"],
                 ["--policy", "lqr", "--preset", "default"]]
    for spelling in spellings:
        assert main(["eval", *spelling, "--env", "DLC120-v0", "--store", str(store)]) == 0
    assert {r["policy_id"] for r in ResultStore(store).rows()} == {"lqr"}
    board = ResultStore(store).leaderboard("custom", ["max_e_y_m"], latest_only=False)
    assert len(board) == 1 and board[0]["episodes"] == len(spellings)


def test_canonical_preset_ids() -> None:
    from vtrack_gym.baselines.resolve import canonical_spec

    assert canonical_spec("smc:paper") == canonical_spec("smc", "paper") == "smc:paper"
    assert canonical_spec("smc:") == canonical_spec("smc:default") == canonical_spec("smc", "default") == "smc"
    # an agent file is named by its stem (its identity is its content): every path to it is one id
    assert canonical_spec("agent.json") == canonical_spec("runs/a/agent.json") == canonical_spec("/x/agent.npz") \
        == "agent"


def test_benchmark_scores_a_duplicate_once_and_accepts_spaces(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                               caplog: pytest.LogCaptureFixture) -> None:
    store = tmp_path / "s.sqlite"
    with caplog.at_level("WARNING"):
        assert main(["benchmark", "--policies", "lqr,lqr:default", "--no-figures", "--store", str(store)]) == 0
    assert "'lqr' and 'lqr:default' are the same policy 'lqr': scored once" in caplog.text
    assert [r["policy_id"] for r in ResultStore(store).rows()] == ["lqr", "lqr"]   # one episode per env
    assert main(["benchmark", "--policies", "stanley, lqr", "--no-figures", "--format", "csv",
                 "--store", str(store)]) == 0
    assert {r["policy_id"] for r in ResultStore(store).rows()} == {"stanley", "lqr"}


# --------------------------------------------------------------------------------------------- 5: PEP 440 order
PEP440_ORDER = ["0.0.9", "0.1.0.dev1", "0.1.0a1", "0.1.0a2.dev1", "0.1.0a2", "0.1.0b1", "0.1.0rc1", "0.1.0",
                "0.1.0+local", "0.1.0+local.1", "0.1.0+local.2", "0.1.0.post1.dev2", "0.1.0.post1", "0.1.0.post2",
                "0.1.1.dev0", "0.1.1", "0.10.0", "1!0.0.1"]


def test_version_sort_key_is_pep440() -> None:
    from vtrack_gym.evaluation.storage.store import version_sort_key

    keys = [version_sort_key(v) for v in PEP440_ORDER]
    assert keys == sorted(keys) and len(set(keys)) == len(keys)
    assert version_sort_key("1.0") == version_sort_key("1.0.0") == version_sort_key("v1.0")
    assert version_sort_key("1.0-1") == version_sort_key("1.0.post1")
    assert version_sort_key("not a version") < version_sort_key("0.0.0.dev0")


@pytest.mark.parametrize(("older", "newer"), [("0.1.0", "0.1.0.post1"), ("0.1.0", "0.1.0+local"),
                                              ("0.1.0rc1", "0.1.0.post1"), ("0.1.0.dev3", "0.1.0a1")])
def test_board_shows_the_newest_version_and_says_what_it_hides(tmp_path: Path, older: str, newer: str,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "s.sqlite"
    ResultStore(store).add([make_row("mpc", 0, 0.5, package_version=newer),
                            make_row("mpc", 0, 0.1, package_version=older),
                            make_row("smc", 0, 0.2, package_version=older)])
    board = ResultStore(store, read_only=True).leaderboard("paper", ["max_e_y_m"])
    assert [(e["policy_id"], e["max_e_y_m"]) for e in board] == [("mpc", 0.5)]
    assert main(["leaderboard", "--store", str(store)]) == 0
    err = capsys.readouterr().err
    assert f"({newer})" in err and "2 row(s) of older versions are hidden" in err and "--all-versions" in err
    assert main(["leaderboard", "--store", str(store), "--all-versions"]) == 0
    assert "hidden" not in capsys.readouterr().err


# --------------------------------------------------------------------------------------------- 6: row validation
@pytest.mark.parametrize(("change", "field"), [
    ({"success": "False"}, "success"), ({"success": 2}, "success"), ({"seed": -1}, "seed"),
    ({"seed": 2**63}, "seed"), ({"seed": 1.5}, "seed"), ({"seed": True}, "seed"),
    ({"metrics": {"max_e_y_m": -5.0}}, "max_e_y_m"), ({"metrics": {"max_e_y_m": "0.1"}}, "max_e_y_m"),
    ({"metrics": {"itae": -1}}, "itae"), ({"metrics": {"cones_hit": -1.0}}, "cones_hit"),
    ({"metrics": {"duration_s": -0.5}}, "duration_s"), ({"metrics": {"comfort_band": [3.0]}}, "comfort_band"),
    ({"metrics": {"rms_e_y_m": [0.1]}}, "rms_e_y_m"), ({"wall_time_per_step_s": "1e-5"}, "wall_time_per_step_s"),
])
def test_store_refuses_invalid_rows_and_keeps_the_others(tmp_path: Path, change: dict, field: str) -> None:
    store = ResultStore(tmp_path / "s.sqlite")
    store.add([make_row("mpc")])
    with pytest.raises(ValueError, match=field):
        store.add([make_row("smc"), make_row("lqr", **change)])
    assert [r["policy_id"] for r in store.rows()] == ["mpc"]


def test_store_accepts_valid_edge_values(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "s.sqlite")
    store.add([make_row("a", 2**63 - 1, success=np.bool_(True)), make_row("b", np.int64(3), success=0),
               make_row("c", None, metrics={"max_e_y_m": float("nan"), "progress_m": -1.0, "comfort_band": "n/a",
                                            "min_fz_n": -10.0, "itae": np.float64(0.0)}, success=1)])
    rows = {r["policy_id"]: r for r in store.rows()}
    assert rows["a"]["seed"] == 2**63 - 1 and rows["a"]["success"] == 1 and rows["b"]["success"] == 0
    assert rows["c"]["metrics"]["max_e_y_m"] is None and rows["c"]["metrics"]["comfort_band"] == "n/a"


# --------------------------------------------------------------------------------------------- 7: store first
class Counting(Straight):
    """``Straight`` that counts its predictions (none may happen when the store is unusable)."""

    def __init__(self) -> None:
        self.calls = 0

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.calls += 1
        return super().predict(observation, state, episode_start, deterministic)


def bad_stores(tmp_path: Path) -> dict[str, Path]:
    text = tmp_path / "notes.txt"
    text.write_text("not a store\n")
    truncated = tmp_path / "truncated.sqlite"
    ResultStore(truncated).add([make_row(seed=s) for s in range(50)])
    truncated.write_bytes(truncated.read_bytes()[:1500])
    return {"directory": tmp_path, "text": text, "truncated": truncated}


def test_evaluate_checks_the_store_before_the_first_rollout(tmp_path: Path) -> None:
    import vtrack_gym
    from vtrack_gym.evaluation.storage.store import StoreError

    for kind, path in bad_stores(tmp_path).items():
        before = None if path.is_dir() else digest(path)
        policy = Counting()
        with pytest.raises(StoreError):
            vtrack_gym.evaluate(policy, "DLC120-v0", store=path)
        assert policy.calls == 0, kind
        assert before is None or digest(path) == before
    with pytest.raises(StoreError, match="read-only"):
        vtrack_gym.evaluate(Counting(), "DLC120-v0", store=ResultStore(bad_stores_ok(tmp_path), read_only=True))


def bad_stores_ok(tmp_path: Path) -> Path:
    path = tmp_path / "ok.sqlite"
    ResultStore(path).add([make_row()])
    return path


def test_cli_checks_the_store_before_the_first_rollout(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for path in bad_stores(tmp_path).values():
        for argv in (["eval", "--policy", "lqr", "--env", "DLC120-v0"], ["benchmark", "--policies", "lqr",
                                                                          "--no-figures"]):
            assert main([*argv, "--store", str(path)]) == 2
            captured = capsys.readouterr()
            assert captured.out == "" and "error" in captured.err


READ_ONLY_SCRIPT = """
import os, sys
import vtrack_gym
from vtrack_gym.evaluation.storage.store import StoreError
from vtrack_gym.cli import main

class Never:
    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        raise AssertionError("a rollout ran before the store was checked")

for store in sys.argv[1:]:
    try:
        vtrack_gym.evaluate(Never(), "DLC120-v0", store=store)
    except StoreError as exc:
        assert "cannot be written" in str(exc), exc
    else:
        raise AssertionError("no StoreError")
    assert main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--store", store]) == 2
print("ok")
"""


def test_read_only_store_is_refused_first_and_left_alone() -> None:
    """Run as an unprivileged user (root may write a read-only file): a read-only file, and a store in a read-only
    folder, are refused before any rollout and no -wal/-shm file appears."""
    import os
    import shutil
    import subprocess
    import sys
    import tempfile

    prefix: list[str] = []
    if os.geteuid() == 0:
        if shutil.which("setpriv") is None:
            pytest.skip("needs setpriv to drop root")
        prefix = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
        probe = subprocess.run([*prefix, sys.executable, "-c", "import numpy, gymnasium"], capture_output=True,
                               text=True, env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])},
                               cwd="/", timeout=120)
        if probe.returncode != 0:
            pytest.skip("the unprivileged user cannot read this Python environment (a venv in a private folder)")
    root = Path(tempfile.mkdtemp(prefix="vtrack-ro-"))
    try:
        os.chmod(root, 0o777)
        writable, locked = root / "w", root / "locked"
        writable.mkdir()
        locked.mkdir()
        for folder in (writable, locked):
            ResultStore(folder / "s.sqlite").add([make_row()])
            os.chmod(folder / "s.sqlite", 0o444 if folder is writable else 0o666)
            for suffix in ("-wal", "-shm"):
                (folder / f"s.sqlite{suffix}").unlink(missing_ok=True)
        os.chmod(writable, 0o777)
        os.chmod(locked, 0o555)
        before = sorted(p.name for p in root.rglob("*"))
        env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1]), "HOME": str(root),
               "NUMBA_CACHE_DIR": str(root / "numba")}
        done = subprocess.run([*prefix, sys.executable, "-c", READ_ONLY_SCRIPT, str(writable / "s.sqlite"),
                               str(locked / "s.sqlite")], capture_output=True, text=True, env=env, timeout=300)
        assert done.returncode == 0 and "ok" in done.stdout, done.stderr[-2000:]
        after = sorted(p.name for p in root.rglob("*") if "numba" not in p.parts)
        assert [n for n in after if n.endswith(("-wal", "-shm"))] == []
        assert [n for n in after if n != "numba"] == [n for n in before if n != "numba"]
    finally:
        os.chmod(root / "locked", 0o755) if (root / "locked").exists() else None
        shutil.rmtree(root, ignore_errors=True)


# --------------------------------------------------------------------------------------------- 8: benchmark --track
def test_benchmark_track_honours_seeds_and_refuses_suite_and_quick(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    track = write_track(tmp_path / "a.csv", 3.0)
    store = tmp_path / "s.sqlite"
    common = ["benchmark", "--policies", "stanley", "--track", str(track), "--no-figures", "--store", str(store)]
    for extra, named in ((["--suite", "robust"], "--suite"), (["--quick"], "--quick"),
                         (["--suite", "paper", "--quick"], "--suite and --quick")):
        assert main([*common, *extra]) == 2
        assert named in capsys.readouterr().err and not store.exists()
    assert main([*common, "--seeds", "0-2", "--format", "json"]) == 0
    assert sorted(r["seed"] for r in ResultStore(store).rows("custom")) == [0, 1, 2]
    assert main([*common, "--format", "json"]) == 0
    assert sorted(r["seed"] for r in ResultStore(store).rows("custom")) == [0, 0, 1, 2]
