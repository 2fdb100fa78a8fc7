"""Cone-lined tracks (``tracks.cones.load_cone_track``, the Formula Student ``tag,x,y`` convention): the centre
line and widths built from the cones, the start at the orange cones, errors naming the cone lines, and a lap through
``gym.make("vtrack/Track-v0", track="....cones.csv", track_limits="wheels")``."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.tracks import load_track
from vtrack_gym.tracks.cones import load_cone_track

RADIUS_M, STRAIGHT_M, HALF_M = 10.0, 30.0, 1.5


def _stadium(offset: float, step: float = 3.0) -> list[tuple[float, float]]:
    """Cones along a stadium (two straights, two half circles of RADIUS_M + offset), counter-clockwise."""
    r = RADIUS_M + offset
    n = max(4, int(math.pi * r / step))
    pts = [(x, -r) for x in np.arange(0.0, STRAIGHT_M, step)]
    pts += [(STRAIGHT_M + r * math.cos(-math.pi / 2 + math.pi * k / n), r * math.sin(-math.pi / 2 + math.pi * k / n))
            for k in range(n)]
    pts += [(x, r) for x in np.arange(STRAIGHT_M, 0.0, -step)]
    pts += [(r * math.cos(math.pi / 2 + math.pi * k / n), r * math.sin(math.pi / 2 + math.pi * k / n))
            for k in range(n)]
    return pts


def _write(file: Path, blue: list, yellow: list, extra: tuple[str, ...] = ("big_orange,10.0,-8.3",
                                                                           "big_orange,10.0,-11.7")) -> Path:
    rows = ["tag,x,y"] + [f"blue,{x:.3f},{y:.3f}" for x, y in blue] + [f"yellow,{x:.3f},{y:.3f}" for x, y in yellow]
    file.write_text("\n".join([*rows, *extra]) + "\n")
    return file


def test_a_cone_loop_becomes_a_closed_path_between_its_cone_lines(tmp_path: Path) -> None:
    file = _write(tmp_path / "stadium.cones.csv", _stadium(-HALF_M), _stadium(HALF_M))
    path = load_track(file)            # by its name; load_cone_track directly gives the same
    assert path.closed and path.length_m == pytest.approx(2 * STRAIGHT_M + 2 * math.pi * RADIUS_M, rel=0.02)
    assert np.allclose(path.table[0, :2], (10.0, -RADIUS_M), atol=0.2)      # starts between the orange cones
    widths = path.half_widths_rows()
    straight = (path.table[:, 1] < -RADIUS_M + 0.5) & (path.table[:, 0] > 3.0) & (path.table[:, 0] < 27.0)
    assert np.allclose(widths[straight], HALF_M, atol=0.02)                 # on the straights: the cone lines
    assert widths.min() > 1.0 and widths.max() < 2.0                        # in the bends: to the cone chords
    assert np.max(np.abs(path.table[:, 3])) == pytest.approx(1.0 / RADIUS_M, rel=0.15)
    renamed = _write(tmp_path / "stadium.csv", _stadium(-HALF_M), _stadium(HALF_M))   # by its tag header
    assert load_track(renamed).length_m == pytest.approx(path.length_m)
    assert load_cone_track(renamed).length_m == pytest.approx(path.length_m)


def test_cones_in_any_order_and_without_a_header_make_the_same_track(tmp_path: Path) -> None:
    """FSDS's files list the cones in any order, with no header (tag, x, y, direction, variances): chained by
    nearest neighbour from the orange cones and driven with blue on the left, they give the same loop."""
    ordered = load_cone_track(_write(tmp_path / "a.cones.csv", _stadium(-HALF_M), _stadium(HALF_M)))
    rows = ([f"blue,{x:.3f},{y:.3f},0.0,0.0,0.0,0.0" for x, y in _stadium(-HALF_M)]
            + [f"yellow,{x:.3f},{y:.3f},0.0,0.0,0.0,0.0" for x, y in _stadium(HALF_M)]
            + ["big_orange,10.0,-8.3,0.0,0.0,0.0,0.0", "big_orange,10.0,-11.7,0.0,0.0,0.0,0.0"])
    np.random.default_rng(0).shuffle(rows)
    (tmp_path / "b.cones.csv").write_text("\n".join(rows) + "\n")
    shuffled = load_cone_track(tmp_path / "b.cones.csv")
    # the midline pairs the two cone lines by arc-length fraction from their first cones, which the chain picks
    # nearest the orange cones: the same loop within 0.5 % of its length
    assert shuffled.closed and shuffled.length_m == pytest.approx(ordered.length_m, rel=5e-3)
    assert np.allclose(shuffled.table[0, :2], ordered.table[0, :2], atol=0.3)
    assert shuffled.table[0, 2] == pytest.approx(ordered.table[0, 2], abs=0.05)
    reversed_file = _write(tmp_path / "c.cones.csv", _stadium(-HALF_M)[::-1], _stadium(HALF_M)[::-1])
    assert load_cone_track(reversed_file).table[0, 2] == pytest.approx(ordered.table[0, 2], abs=0.05)


def test_a_lap_of_the_cone_loop_under_the_wheels_rule(tmp_path: Path) -> None:
    """Stanley laps the 3 m wide cone loop at Track-v0's default profile; the rule holds, the body stays inside."""
    file = _write(tmp_path / "stadium.cones.csv", _stadium(-HALF_M), _stadium(HALF_M))
    env = gym.make("vtrack/Track-v0", track=str(file), track_limits="wheels")
    policy = vtrack_gym.make_policy("stanley", env)
    obs, _ = env.reset(seed=0)
    done = False
    while not done:
        action, _ = policy.predict(obs)
        obs, _, term, trunc, info = env.step(action)
        done = term or trunc
    metrics = env.unwrapped.success_metrics()
    assert info["termination"] == "completed" and info["success"]
    assert metrics["track_limit_violations"] == 0.0 and 0.0 < metrics["min_edge_margin_m"] < HALF_M


@pytest.mark.parametrize(("edit", "message"), [
    (lambda b, y, e: (b, y, ("purple,1,2",)), r"line 82: unknown cone tag 'purple'"),   # 1 + 40 + 40 + 1
    (lambda b, y, e: (b[:5] + b[8:], y, e), r"lines (6 and 7|7 and 6): left \(blue\) cones 12.00 m apart \(sparse"),
    (lambda b, y, e: (b, y[:2], e), r"2 yellow cones on the right \(yellow\) side"),
    (lambda b, y, e: (b, y[:18], e), r"line 2[0-9]: blue cone at \(.*\) has no yellow cone within 10 m"),
    (lambda b, y, e: ([*b[:3], (9.0, -12.5), *b[4:]], y, e), r"the cone lines cross: left cones of lines 4-5"),
])
def test_bad_cone_files_name_the_cone_lines(edit, message: str, tmp_path: Path) -> None:
    blue, yellow, extra = edit(_stadium(-HALF_M), _stadium(HALF_M), ("big_orange,10.0,-8.3",))
    file = _write(tmp_path / "bad.cones.csv", blue, yellow, extra)
    with pytest.raises(ValueError, match=message):
        load_cone_track(file)


@pytest.mark.parametrize(("into_m", "hits"), [(0.001, True), (-0.002, False)])
def test_cones_are_judged_as_discs_to_the_millimetre(into_m: float, hits: bool, tmp_path: Path) -> None:
    """A straight cone lane 3 m wide (cones every 3 m); the car drives straight with its left side ``into_m`` into
    the blue cones' discs (radius 0.114 m): 1 mm in touches every cone it passes (2 s each), 2 mm clear none."""
    from vtrack_gym.tracks.cones import CONE_RADIUS_M

    xs = np.arange(0.0, 61.0, 3.0)
    file = _write(tmp_path / "lane.cones.csv", [(x, HALF_M) for x in xs], [(x, -HALF_M) for x in xs], ())
    body_half = 1.916 / 2                                                    # the hatchback's body
    offset = HALF_M - CONE_RADIUS_M["blue"] - body_half + into_m
    env = gym.make("vtrack/Track-v0", track=str(file), track_limits="body", speed_profile=8.0)
    env.reset(seed=0, options={"initial_lateral_offset_m": offset})
    done = False
    while not done:
        _, _, term, trunc, info = env.step(np.zeros(1, dtype=np.float32))
        done = term or trunc
    metrics = env.unwrapped.success_metrics()
    assert info["termination"] == "completed"
    if hits:
        assert metrics["cones_hit"] >= 15 and metrics["fs_penalty_s"] == 2.0 * metrics["cones_hit"]
    else:
        assert metrics["cones_hit"] == 0.0 and metrics["fs_penalty_s"] == 0.0
    assert info["success"]      # the cone lines themselves are 0.11 m further out: the body rule holds
