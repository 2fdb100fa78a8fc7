"""Map files as tracks: the format registry, OpenDRIVE routes and their errors, GPX, Lanelet2 and CommonRoad (where
their packages are installed), bounded input, and the map options through ``gym.make`` into a row's identity."""

from __future__ import annotations

import builtins
import math
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.tracks import load_track
from vtrack_gym.tracks.formats import FORMATS, TrackFormat, TrackRead, format_of, read_track_file

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import map_files


@pytest.fixture(scope="module")
def maps(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("maps")
    map_files.write_examples(folder)
    return folder


# ------------------------------------------------------------------------------------------------- the registry
def test_the_format_comes_from_the_suffix_or_is_given(maps: Path, tmp_path: Path) -> None:
    assert [format_of(maps / f) for f in ("ring.xodr", "ring.gpx", "ring.osm", "ring.xml")] == [
        "opendrive", "gpx", "lanelet2", "commonroad"]
    assert format_of(tmp_path / "points.dat") == "csv"        # a suffix no format claims: a CSV of points
    assert format_of(tmp_path / "points.dat", "gpx") == "gpx"
    with pytest.raises(ValueError, match="unknown track format 'kml'; known: cones, csv, opendrive"):
        format_of(maps / "ring.xodr", "kml")


def test_a_new_format_is_one_module_and_one_registry_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """A second format on the .csv suffix (as a cone map would be) is chosen by its module's ``sniff``."""
    module = type(sys)("cone_format")
    module.sniff = lambda head: head.startswith(b"tag,")
    module.load = lambda file, read: ("cones", file.name, read.allow_self_crossing)
    monkeypatch.setitem(sys.modules, "cone_format", module)
    monkeypatch.setitem(FORMATS, "cones", TrackFormat((".csv",), "cone_format", "cone map"))
    cones, points = tmp_path / "cones.csv", tmp_path / "points.csv"
    cones.write_text("tag,x,y\nblue,0,0\n")
    points.write_text("x,y\n0,0\n")
    assert format_of(cones) == "cones" and format_of(points) == "csv"
    assert read_track_file(cones, TrackRead(allow_self_crossing=True)) == ("cones", "cones.csv", True)


def test_a_missing_optional_package_names_its_extra(maps: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real_import = builtins.__import__

    def no_lanelet2(name, *args, **kwargs):
        if name.startswith(("lanelet2", "commonroad")):
            raise ImportError(f"No module named {name!r}")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_lanelet2)
    with pytest.raises(ImportError, match=r"pip install 'vtrack_gym\[lanelet2\]'"):
        load_track(maps / "ring.osm", route="1001")
    with pytest.raises(ImportError, match=r"pip install 'vtrack_gym\[commonroad\]'"):
        load_track(maps / "ring.xml")


@pytest.mark.parametrize(("options", "message"), [
    ({"route": ""}, "route: 1 to 10000 ids"), ({"lane": 0}, r"lane must be a lane id in \[-100, -1\]"),
    ({"road_width_m": -1.0}, r"road_width_m must be in \[1, 100\] m"), ({"routes": "1"}, "unknown track option")])
def test_bad_read_options_name_the_field_and_the_range(options: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        TrackRead.of(options)


# ----------------------------------------------------------------------------------------------- OpenDRIVE errors
def _road(rid: str, x0: float, length: float = 50.0, body: str = "<line/>") -> str:
    return (f'<road id="{rid}" length="{length}"><planView><geometry s="0" x="{x0}" y="0" hdg="0" '
            f'length="{length}">{body}</geometry></planView><lanes><laneSection s="0"><right><lane id="-1" '
            'type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane></right></laneSection></lanes>'
            "</road>")


@pytest.mark.parametrize(("text", "route", "message"), [
    ("<OpenDRIVE>" + _road("1", 0) + "<road id=", None, r"line 1, column \d+: malformed XML"),
    ("<OpenDRIVE>\n" + _road("1", 0, body='<clothoid a="1"/>') + "</OpenDRIVE>", None,
     r"line 2: road 1: a <geometry> holds <clothoid>; expected one of <line>, <arc>, <spiral>"),
    ("<OpenDRIVE>" + _road("1", 0, length=0.0) + "</OpenDRIVE>", None, "road 1 has length 0 m; expected > 0"),
    ("<OpenDRIVE>" + _road("1", 0) + _road("2", 80) + "</OpenDRIVE>", None,
     r"the map has 2 roads \(1, 2\); give the roads to drive"),
    ("<OpenDRIVE>" + _road("1", 0) + _road("2", 80) + "</OpenDRIVE>", "1,2",
     r"road 2 does not connect to road 1 \(road 1 ends at \(50.00, 0.00\)"),
    ("<OpenDRIVE>" + _road("1", 0) + _road("2", 50) + "</OpenDRIVE>", "1,9", "route: no road with id '9'"),
    ('<!DOCTYPE x [<!ENTITY a "aaaa">]><OpenDRIVE/>', None, "document type or entity declaration"),
    ("<osm/>", None, "the root element is <osm>; expected <OpenDRIVE>"),
    ("<OpenDRIVE>" + _road("1", 0).replace('lane id="-1"', 'lane id="-2"') + "</OpenDRIVE>", None,
     r"road 1: the right lanes have ids \[-2\]; expected -1, -2, ... from the centre"),
    ("<OpenDRIVE>" + _road("1", 0).replace('length="50.0">', 'length="60.0">', 1) + "</OpenDRIVE>", None,
     "road 1: its <geometry> records end at s = 50 m; expected its length 60 m"),
    ("<OpenDRIVE>" + _road("1", 0).replace('road id="1" length="50.0"', 'road id="1" length="1e9"')
     .replace('length="50.0">', 'length="1e9">') + "</OpenDRIVE>", None, "road 1 has length 1e[+]09 m; at most"),
    ("<OpenDRIVE>" + "".join(_road(str(k), 0, length=40_000.0) for k in range(6)) + "</OpenDRIVE>", "0,1,2,3,4,5",
     "the route is 240 km long; at most 200 km"),
])
def test_bad_opendrive_names_the_element_and_what_was_expected(tmp_path: Path, text: str, route: str | None,
                                                              message: str) -> None:
    file = tmp_path / "bad.xodr"
    file.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        load_track(file, route=route)


def test_a_huge_document_is_refused_by_its_element_count(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from vtrack_gym.tracks import xml_reader

    monkeypatch.setattr(xml_reader, "MAX_ELEMENTS", 50)
    file = tmp_path / "big.gpx"
    file.write_text("<gpx>\n" + "\n".join('<trkpt lat="48" lon="11"/>' for _ in range(60)) + "\n</gpx>")
    with pytest.raises(ValueError, match="line 51: more than 50 XML elements"):
        load_track(file)


def test_a_lane_missing_from_a_section_is_named(tmp_path: Path) -> None:
    file = tmp_path / "one.xodr"
    file.write_text("<OpenDRIVE>" + _road("1", 0) + "</OpenDRIVE>", encoding="utf-8")
    assert load_track(file, lane=-1).length_m == pytest.approx(50.0, abs=1e-9)
    with pytest.raises(ValueError, match=r"road 1, lane section at s = 0 m: no lane -2 \(lanes \[-1\]\)"):
        load_track(file, lane=-2)


def test_a_self_crossing_route_is_refused_unless_allowed(tmp_path: Path) -> None:
    """A figure eight of two roads: two 270 deg loops of radius 30 m whose straights cross at the origin."""
    first, second = map_files.figure_eight()
    file = tmp_path / "eight.xodr"
    file.write_text(map_files.xodr_text([map_files.road_xml("1", first), map_files.road_xml("2", second)]))
    with pytest.raises(ValueError, match=r"the route crosses itself \(road 1 at s = [\d.]+ m meets road \d at s = "):
        load_track(file, route="1,2")
    path = load_track(file, route="1,2", allow_self_crossing=True)
    assert path.closed and path.self_intersects()


def test_a_10_km_town_map_imports_in_under_2_s(tmp_path: Path) -> None:
    from bench_map_import import town_map

    file, route, length_m = town_map(tmp_path / "town.xodr", 10_000.0)
    start = time.process_time()   # CPU time: wall time on a shared CI machine also counts its neighbours' work
    path = load_track(file, route=route)
    elapsed = time.process_time() - start
    assert path.length_m == pytest.approx(length_m, rel=1e-6) and length_m > 10_000.0
    assert elapsed < 2.0, f"{elapsed:.2f} s of CPU time"


# ------------------------------------------------------------------------------------------------------------ GPX
def test_gpx_is_projected_on_the_local_plane_with_the_given_width(maps: Path) -> None:
    from vtrack_gym.tracks.gpx import local_xy

    x, y, _ = map_files.ring_centre(5.0)
    lat, lon = map_files.geodetic(x, y)
    px, py = local_xy(lat, lon, *map_files.ORIGIN)
    np.testing.assert_allclose(np.column_stack((px, py)), np.column_stack((x, y)), atol=1e-6)
    path = load_track(maps / "ring.gpx", road_width_m=5.0)
    assert path.closed and abs(path.length_m - map_files.ring_length_m()) < 0.05
    np.testing.assert_allclose(path.widths_m, 2.5)
    assert load_track(maps / "ring.gpx").half_width_m == 3.5


def test_a_given_format_reads_a_file_of_another_suffix(maps: Path, tmp_path: Path) -> None:
    logged = tmp_path / "ride.log"
    logged.write_bytes((maps / "ring.gpx").read_bytes())
    with pytest.raises(ValueError, match="line 1"):          # read as a CSV of points by default
        load_track(logged)
    assert load_track(logged, format="gpx").length_m == pytest.approx(load_track(maps / "ring.gpx").length_m)


def test_gpx_errors_name_the_line(tmp_path: Path) -> None:
    file = tmp_path / "bad.gpx"
    points = "\n".join(f'<trkpt lat="48.1" lon="{11.5 + k * 1e-4}"/>' for k in range(5))
    file.write_text(f'<gpx>\n<trk><trkseg>\n{points}\n<trkpt lat="91" lon="11.6"/></trkseg></trk></gpx>')
    with pytest.raises(ValueError, match=r"line 8: lat=91, lon=11.6; expected latitude in \[-90, 90\]"):
        load_track(file)
    with pytest.raises(ValueError, match="route and lane apply to road maps"):
        load_track(file, route="1")


# ----------------------------------------------------------------------------------------- Lanelet2 and CommonRoad
def test_lanelet2_routes_given_ids_and_through_the_routing_graph(maps: Path) -> None:
    pytest.importorskip("lanelet2")
    loop = load_track(maps / "ring.osm", route="1001,1002,1003,1004")
    outer = map_files.ring_length_m() + 2 * math.pi * map_files.LANE_M / 2      # the right lane's centre
    assert loop.closed and abs(loop.length_m - outer) < 0.05
    np.testing.assert_allclose(loop.widths_m, map_files.LANE_M / 2, atol=0.02)
    routed = load_track(maps / "ring.osm", route="1001,1003")                  # 1002 found by the routing graph
    assert not routed.closed
    assert routed.length_m == pytest.approx(2 * map_files.STRAIGHT_M + map_files.turn_length_m()
                                            + math.pi * map_files.LANE_M / 2, abs=0.05)
    with pytest.raises(ValueError, match="the map has 4 lanelets"):
        load_track(maps / "ring.osm")
    with pytest.raises(ValueError, match="route: no lanelet with id '77'"):
        load_track(maps / "ring.osm", route="1001,77")


def test_lanelet2_reads_autowares_local_coordinates(maps: Path, tmp_path: Path) -> None:
    pytest.importorskip("lanelet2")
    file = tmp_path / "autoware.osm"
    file.write_text(map_files.osm_text(map_files.ring_lanelets(), local_xy=True))   # lat = lon = 0 everywhere
    local = load_track(file, route="1001,1002,1003,1004")
    projected = load_track(maps / "ring.osm", route="1001,1002,1003,1004")
    assert local.closed and local.length_m == pytest.approx(projected.length_m, abs=1e-3)
    start = (0.0, -map_files.LANE_M / 2)      # the first lanelet's start, in the file's own metres (smoothed fit)
    np.testing.assert_allclose(local.table[0, :2], start, atol=0.01)
    file.write_text(file.read_text().replace('k="local_x" v="0.0"', 'k="local_x" v="east"', 1))
    with pytest.raises(ValueError, match=r"line \d+: node \d+: local_x / local_y must be finite numbers"):
        load_track(file, route="1001")


def test_lanelet2_names_lanelets_that_do_not_connect(tmp_path: Path) -> None:
    pytest.importorskip("lanelet2")
    lanes = map_files.ring_lanelets()
    file = tmp_path / "two.osm"
    file.write_text(map_files.osm_text([lanes[0], lanes[2]]))        # the straights only: 1002 leads nowhere
    with pytest.raises(ValueError, match="no lanelet sequence leads from lanelet 1001 to lanelet 1002"):
        load_track(file, route="1001,1002")


def test_commonroad_drives_the_planning_problem_or_given_lanelets(maps: Path, tmp_path: Path) -> None:
    pytest.importorskip("commonroad.common.file_reader")
    path = load_track(maps / "ring.xml")                             # the planning problem: 1001 -> 1003
    expected = 2 * map_files.STRAIGHT_M + map_files.turn_length_m() + math.pi * map_files.LANE_M / 2
    assert not path.closed and path.length_m == pytest.approx(expected, abs=0.05)
    assert load_track(maps / "ring.xml", route="1001,1002").length_m == pytest.approx(
        map_files.STRAIGHT_M + map_files.turn_length_m() + math.pi * map_files.LANE_M / 2, abs=0.05)
    with pytest.raises(ValueError, match="no lanelet sequence leads from lanelet 1003 to lanelet 1001"):
        load_track(maps / "ring.xml", route="1003,1001")


# ------------------------------------------------------------------------------------- through gym.make, identity
def test_map_options_travel_with_the_track_into_the_rows_identity(maps: Path) -> None:
    from vtrack_gym.envs.registration import register_track
    from vtrack_gym.evaluation.api import env_identity

    env = gym.make("vtrack/Track-v0", track=str(maps / "ring.xodr"), track_options={"route": "1,2,3,4", "lane": -1})
    assert env.unwrapped.paths[0].length_m == pytest.approx(map_files.ring_length_m() + math.pi * 3.5, abs=1e-4)
    env_id, options = env_identity(env)
    assert options["track_read"] == {"track_options": {"route": ["1", "2", "3", "4"], "lane": -1}}
    profile = env.unwrapped.scenario.speed_profile
    same, _ = register_track(maps / "ring.xodr", profile, track_options={"route": "1,2,3,4", "lane": -1})
    other, _ = register_track(maps / "ring.xodr", profile, track_options={"route": "1,2,3,4"})
    assert env_id == same != other
    with pytest.raises(ValueError, match="unknown track option"):
        gym.make("vtrack/Track-v0", track=str(maps / "ring.xodr"), track_options={"roads": "1"})
    with pytest.raises(ValueError, match="apply to a track file only"):
        gym.make("vtrack/Track-v0", track="handling_course", allow_self_crossing=True)


# ------------------------------------------------------------------------------------------------- hostile input
@pytest.mark.parametrize("name", ["ring.xodr", "ring.gpx"])
def test_mangled_maps_give_a_valueerror_or_a_path(maps: Path, tmp_path: Path, name: str) -> None:
    """Truncated files, numbers replaced by nan / huge / negative values, deleted attributes and random bytes:
    a ValueError or a valid Path, never another exception."""
    from vtrack_gym.tracks import Path as TrackPath

    rng = np.random.default_rng(7)
    text = (maps / name).read_text(encoding="utf-8")
    route = "1,2,3,4" if name.endswith("xodr") else None
    numbers = [m.span() for m in __import__("re").finditer(r'"-?[0-9][0-9.e+-]*"', text)]
    cases = [text[: int(rng.integers(0, len(text)))] for _ in range(8)]
    for _ in range(16):
        a, b = numbers[int(rng.integers(len(numbers)))]
        value = rng.choice(['"nan"', '"1e308"', '"-5"', '"0"', '""', '"x"'])
        cases.append(text[:a] + value + text[b:])
    cases += [rng.bytes(int(rng.integers(1, 400))).decode("latin-1") for _ in range(4)]
    file = tmp_path / name
    for case in cases:
        file.write_text(case, encoding="utf-8")
        try:
            path = load_track(file, route=route)
        except ValueError:
            continue
        assert isinstance(path, TrackPath) and np.isfinite(path.table).all() and path.length_m > 0.0


_MANGLE_OSM = """
import re, sys
import numpy as np
from pathlib import Path
from vtrack_gym.tracks import load_track
from vtrack_gym.tracks.example_maps import example_map

rng = np.random.default_rng(int(sys.argv[1]))
text = example_map("ring.osm").read_text(encoding="utf-8")
numbers = [m.span() for m in re.finditer(r'"-?[0-9][0-9.e+-]*"', text)]
cases = [text[: int(rng.integers(0, len(text)))] for _ in range(4)]
for _ in range(24):
    a, b = numbers[int(rng.integers(len(numbers)))]
    cases.append(text[:a] + str(rng.choice(['"nan"', '"1e308"', '"-5"', '"0"', '""', '"x"', '"999999"'])) + text[b:])
file = Path(sys.argv[2])
for case in cases:
    file.write_text(case, encoding="utf-8")
    try:
        path = load_track(file, route="1001,1002,1003,1004")
    except ValueError:
        continue
    assert np.isfinite(path.table).all() and path.length_m > 0.0
print("done")
"""


@pytest.mark.parametrize("seed", [7, 8])
def test_mangled_lanelet2_maps_never_crash_the_process(tmp_path: Path, seed: int) -> None:
    """lanelet2's C++ reader may crash on bad ids or references: the file is checked first (in a subprocess here,
    so that a crash fails this test instead of ending the session)."""
    import subprocess

    pytest.importorskip("lanelet2")
    done = subprocess.run([sys.executable, "-c", _MANGLE_OSM, str(seed), str(tmp_path / "m.osm")],
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0 and done.stdout.strip() == "done", done.stderr[-2000:]
