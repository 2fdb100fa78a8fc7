"""The output gate: every file a command writes is checked before the work (FIFO, device, symlink to a device,
symlink into a missing folder, a file of another kind, an SQLite file, a read-only folder) and written to a
temporary file that is renamed into place; a full or read-only disk is a clear error that leaves nothing behind."""

from __future__ import annotations

import errno
import os
import sqlite3
import tempfile
from pathlib import Path

import pytest

import vtrack_gym._io as io_module
from vtrack_gym._io import atomic_output, write_atomic
from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore


def _target(tmp: Path, kind: str, name: str) -> Path:
    """An output path of the given hostile kind."""
    path = tmp / name
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "device_link":
        path.symlink_to("/dev/null")
    elif kind == "full_device_link":
        path.symlink_to("/dev/full")
    elif kind == "dangling_link":
        path.symlink_to(tmp / "missing" / "deeper" / name)
    elif kind == "directory":
        path.mkdir()
    elif kind == "sqlite":
        con = sqlite3.connect(path)
        con.execute("CREATE TABLE t (x)")
        con.commit()
        con.close()
    return path


HOSTILE = ("fifo", "device_link", "full_device_link", "dangling_link", "directory", "sqlite")


def _listing(folder: Path) -> set[str]:
    return {p.name for p in folder.rglob("*")}


@pytest.mark.parametrize("kind", HOSTILE)
def test_video_out_is_checked_before_any_work(tmp_path, capsys, kind):
    out = _target(tmp_path, kind, "v.mp4")
    before = _listing(tmp_path)
    assert main(["video", "--policy", "smc", "--env", "DLC120-v0", "--seconds", "1", "--out", str(out)]) == 2
    assert "--out" in capsys.readouterr().err
    assert _listing(tmp_path) == before                      # nothing created, no folder of a link's target


@pytest.mark.parametrize("kind", HOSTILE)
def test_leaderboard_and_preset_outputs_refuse_hostile_targets(tmp_path, kind):
    out = _target(tmp_path, kind, "board.md")
    before = _listing(tmp_path)
    with pytest.raises(ValueError, match="--out"):
        write_atomic(out, "text", "--out")
    assert _listing(tmp_path) == before


def test_video_on_a_full_disk_says_so_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    from vtrack_gym.evaluation.figures import video

    add = video._Writer.add

    def fill_up(self, frame):
        if self.frames >= 3:
            raise OSError(errno.ENOSPC, "No space left on device")
        add(self, frame)

    monkeypatch.setattr(video._Writer, "add", fill_up)
    out = tmp_path / "v.mp4"
    assert main(["video", "--policy", "smc", "--env", "DLC120-v0", "--seconds", "2", "--out", str(out)]) == 2
    assert "disk is full" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_outputs_in_a_read_only_folder_are_refused_before_the_work(tmp_path, capsys, monkeypatch):
    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(io_module.tempfile, "mkstemp", read_only)
    assert main(["video", "--policy", "smc", "--env", "DLC120-v0", "--seconds", "1",
                 "--out", str(tmp_path / "v.mp4")]) == 2
    assert "Read-only file system" in capsys.readouterr().err
    assert main(["plot", "--policies", "smc", "--env", "DLC120-v0", "--out", str(tmp_path / "figs")]) == 2
    assert "Read-only file system" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_plot_on_a_full_disk_says_so_and_leaves_no_empty_folder(tmp_path, capsys, monkeypatch):
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", full)
    figs = tmp_path / "figs" / "deeper"
    assert main(["plot", "--policies", "smc", "--env", "DLC120-v0", "--out", str(figs)]) == 2
    assert "disk is full" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


class _FullFile:
    """A file whose writes fail as on a full disk."""

    def __init__(self, *args, **kwargs) -> None:
        self._fh = open(*args, **kwargs)

    def write(self, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._fh.close()


def test_leaderboard_out_on_a_full_disk_keeps_the_old_file(tmp_path, capsys, monkeypatch):
    store = tmp_path / "s.sqlite"
    ResultStore(store).add([ResultRow("paper", "DLC120-v0", "mpc", "abc", 0, {"max_e_y_m": 0.1}, "completed", 1e-5)])
    board = tmp_path / "board.md"
    board.write_text("the previous board\n")
    monkeypatch.setattr(io_module, "open", _FullFile, raising=False)
    assert main(["leaderboard", "--store", str(store), "--out", str(board)]) == 2
    assert "disk is full" in capsys.readouterr().err
    assert board.read_text() == "the previous board\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["board.md", "s.sqlite"]


def test_atomic_output_never_shows_a_half_written_file(tmp_path):
    target = tmp_path / "sub" / "f.txt"
    with pytest.raises(RuntimeError), atomic_output(target) as tmp:
        tmp.write_text("half")
        assert not target.exists()
        raise RuntimeError("the writer died")
    assert not (tmp_path / "sub").exists()
    with atomic_output(target) as tmp:
        tmp.write_text("whole")
    assert target.read_text() == "whole" and _listing(tmp_path) == {"sub", "f.txt"}


def test_train_refuses_a_symlinked_logs_folder(tmp_path, capsys):
    elsewhere = Path(tempfile.mkdtemp(dir=tmp_path))
    run = tmp_path / "run"
    run.mkdir()
    (run / "logs").symlink_to(elsewhere)
    assert main(["train", "--algo", "ppo", "--timesteps", "10", "--run-dir", str(run)]) == 2
    assert "logs is a symbolic link" in capsys.readouterr().err
    assert list(elsewhere.iterdir()) == []


TRAIN_FAST = ["--algo", "ppo", "--timesteps", "64", "--num-envs", "2", "--no-progress", "--no-final-eval",
              "--set", "n_steps=32", "--set", "batch_size=64", "--set", "n_epochs=1"]
"""A smoke-size `vtrack train` (one 64-transition PPO rollout)."""


@pytest.mark.parametrize("name", ["progress.csv", "log.txt"])
@pytest.mark.parametrize("kind", HOSTILE)
def test_train_refuses_hostile_logger_files_before_training(tmp_path, capsys, name, kind):
    """SB3's logger opens logs/progress.csv and logs/log.txt by name (a FIFO would block it for ever, a device
    link swallow the logs): each passes the output gate's check before anything is trained or written."""
    run = tmp_path / "run"
    (run / "logs").mkdir(parents=True)
    _target(run / "logs", kind, name)
    before = _listing(tmp_path)
    assert main(["train", *TRAIN_FAST, "--eval-freq", "0", "--run-dir", str(run)]) == 2
    assert "--run-dir" in capsys.readouterr().err
    assert _listing(tmp_path) == before


@pytest.mark.parametrize("checkpoint", ["best_model.zip", "model.zip"])
def test_train_checkpoints_on_a_full_disk_say_so_and_leave_no_partial_file(tmp_path, capsys, monkeypatch,
                                                                          checkpoint):
    """The best checkpoint (``best_model.zip``, saved at a periodic evaluation) and the final ``model.zip`` are
    written through the gate: a full disk while SB3 saves them is a one-line error and leaves no partial or
    temporary checkpoint. (The final ``model.zip`` is serialised in memory and signed before it is written: the
    disk fills while its bytes are written.)"""
    from stable_baselines3.common.base_class import BaseAlgorithm

    import vtrack_gym._io as io_module

    def full(self, path, *args, **kwargs):
        Path(path).write_bytes(b"half a checkpoint")
        raise OSError(errno.ENOSPC, "No space left on device")

    publish = io_module._publish

    def full_at_model_zip(tmp, target, label):
        if Path(target).name != "model.zip":
            return publish(tmp, target, label)
        Path(tmp).write_bytes(b"half a checkpoint")
        raise OSError(errno.ENOSPC, "No space left on device")

    import vtrack_gym.agents.train as train_module

    if checkpoint == "best_model.zip":
        monkeypatch.setattr(BaseAlgorithm, "save", full)
    else:
        monkeypatch.setattr(io_module, "_publish", full_at_model_zip)
    monkeypatch.setattr(train_module, "selection_score", lambda results: 0.1)  # a new best at the evaluation
    run = tmp_path / "run"
    freq = "64" if checkpoint == "best_model.zip" else "0"
    assert main(["train", *TRAIN_FAST, "--eval-freq", freq, "--case1-max-steps", "20", "--run-dir", str(run)]) == 2
    err = capsys.readouterr().err
    assert f"--run-dir {run / checkpoint}: could not write the file (the disk is full)" in err
    assert not (run / checkpoint).exists()
    assert [p.name for p in run.iterdir() if p.name.endswith(".tmp.zip") or ".tmp" in p.name] == []


def test_train_logger_on_a_full_disk_is_a_one_line_error(tmp_path, capsys, monkeypatch):
    """SB3's logger files grow while training runs (written in place, checked before): a full disk while it
    writes them ends `vtrack train` with exit 2 naming the run folder, not a traceback."""
    from stable_baselines3.common.logger import CSVOutputFormat

    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(CSVOutputFormat, "write", full)
    run = tmp_path / "run"
    assert main(["train", *TRAIN_FAST, "--eval-freq", "0", "--run-dir", str(run)]) == 2
    err = capsys.readouterr().err
    assert f"--run-dir {run / 'logs'}: could not write (the disk is full)" in err


def test_train_evaluations_are_written_whole_through_the_gate(tmp_path):
    """``evaluations.jsonl`` is rewritten whole through the gate at each evaluation (never appended to in
    place): after a run it holds one JSON line per evaluation and no temporary file is left."""
    import json

    run = tmp_path / "run"
    assert main(["train", *TRAIN_FAST, "--eval-freq", "32", "--case1-max-steps", "20", "--run-dir", str(run)]) == 0
    lines = (run / "evaluations.jsonl").read_text().splitlines()
    assert len(lines) >= 1 and all("selection_score" in json.loads(line) for line in lines)
    assert [p.name for p in run.rglob("*") if ".tmp" in p.name] == []
