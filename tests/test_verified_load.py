"""Verify what you load, load what you verified: a `vtrack train` run folder is signed over the bytes serialised
before any file is visible, and `vtrack export --run-dir` reads each file once, checks the signature on those
bytes and loads from them (a file swapped between the check and the load is never loaded)."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")
torch = pytest.importorskip("torch")
torch.set_num_threads(1)

from vtrack_gym.cli import main  # noqa: E402

SMALL = ["--num-envs", "2", "--eval-freq", "0", "--no-progress", "--no-final-eval", "--set", "batch_size=64",
         "--set", "n_steps=32", "--set", "n_epochs=1"]


class _Payload:
    """A pickle that writes a file when loaded (what an attacker would put in a run folder)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple:
        return (Path.write_text, (self.marker, "code ran"))


@pytest.fixture(scope="module")
def trained_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One smoke-size PPO run, signed by `vtrack train` with a key of this test's own."""
    root = tmp_path_factory.mktemp("signed")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("XDG_CONFIG_HOME", str(root / "config"))
        run = root / "run"
        assert main(["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", str(run), *SMALL]) == 0
    return run


def test_train_signs_what_it_wrote(trained_run: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from vtrack_gym.agents.export import run_is_trusted

    monkeypatch.setenv("XDG_CONFIG_HOME", str(trained_run.parent / "config"))
    assert run_is_trusted(trained_run)
    assert main(["export", "--run-dir", str(trained_run), "--out", str(tmp_path / "a")]) == 0
    a, ref = np.load(tmp_path / "a.npz"), np.load(trained_run / "agent.npz")
    assert all(np.array_equal(a[k], ref[k]) for k in ref.files)
    assert not [p.name for p in trained_run.iterdir() if p.name.startswith(".")]  # no temporary file left


@pytest.mark.parametrize("swapped", ["model.zip", "vecnormalize.pkl"])
def test_file_swapped_between_check_and_load_is_never_loaded(trained_run: Path, tmp_path: Path, swapped: str,
                                                             monkeypatch: pytest.MonkeyPatch,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    """The swap happens right after the signature check, before the (seconds-long) import of SB3 and the load:
    the export loads the verified bytes, the payload never runs, and the next export refuses the folder."""
    import shutil

    import vtrack_gym.agents.export as export_module

    monkeypatch.setenv("XDG_CONFIG_HOME", str(trained_run.parent / "config"))
    run = tmp_path / "run"
    shutil.copytree(trained_run, run)
    assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "copy")]) == 2  # signed over its path
    assert "--trust" in capsys.readouterr().err
    run = trained_run  # the signed folder itself; restored at the end
    original = (run / swapped).read_bytes()
    marker = tmp_path / "pwned"
    verified = export_module.verified_run_files

    def check_then_swap(run_dir: Path, *, trust: bool = False) -> dict:
        files = verified(run_dir, trust=trust)
        (Path(run_dir) / swapped).write_bytes(pickle.dumps(_Payload(marker)))
        return files

    monkeypatch.setattr(export_module, "verified_run_files", check_then_swap)
    try:
        assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "a")]) == 0
        assert not marker.exists()
        a, ref = np.load(tmp_path / "a.npz"), np.load(run / "agent.npz")
        assert all(np.array_equal(a[k], ref[k]) for k in ref.files)
        monkeypatch.setattr(export_module, "verified_run_files", verified)
        assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "b")]) == 2
        assert "no valid vtrack-train.sig" in capsys.readouterr().err
        assert not marker.exists() and not (tmp_path / "b.json").exists()
    finally:
        (run / swapped).write_bytes(original)


def test_signing_covers_the_serialised_bytes(trained_run: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The signature matches the bytes on disk, and a file written after signing (the old window between saving
    and signing) does not match it."""
    from vtrack_gym.agents.run_signature import files_are_trusted, read_run_files

    monkeypatch.setenv("XDG_CONFIG_HOME", str(trained_run.parent / "config"))
    files = read_run_files(trained_run)
    assert files_are_trusted(trained_run, files)
    config = json.loads(files["config.json"])
    assert config["algo"] == "ppo"
    assert not files_are_trusted(trained_run, {**files, "model.zip": files["model.zip"] + b"x"})
