"""`vtrack video`: MP4/GIF files with the expected frame count and size; the output path checked first."""

from __future__ import annotations

import time

import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.figures.video import check_video_path

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")


def _mp4_frames_and_size(path) -> tuple[int, tuple[int, int]]:
    n_frames, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    meta = next(imageio_ffmpeg.read_frames(str(path)))
    return n_frames, tuple(meta["size"])


def test_vtrack_video_writes_mp4_at_real_time(tmp_path, capsys) -> None:
    out = tmp_path / "dlc.mp4"
    rc = main(["video", "--policy", "lqr", "--env", "DLC120-v0", "--out", str(out), "--seconds", "2"])
    assert rc == 0, capsys.readouterr().err
    n_frames, size = _mp4_frames_and_size(out)
    assert n_frames == 51  # t = 0, 0.04, ..., 2.0 s at 25 frames/s
    assert size == (640, 384)
    assert "51 frames" in capsys.readouterr().out


def test_vtrack_video_speedup_and_side_by_side(tmp_path) -> None:
    out = tmp_path / "two.mp4"
    rc = main(["video", "--policies", "lqr,stanley", "--env", "DLC120-v0", "--out", str(out), "--seconds", "2",
               "--speedup", "2", "--width", "320", "--height", "192"])
    assert rc == 0
    n_frames, size = _mp4_frames_and_size(out)
    assert n_frames == 26  # 2 s of driving in 1 s of video
    assert size == (640, 192)  # two 320 px panels


def test_vtrack_video_overlay_gif(tmp_path) -> None:
    from PIL import Image

    out = tmp_path / "dlc.gif"
    rc = main(["video", "--policies", "lqr,stanley", "--arrangement", "overlay", "--env", "DLC120-v0", "--out",
               str(out), "--seconds", "1", "--fps", "10", "--width", "320", "--height", "128"])
    assert rc == 0
    with Image.open(out) as gif:
        assert gif.n_frames == 11
        assert gif.size == (320, 128)
        assert gif.info["duration"] == 100  # ms per frame at 10 frames/s


@pytest.mark.parametrize(("name", "message"), [("video.avi", ".mp4 or .gif"), ("missing/video.mp4", "does not exist"),
                                               ("folder.mp4", "is a folder")])
def test_output_path_checked_before_any_work(tmp_path, capsys, name, message) -> None:
    (tmp_path / "folder.mp4").mkdir()
    start = time.perf_counter()
    rc = main(["video", "--policy", "mpc", "--env", "DLC120-v0", "--out", str(tmp_path / name)])
    assert rc == 2
    assert message in capsys.readouterr().err
    assert time.perf_counter() - start < 5.0  # refused before the rollout
    with pytest.raises(ValueError, match=message.split()[0]):
        check_video_path(tmp_path / name)


def test_policy_options_checked(tmp_path, capsys) -> None:
    out = str(tmp_path / "v.mp4")
    assert main(["video", "--policy", "lqr", "--policies", "smc", "--env", "DLC120-v0", "--out", out]) == 2
    assert "exactly one of --policy" in capsys.readouterr().err
    assert main(["video", "--policy", "nope", "--env", "DLC120-v0", "--out", out]) == 2
    assert "unknown policy" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:   # out of its range: refused while parsing
        main(["video", "--policy", "lqr", "--env", "DLC120-v0", "--out", out, "--speedup", "0"])
    assert exc.value.code == 2 and "--speedup: must be a number in [0.05, 100]" in capsys.readouterr().err
