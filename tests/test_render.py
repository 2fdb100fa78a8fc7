"""Top-down rendering: frames show the car on the track, frame rates, render modes, RecordVideo, colours."""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.envs import render as R
from vtrack_gym.envs.palette import FALLBACK_COLOURS, hex_to_rgb, policy_colour


def test_follow_frame_shows_the_car_on_the_road() -> None:
    env = gym.make("DLC120-v0", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(250):  # 2.5 s at 120 km/h: ~83 m down the straight, the first gate (100-130 m) ahead
        env.step(np.zeros(1, dtype=np.float32))
    frame = env.render()
    h, w, _ = frame.shape
    assert (h, w) == (384, 640) and frame.dtype == np.uint8
    car = np.all(frame == hex_to_rgb("#1f77b4"), axis=-1)  # the default car colour
    ys, xs = np.nonzero(car)
    assert car.sum() > 100  # 4.75 m x 1.9 m at 640 px / 60 m: ~ 50 x 20 px minus the outline and windscreen
    assert abs(xs.mean() - w / 2) < 10 and abs(ys.mean() - h / 2) < 10  # the follow camera centres the car
    # road under and around the car (between the edges), grass well above and below the 8 m wide road
    road = np.all(frame == R.ROAD, axis=-1)
    assert road[h // 2 + 25, w // 2 - 60] and road[h // 2 - 25, w // 2 + 60]  # 2.3 m off the centre-line
    assert np.all(frame[h // 2 - 100, w // 2] == R.GRASS) and np.all(frame[h // 2 + 100, w // 2] == R.GRASS)
    assert np.all(frame == R.CONE, axis=-1).sum() > 20  # the first gate's cones
    env.close()


def test_car_moves_in_the_whole_track_view() -> None:
    env = gym.make("DLC120-v0", render_mode="rgb_array", render_view="track")
    env.reset(seed=0)
    colour = hex_to_rgb("#1f77b4")
    x0 = np.nonzero(np.all(env.render() == colour, axis=-1))[1].mean()
    for _ in range(100):
        env.step(np.zeros(1, dtype=np.float32))
    x1 = np.nonzero(np.all(env.render() == colour, axis=-1))[1].mean()
    renderer = R.TopDownRenderer(env.unwrapped.current_path, env.unwrapped.config.vehicle.chassis,
                                 R.RenderConfig(view="track"))
    expected_px = (env.unwrapped._sim.plant.state[0, 0] - 0.0) * renderer.px_per_m  # ~33 m driven in 1 s
    assert x1 - x0 == pytest.approx(expected_px, abs=3.0)
    env.close()


def test_render_fps_is_configurable_and_checked() -> None:
    env = gym.make("DLC120-v0", render_mode="rgb_array", render_fps=30)
    assert env.metadata["render_fps"] == 30
    assert gym.make("DLC120-v0").metadata["render_fps"] == 25
    with pytest.raises(ValueError, match="render_fps"):
        gym.make("DLC120-v0", render_fps=0)
    with pytest.raises(ValueError, match="view"):
        gym.make("DLC120-v0", render_view="cockpit")


def test_rgb_array_list_takes_frames_at_render_fps_not_every_step() -> None:
    env = gym.make("DLC120-v0", render_mode="rgb_array_list", render_fps=25)
    env.reset(seed=0)
    for _ in range(100):  # 1 s of driving at 100 Hz
        env.step(np.zeros(1, dtype=np.float32))
    frames = env.render()
    assert len(frames) == 26  # t = 0, 0.04, ..., 1.00 s
    assert all(f.shape == (384, 640, 3) for f in frames)
    assert not np.array_equal(frames[0], frames[-1])
    assert env.render() == []  # collected frames are handed out once
    env.close()


def test_record_video_wrapper_writes_real_time_video(tmp_path) -> None:
    pytest.importorskip("moviepy")
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    from gymnasium.wrappers import RecordVideo

    env = gym.make("DLC120-v0", render_mode="rgb_array_list", max_episode_steps=150)
    env = RecordVideo(env, str(tmp_path / "videos"), episode_trigger=lambda e: True, name_prefix="dlc")
    env.reset(seed=0)
    done = False
    with pytest.warns(UserWarning):  # Gymnasium notes the control steps that take no frame
        while not done:
            _, _, term, trunc, _ = env.step(np.zeros(1, dtype=np.float32))
            done = term or trunc
    env.close()
    files = list((tmp_path / "videos").glob("dlc-episode-0.mp4"))
    assert len(files) == 1
    n_frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(files[0]))
    assert n_frames == 1 + 150 // 4  # 1.5 s of driving at 25 frames/s, plus the reset frame
    assert seconds == pytest.approx(1.5 + 1 / 25, abs=0.05)  # real time
    meta = next(imageio_ffmpeg.read_frames(str(files[0])))
    assert tuple(meta["size"]) == (640, 384)


def test_human_mode_headless_names_what_is_missing(monkeypatch) -> None:
    if not sys.platform.startswith("linux"):
        pytest.skip("the display check is for X11/Wayland")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(R.RenderUnavailable, match=r"\$DISPLAY"):
        gym.make("DLC120-v0", render_mode="human")


def test_human_mode_shows_frames_at_render_fps(monkeypatch) -> None:
    shown: list[np.ndarray] = []

    class FakeWindow:
        def __init__(self, title: str, fps: int) -> None:
            self.title, self.fps = title, fps

        def show(self, frame: np.ndarray) -> None:
            shown.append(frame)

        def close(self) -> None:
            pass

    monkeypatch.setattr(R, "display_problem", lambda: None)
    monkeypatch.setattr(R, "HumanWindow", FakeWindow)
    env = gym.make("DLC120-v0", render_mode="human", render_fps=20)
    env.reset(seed=0)
    for _ in range(50):
        env.step(np.zeros(1, dtype=np.float32))
    assert len(shown) == 11  # t = 0, 0.05, ..., 0.5 s: not one per 10 ms step
    env.close()


def test_vector_env_renders_every_car() -> None:
    envs = gym.make_vec("DLC120-v0", num_envs=2, vectorization_mode="vector_entry_point", render_mode="rgb_array")
    envs.reset(seed=0)
    frames = envs.render()
    assert len(frames) == 2 and all(f.shape == (384, 640, 3) for f in frames)
    envs.close()


def test_frame_clock_and_scale_bar_length() -> None:
    clock = R.FrameClock(25)
    due = [clock.due(k * 0.01) for k in range(101)]
    assert sum(due) == 26 and due[0] and due[4] and not due[3]
    assert [R.nice_length(x) for x in (0.7, 1.0, 13.0, 27.0, 99.0, 120.0)] == [0.5, 1.0, 10.0, 20.0, 50.0, 100.0]


def test_render_config_validation() -> None:
    with pytest.raises(ValueError, match="width_px"):
        R.RenderConfig(width_px=641)
    with pytest.raises(ValueError, match="view_width_m"):
        R.RenderConfig(view_width_m=1.0)


def test_policy_colours_are_stable_and_distinct() -> None:
    names = ["smc", "mpc", "lqr", "stanley", "pure_pursuit", "mpc_osqp", "ppo", "sac", "td3"]
    assert len({policy_colour(n) for n in names}) == len(names)
    assert policy_colour("mpc_tuned") == policy_colour("mpc") != policy_colour("mpc_osqp")
    assert policy_colour("SMC (paper)") == policy_colour("smc")
    assert policy_colour("my_agent") == policy_colour("my_agent")
    assert policy_colour("smcx") in FALLBACK_COLOURS  # a prefix counts only up to a separator


def test_human_window_shows_frames_and_survives_being_closed(monkeypatch) -> None:
    """The Tk window code path with stand-ins for tkinter and ImageTk (no display on the test machine)."""
    import types

    class TclError(Exception):
        pass

    events: list[str] = []

    class Tk:
        def title(self, text: str) -> None:
            events.append(f"title {text}")

        def update(self) -> None:
            if len(events) > 3:
                raise TclError("application has been destroyed")  # the user closed the window
            events.append("update")

        def destroy(self) -> None:
            events.append("destroy")

    class Label:
        def __init__(self, root: Tk) -> None:
            pass

        def pack(self) -> None:
            pass

        def configure(self, image: object) -> None:
            events.append(f"image {image.size}")

    tk = types.SimpleNamespace(Tk=Tk, Label=Label, TclError=TclError)
    image_tk = types.SimpleNamespace(PhotoImage=lambda img: img)
    monkeypatch.setitem(sys.modules, "tkinter", tk)
    monkeypatch.setattr("PIL.ImageTk", image_tk, raising=False)
    monkeypatch.setitem(sys.modules, "PIL.ImageTk", image_tk)
    monkeypatch.setattr(R, "display_problem", lambda: None)
    window = R.HumanWindow("DLC120-v0", fps=1000)
    frame = np.zeros((96, 128, 3), dtype=np.uint8)
    window.show(frame)
    assert events == ["title DLC120-v0", "image (128, 96)", "update"]
    window.show(frame)
    window.show(frame)  # update() raised: the window is marked closed, no exception reaches the env
    assert window.closed
    window.show(frame)  # a no-op once closed
    window.close()
    assert "destroy" not in events
