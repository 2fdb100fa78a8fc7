"""A CommonRoad scenario (``.xml``) as a track, through the ``commonroad-io`` package (the ``commonroad`` extra):
a lanelet sequence's centre vertices, with the distances to its left and right vertices as half widths.

The route is ``route``: lanelet ids in driving order, two consecutive ids that do not follow each other joined by
the fewest lanelets along the successors; without one, the first planning problem's route: from the lanelet of its
initial position to its goal lanelet. Coordinates are the scenario's own (metres).
"""

from __future__ import annotations

from pathlib import Path as FsPath
from typing import Any

from vtrack_gym.tracks.map_path import expand_route, lanelet_line, map_path, no_route_error, successor_path
from vtrack_gym.tracks.xml_reader import read_xml


def sniff(head: bytes) -> bool:
    """Whether a file's first bytes look like a CommonRoad scenario."""
    return b"<commonRoad" in head


def _open(file: FsPath) -> tuple[Any, Any]:
    try:
        from commonroad.common.file_reader import CommonRoadFileReader
    except ImportError as exc:
        raise ImportError("reading a CommonRoad scenario (.xml) needs the commonroad-io package: pip install "
                          f"'vtrack_gym[commonroad]' ({exc})") from exc
    try:
        return CommonRoadFileReader(str(file)).open()
    except Exception as exc:  # commonroad-io raises many kinds on bad content
        raise ValueError(f"{file}: commonroad-io cannot read the scenario ({type(exc).__name__}: {exc})") from None


def _problem_route(file: FsPath, network: Any, problems: Any) -> tuple[str, ...]:
    """(start lanelet, goal lanelet) of the first planning problem; ValueError when it names neither."""
    found = list(getattr(problems, "planning_problem_dict", {}).values())
    if not found:
        raise no_route_error(file, sorted(str(ll.lanelet_id) for ll in network.lanelets), "along the successors")
    problem = found[0]
    start = network.find_lanelet_by_position([problem.initial_state.position])[0]
    goals = [g for ids in (problem.goal.lanelets_of_goal_position or {}).values() for g in ids]
    if not start or not goals:
        raise ValueError(f"{file}: planning problem {problem.planning_problem_id}: expected an initial position on a "
                         "lanelet and a goal lanelet (give route= instead)")
    return str(start[0]), str(goals[0])


def load(file: FsPath, read: Any) -> Any:
    """The track format registry's entry: a CommonRoad scenario as a ``tracks.Path`` (``read``: a
    ``tracks.formats.TrackRead``; lane and road width do not apply)."""
    from vtrack_gym.tracks.csv_loader import read_track_bytes

    if read.lane is not None or read.road_width_m is not None:
        raise ValueError(f"{file}: lane and road_width_m do not apply to a CommonRoad scenario (its lanelets have "
                         "bounds)")
    data = read_track_bytes(file)
    root = read_xml(file, data, "CommonRoad")   # malformed XML named by line before commonroad-io sees it
    if root.tag != "commonRoad":
        raise ValueError(f"{file}, line {root.line}: the root element is <{root.tag}>; expected <commonRoad>")
    scenario, problems = _open(file)
    network = scenario.lanelet_network
    lanelets = {str(ll.lanelet_id): ll for ll in network.lanelets}
    if not lanelets:
        raise ValueError(f"{file}: no lanelet in the scenario")
    route = read.route or (tuple(lanelets) if len(lanelets) == 1 else _problem_route(file, network, problems))
    for rid in route:
        if rid not in lanelets:
            raise ValueError(f"{file}: route: no lanelet with id {rid!r:.30} in the scenario (lanelets: "
                             f"{', '.join(sorted(lanelets)[:12])}{', ...' if len(lanelets) > 12 else ''})")
    successors = {k: [str(s) for s in ll.successor] for k, ll in lanelets.items()}
    ids = expand_route(file, route, lambda a, b: successor_path(successors, a, b))
    parts = [(k, lanelets[k].center_vertices, lanelets[k].left_vertices, lanelets[k].right_vertices) for k in ids]
    return map_path(file, data, lanelet_line(parts), closed=read.closed, smoothing_m=read.smoothing_m,
                    allow_self_crossing=read.allow_self_crossing)
