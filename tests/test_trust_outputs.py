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
from vtrack_gym.evaluation.store import ResultRow, ResultStore


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
    from vtrack_gym.evaluation import video

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
