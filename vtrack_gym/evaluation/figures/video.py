"""Videos of policies driving a scenario (``vtrack video``): MP4 through imageio's ffmpeg plugin, GIF through Pillow.

Frames are taken at ``fps`` of video time; ``speedup`` > 1 packs that many seconds of driving into one second of
video. Several policies drive the same scenario and seed, side by side (one panel each) or overlaid (all cars in
one frame, the camera on the first).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from vtrack_gym.envs import render as R
from vtrack_gym.envs.palette import FALLBACK_COLOURS, KNOWN_POLICY_COLOURS, hex_to_rgb, policy_colour
from vtrack_gym.envs.render import CarView, FrameClock, RenderConfig, TopDownRenderer
from vtrack_gym.evaluation.rollouts.rollout import step_action

VIDEO_SUFFIXES: tuple[str, ...] = (".mp4", ".gif")
ARRANGEMENTS: tuple[str, ...] = ("side", "overlay")
TRAIL_POINTS = 75  # frames of trail drawn behind each car
MAX_GIF_FRAMES = 3000  # a GIF is assembled in memory: longer videos should be MP4


_SCENE_COLOURS: list[tuple[int, int, int]] = [
    *(hex_to_rgb(c) for c in (*KNOWN_POLICY_COLOURS.values(), *FALLBACK_COLOURS)),
    R.GRASS, R.ROAD, R.EDGE, R.REFERENCE, R.CONE, R.PREVIEW, R.TEXT, R.PANEL]


def check_video_path(out: str | Path) -> Path:
    """``out`` as a Path if a video can be written there: suffix .mp4/.gif, parent folder exists, and the output
    gate's checks (``vtrack_gym._io.check_output_file``: not a folder, FIFO, device, symlink to one, symlink into a
    missing folder or SQLite file; a folder the process can write)."""
    from vtrack_gym._io import check_output_file

    p = Path(out)
    if p.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"--out must end in {' or '.join(VIDEO_SUFFIXES)} (got {str(out)!r})")
    if p.is_dir():
        raise ValueError(f"--out {str(out)!r} is a folder; give a file name such as {p / 'video.mp4'}")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"--out: folder {str(parent)!r} does not exist (create it first)")
    check_output_file(p, "--out")
    return p


@dataclass(frozen=True)
class VideoConfig:
    """Video options: ``fps`` frames per second of video, ``speedup`` seconds of driving per second of video,
    ``arrangement`` 'side' or 'overlay', ``max_seconds`` of driving (None: whole episodes), panel ``render``."""

    fps: int = 25
    speedup: float = 1.0
    arrangement: str = "side"
    max_seconds: float | None = None
    render: RenderConfig = field(default_factory=RenderConfig)

    def __post_init__(self) -> None:
        if not isinstance(self.fps, int) or isinstance(self.fps, bool) or not 1 <= self.fps <= 120:
            raise ValueError(f"--fps must be an integer in [1, 120] frames/s (got {self.fps!r})")
        if not (isinstance(self.speedup, int | float) and 0.05 <= self.speedup <= 100.0):
            raise ValueError(f"--speedup must be in [0.05, 100] (got {self.speedup!r})")
        if self.arrangement not in ARRANGEMENTS:
            raise ValueError(f"--arrangement must be one of {ARRANGEMENTS} (got {self.arrangement!r})")
        if self.max_seconds is not None and not (isinstance(self.max_seconds, int | float) and self.max_seconds > 0):
            raise ValueError(f"--seconds must be > 0 s (got {self.max_seconds!r})")


def car_view_from_info(info: dict[str, Any], path: Any, layout: Any, label: str, colour: str,
                       status: str = "", trail_xy: np.ndarray | None = None) -> CarView:
    """A ``CarView`` from a ``TrackingEnv`` step info (public signals only)."""
    v = float(info["v_mps"])
    preview = R.preview_points(path, float(info["station_m"]) + layout.preview_distances(v))
    return CarView(float(info["x_m"]), float(info["y_m"]), float(info["psi_rad"]),
                   float(info["road_wheel_angle_rad"]), v, float(info["e_y_m"]),
                   math.degrees(float(info["hand_wheel_angle_rad"])), label, colour,
                   preview, status, trail_xy)


class _Driver:
    """One policy driving its own env; holds its last info once the episode ended."""

    def __init__(self, name: str, make_policy: Callable[[gym.Env], Any], env_id: str, seed: int,
                 make_kwargs: dict[str, Any] | None = None) -> None:
        self.name = name
        self.env = gym.make(env_id, **(make_kwargs or {}))
        self.policy = make_policy(self.env)
        self.obs, self.info = self.env.reset(seed=seed)
        self.done = False
        self.status = ""
        self._state = None
        self._start = np.ones(1, dtype=bool)
        self._trail: list[tuple[float, float]] = []

    def step(self) -> None:
        if self.done:
            return
        action, self._state = self.policy.predict(self.obs, state=self._state, episode_start=self._start,
                                                  deterministic=True)
        self._start = np.zeros(1, dtype=bool)
        self.obs, _, term, trunc, self.info = self.env.step(step_action(action, self.env.action_space.shape))
        if term or trunc:
            self.done = True
            self.status = f"[{self.info['termination'] or 'time limit'}]"

    def view(self, path: Any) -> CarView:
        u = self.env.unwrapped
        self._trail = [*self._trail[-TRAIL_POINTS + 1:], (float(self.info["x_m"]), float(self.info["y_m"]))]
        return car_view_from_info(self.info, path, u.observation_layout, self.name, policy_colour(self.name),
                                  self.status, np.array(self._trail))


def _grid(panels: list[np.ndarray]) -> np.ndarray:
    """Panels side by side, at most three per row."""
    cols = min(len(panels), 3)
    rows = math.ceil(len(panels) / cols)
    h, w, _ = panels[0].shape
    out = np.zeros((rows * h, cols * w, 3), dtype=np.uint8)
    for k, p in enumerate(panels):
        r, c = divmod(k, cols)
        out[r * h:(r + 1) * h, c * w:(c + 1) * w] = p
    return out


class _Writer:
    """MP4 (imageio + imageio-ffmpeg, streamed) or GIF (Pillow, assembled in memory)."""

    def __init__(self, out: Path, fps: int) -> None:
        self.out, self.fps, self.frames = out, fps, 0
        self._gif: list[Any] | None = None
        self._palette: Any = None
        if out.suffix.lower() == ".gif":
            self._gif = []
            return
        try:
            import imageio.v2 as imageio
        except ImportError:
            raise ImportError('writing MP4 needs imageio and imageio-ffmpeg: pip install "vtrack_gym[render]"') \
                from None
        self._mp4 = imageio.get_writer(out, format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=7,
                                       macro_block_size=2, ffmpeg_log_level="error",
                                       output_params=["-preset", "veryfast"])  # ~1.5x faster, files ~20 % larger

    def add(self, frame: np.ndarray) -> None:
        self.frames += 1
        if self._gif is None:
            self._mp4.append_data(frame)
            return
        if self.frames > MAX_GIF_FRAMES:
            raise ValueError(f"a GIF is limited to {MAX_GIF_FRAMES} frames; write .mp4, raise --speedup or set "
                             "--seconds")
        from PIL import Image

        if self._palette is None:  # one palette for the whole GIF: the first frame plus every scene colour
            swatch = np.repeat(np.array([_SCENE_COLOURS], dtype=np.uint8), 4, axis=0)
            rows = np.zeros((4, frame.shape[1], 3), dtype=np.uint8)
            rows[:, :swatch.shape[1]] = swatch[:, :frame.shape[1]]
            self._palette = Image.fromarray(np.vstack([frame, rows])).quantize(
                colors=96, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        self._gif.append(Image.fromarray(frame).quantize(palette=self._palette, dither=Image.Dither.NONE))

    def abort(self) -> None:
        """Stop after a failure: end ffmpeg without waiting on a full disk (the file is discarded)."""
        if self._gif is None:
            try:
                self._mp4.close()
            except (OSError, ValueError, RuntimeError):
                pass

    def close(self) -> None:
        if self._gif is None:
            self._mp4.close()
        elif self._gif:
            first, *rest = self._gif
            first.save(self.out, save_all=True, append_images=rest, duration=round(1000 / self.fps), loop=0,
                       optimize=True, disposal=1)


def record_video(env_id: str, policies: Sequence[tuple[str, Callable[[gym.Env], Any]]], out: str | Path,
                 config: VideoConfig | None = None, seed: int = 0,
                 progress: Callable[[str], None] | None = None, vehicle: str | None = None) -> dict[str, Any]:
    """Drive ``policies`` (``(name, make(env) -> policy)``) on ``env_id`` and write the video to ``out``.

    ``vehicle``: the car (a name of ``vehicle.list_vehicles()`` or a vehicle file; default the paper's car).

    Returns ``{"path", "frames", "video_s", "driven_s", "wall_s"}``.
    """
    cfg = config or VideoConfig()
    out = check_video_path(out)
    if not policies:
        raise ValueError("record_video needs at least one policy")
    start = time.perf_counter()
    kwargs = {} if vehicle is None else {"vehicle": vehicle}
    drivers = [_Driver(name, make, env_id, seed, kwargs) for name, make in policies]
    u = drivers[0].env.unwrapped
    path = u.current_path
    dt = float(u.control_period_s)
    renderer = TopDownRenderer(path, u.config.vehicle.chassis, cfg.render)
    limit_s = cfg.max_seconds if cfg.max_seconds is not None else float(u.scenario.time_limit_s)
    if out.suffix.lower() == ".gif" and limit_s / cfg.speedup * cfg.fps > MAX_GIF_FRAMES:
        raise ValueError(f"{limit_s:g} s of driving at --speedup {cfg.speedup:g} and {cfg.fps} frames/s can exceed "
                         f"the {MAX_GIF_FRAMES}-frame GIF limit; write .mp4, raise --speedup or set --seconds")
    from vtrack_gym._io import atomic_output

    try:
        with atomic_output(out, "--out") as tmp:
            frames, steps = _render_frames(drivers, renderer, path, tmp, cfg, limit_s, env_id, progress)
    finally:
        for d in drivers:
            d.env.close()
    return {"path": out, "frames": frames, "video_s": frames / cfg.fps, "driven_s": steps * dt,
            "wall_s": time.perf_counter() - start}


def _render_frames(drivers: list[_Driver], renderer: TopDownRenderer, path: Any, tmp: Path, cfg: VideoConfig,
                   limit_s: float, title: str, progress: Callable[[str], None] | None) -> tuple[int, int]:
    """Drive and draw into the video file ``tmp``; returns (frames written, control steps driven)."""
    dt = float(drivers[0].env.unwrapped.control_period_s)
    clock = FrameClock(cfg.fps)
    writer = _Writer(tmp, cfg.fps)
    steps = 0
    done = False
    try:
        while True:
            t = steps * dt
            if clock.due(t / cfg.speedup):
                views = [d.view(path) for d in drivers]
                if cfg.arrangement == "overlay":
                    frame = renderer.frame(views, t, title)
                else:
                    frame = _grid([renderer.frame([v], t, title) for v in views])
                writer.add(frame)
                if progress is not None and writer.frames % (10 * cfg.fps) == 0:
                    progress(f"{t:.1f} s driven, {writer.frames} frames")
            if all(d.done for d in drivers) or t >= limit_s - 1e-9:
                break
            for d in drivers:
                d.step()
            steps += 1
        done = True
    finally:
        if done:
            writer.close()
        else:
            writer.abort()
    return writer.frames, steps
