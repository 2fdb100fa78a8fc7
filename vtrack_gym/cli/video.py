"""``vtrack video``: an MP4 or GIF of one or more policies driving one env (side by side or overlaid)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import check_vehicle, env_or_track
from vtrack_gym.cli._policies import policy_makers
from vtrack_gym.cli._terminal import err, out

NAME = "video"


def register(sub: Any) -> None:
    vd = sub.add_parser(NAME, help="write an MP4 or GIF of policies driving a scenario (extra 'render')",
                        description="Drive one or more policies on one env (same seed) and write a top-down video: "
                        "MP4 through imageio-ffmpeg or GIF through Pillow, at real time or --speedup. Several "
                        "policies are shown side by side (one panel each) or overlaid in one frame.")
    vd.add_argument("--policy", default=None, help="one policy name or agent file (as for `vtrack eval`)")
    vd.add_argument("--policies", default=None, help="comma-separated policy names, e.g. mpc,smc")
    opt.add_user_code(vd)
    where = vd.add_mutually_exclusive_group(required=True)
    where.add_argument("--env", default=None, help="env id, e.g. DLC120-v0 or LateralTracking-v0")
    opt.add_track(vd, where=where)
    vd.add_argument("--out", type=Path, required=True, help="output file ending in .mp4 or .gif")
    vd.add_argument("--preset", default="default", help="baseline preset for every policy (default: default)")
    opt.add_vehicle(vd)
    vd.add_argument("--seed", "--episode-seed", dest="seed", type=opt.int_in(0, opt.MAX_SEED), default=0,
                    help="episode seed: the env's reset seed (its draw of initial offset and heading error, as "
                    "--seeds of vtrack eval) (default: 0)")
    vd.add_argument("--speedup", type=opt.float_in(0.05, 100.0), default=1.0,
                    help="seconds of driving per second of video, in [0.05, 100] (default: 1 = real time)")
    vd.add_argument("--fps", type=opt.int_in(1, 120), default=25,
                    help="frames per second of video, 1-120 (default: 25)")
    vd.add_argument("--seconds", type=opt.float_in(0.01, 86_400.0), default=None,
                    help="stop after this much driving [s], 0.01 to 86400 (default: the whole episode)")
    vd.add_argument("--arrangement", choices=("side", "overlay"), default="side",
                    help="several policies: side by side or overlaid in one frame (default: side)")
    vd.add_argument("--view", choices=("follow", "track"), default="follow",
                    help="follow: camera on the (first) car; track: the whole track (default: follow)")
    vd.add_argument("--view-width", type=opt.float_in(5.0, 2000.0), default=60.0,
                    help="follow view: metres across, 5 to 2000 (default: 60)")
    vd.add_argument("--width", type=opt.int_in(64, 4096), default=640,
                    help="panel width in pixels, even, 64 to 4096 (default: 640)")
    vd.add_argument("--height", type=opt.int_in(64, 4096), default=384,
                    help="panel height in pixels, even, 64 to 4096 (default: 384)")


def _video_config(args: argparse.Namespace) -> Any:
    from vtrack_gym.envs.render import RenderConfig
    from vtrack_gym.evaluation.figures.video import VideoConfig

    render = RenderConfig(width_px=args.width, height_px=args.height, view=args.view, view_width_m=args.view_width,
                          fps=args.fps)
    return VideoConfig(fps=args.fps, speedup=args.speedup, arrangement=args.arrangement, max_seconds=args.seconds,
                       render=render)


def _drawable_env(args: argparse.Namespace) -> str:
    """The env id of --env/--track, refused unless it is a vtrack env (the renderer draws those only)."""
    import vtrack_gym
    from vtrack_gym.envs.registration import TRACK_ID_PREFIX

    env_id, _ = env_or_track(args)
    if env_id not in vtrack_gym.ALL_ENV_IDS and not env_id.startswith(TRACK_ID_PREFIX):
        raise ValueError(f"vtrack video draws the vtrack envs only: {', '.join(vtrack_gym.ENV_IDS)} (got --env "
                         f"{args.env!r})")
    return env_id


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.figures.video import check_video_path, record_video

    if (args.policy is None) == (args.policies is None):
        raise ValueError("give exactly one of --policy NAME or --policies A,B")
    out_file = check_video_path(args.out)
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0 (got {args.seed})")
    config = _video_config(args)
    check_vehicle(args)   # read once: every env of the video drives the same bytes
    env_id = _drawable_env(args)
    names = [args.policy] if args.policy is not None else opt.policy_list(args.policies)
    if not names:
        raise ValueError("--policies needs at least one policy name, e.g. --policies mpc,smc")
    policies = [(Path(n).stem if Path(n).suffix else n, make)
                for n, make in policy_makers(names, args.preset, args.trust_code, args.policy_kwargs)]
    result = record_video(env_id, policies, out_file, config, seed=args.seed,
                          progress=lambda msg: err(f"recording: {msg}"), vehicle=args.vehicle)
    out(f"video: {result['path']} ({result['frames']} frames, {result['video_s']:.1f} s of video for "
        f"{result['driven_s']:.1f} s of driving, written in {result['wall_s']:.1f} s)")
    return 0
