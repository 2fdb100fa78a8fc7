"""Rendering speed and video recording time, each as a ratio against highway-env's renderer in the same run.

- frames/s of ``env.render()`` (rgb_array, 640x384): DLC120-v0 follow camera, LateralTracking-v0 whole-track
  view, and highway-env's ``lane-keeping-v0`` at the same size (pygame, ``SDL_VIDEODRIVER=dummy``);
- wall time of recording one DLC120-v0 episode (LQR steering) to MP4 with ``gymnasium.wrappers.RecordVideo``:
  ``render_mode='rgb_array_list'`` (frames at render_fps = 25/s of driving) and ``'rgb_array'`` (one frame per
  10 ms control step, the old behaviour), with ``vtrack video``'s ``record_video``, and the rollout alone;
  against RecordVideo on highway-env's ``lane-keeping-v0`` for the same driven time (per second of driving).

Run: ``python benchmarks/bench_render.py`` (needs the 'render' and 'highway' extras and moviepy for RecordVideo).
"""

from __future__ import annotations

import os
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import gymnasium as gym
import numpy as np
from _timing import rate
from gymnasium.wrappers import RecordVideo

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.baselines.registry import make_policy
from vtrack_gym.evaluation.figures.video import VideoConfig, record_video

SIZE = (640, 384)


def vtrack_render_rate(env_id: str, view: str) -> float:
    env = gym.make(env_id, render_mode="rgb_array", render_view=view)
    env.reset(seed=0)
    for _ in range(200):  # drive a little so the camera is mid-track
        env.step(np.zeros(1, dtype=np.float32))
    return rate(env.render, 1.0, min_seconds=3.0, repeats=6)


def highway_env():
    import highway_env

    gym.register_envs(highway_env)
    env = gym.make("lane-keeping-v0")  # its __init__ takes no render_mode (highway-env 1.12.1)
    env.unwrapped.render_mode = "rgb_array"
    env.unwrapped.configure({"screen_width": SIZE[0], "screen_height": SIZE[1]})
    env.reset(seed=0)
    return env


def highway_render_rate() -> float:
    env = highway_env()
    for _ in range(5):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    return rate(env.render, 1.0, min_seconds=3.0, repeats=6)


def _drive(env, policy, max_steps: int | None = None) -> int:
    obs, _ = env.reset(seed=0)
    steps, done, state = 0, False, None
    while not done and (max_steps is None or steps < max_steps):
        action, state = policy.predict(obs, state=state, episode_start=np.array([steps == 0]), deterministic=True)
        obs, _, term, trunc, _ = env.step(np.asarray(action, dtype=np.float32).reshape(1))
        steps += 1
        done = term or trunc
    return steps


def record_dlc(mode: str | None, folder: Path) -> tuple[float, int]:
    """(wall s, control steps) of one DLC120 episode with LQR, recorded by RecordVideo in ``mode``."""
    env = gym.make("DLC120-v0", render_mode=mode)
    policy = make_policy("lqr", env)
    if mode is not None:
        env = RecordVideo(env, str(folder / (mode or "none")), episode_trigger=lambda e: True, disable_logger=True)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # RecordVideo warns once about the steps that take no frame
        steps = _drive(env, policy)
        env.close()
    return time.perf_counter() - start, steps


def record_highway(driven_s: float, folder: Path) -> float:
    """Wall s of RecordVideo on lane-keeping-v0 for ``driven_s`` seconds of driving (zero action)."""
    env = highway_env()
    freq = env.unwrapped.config["policy_frequency"]
    env = RecordVideo(env, str(folder / "highway"), episode_trigger=lambda e: True, disable_logger=True)
    start = time.perf_counter()
    env.reset(seed=0)
    for _ in range(round(driven_s * freq)):
        _, _, term, trunc, _ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        if term or trunc:
            env.reset()
    env.close()
    return time.perf_counter() - start


def main() -> None:
    ours = {("DLC120-v0", "follow"): vtrack_render_rate("DLC120-v0", "follow"),
            ("LateralTracking-v0", "track"): vtrack_render_rate("LateralTracking-v0", "track")}
    theirs = highway_render_rate()
    print(f"render() frames/s at {SIZE[0]}x{SIZE[1]} (rgb_array):")
    for (env_id, view), fps in ours.items():
        print(f"  vtrack {env_id:<20s} {view:<7s} {fps:8.0f} frames/s  ({1e3 / fps:5.2f} ms)  "
              f"{fps / theirs:5.1f}x highway-env")
    print(f"  highway-env lane-keeping-v0           {theirs:8.0f} frames/s  ({1e3 / theirs:5.2f} ms)")

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        record_dlc(None, folder)  # warm-up: compiled kernels, policy set-up
        bare, steps = record_dlc(None, folder)
        driven = steps * 0.01
        n_listed = 1 + int(driven * 25 + 1e-6)
        listed, _ = record_dlc("rgb_array_list", folder)
        every, _ = record_dlc("rgb_array", folder)
        cli = record_video("DLC120-v0", [("lqr", lambda env: make_policy("lqr", env))], folder / "cli.mp4",
                           VideoConfig())
        hw = record_highway(driven, folder)
    print(f"\nrecording one DLC120-v0 episode ({driven:.1f} s of driving, LQR) to MP4:")
    print(f"  rollout alone, no rendering                 {bare:6.2f} s")
    print(f"  RecordVideo, rgb_array_list (25 frames/s)   {listed:6.2f} s  ({listed / driven:.2f} s per s driven, "
          f"{n_listed} frames, {1e3 * listed / n_listed:.1f} ms/frame)")
    print(f"  RecordVideo, rgb_array (every 10 ms step)   {every:6.2f} s  ({every / driven:.2f} s per s driven, "
          f"{steps + 1} frames, {1e3 * every / (steps + 1):.1f} ms/frame)")
    print(f"  vtrack video / record_video ({cli['frames']} frames)      {cli['wall_s']:6.2f} s  "
          f"({cli['wall_s'] / driven:.2f} s per s driven)")
    n_hw = env_frames(driven)
    print(f"  highway-env lane-keeping-v0, RecordVideo    {hw:6.2f} s  ({hw / driven:.2f} s per s driven, "
          f"{n_hw} frames, {1e3 * hw / n_hw:.1f} ms/frame)")
    print(f"  ratio RecordVideo rgb_array_list / highway-env: {listed / hw:.2f}x the wall time per second driven, "
          f"{(listed / n_listed) / (hw / n_hw):.2f}x per frame (below 1: faster)")


def env_frames(driven_s: float) -> int:
    """Frames RecordVideo takes of lane-keeping-v0 for ``driven_s`` (one per policy step)."""
    return round(driven_s * highway_env().unwrapped.config["policy_frequency"]) + 1


if __name__ == "__main__":
    main()
