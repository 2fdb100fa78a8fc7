"""Real-road CSV files: header-aware columns (racetrack-database layout with per-side widths), closure relative to
the point spacing, self-crossing roads (bridges), dense rounded coordinates, bounded work, refusals naming the line
and the fix. Every track is built here."""

from __future__ import annotations

import math
import pathlib

import numpy as np
import pytest

from vtrack_gym.tracks import (
    Path,
    csv_loader,
    handling_course,
    load_track,
    load_track_csv,
    path_digest,
    track_names,
)
from vtrack_gym.tracks.geometry import TooDenseError, segment_intersections

HAIRPIN_R_M = 7.0
BLEND_M = 8.0
STRAIGHT_M = 150.0


def hairpin_loop(ds_m: float = 0.05) -> Path:
    """Closed stadium with two 7 m hairpins (smootherstep entries/exits of 8 m) and 150 m straights."""
    k = 1.0 / HAIRPIN_R_M
    arc = HAIRPIN_R_M * (math.pi - BLEND_M * k)          # the blends turn BLEND_M * k in total
    hairpin = [(BLEND_M, k), (arc, k), (BLEND_M, 0.0)]
    return Path.from_curvature([(STRAIGHT_M, 0.0), *hairpin, (STRAIGHT_M, 0.0), *hairpin], closed=True, ds_m=ds_m)


def write(tmp_path: pathlib.Path, text: str, name: str = "road.csv") -> pathlib.Path:
    f = tmp_path / name
    f.write_text(text)
    return f


def points_csv(tmp_path: pathlib.Path, cols: list[np.ndarray], header: str, fmt: str = "{:.3f}",
               name: str = "road.csv") -> pathlib.Path:
    body = "\n".join(",".join(fmt.format(c[i]) for c in cols) for i in range(cols[0].size))
    return write(tmp_path, header + body + "\n", name)


def loop_points(truth: Path, spacing_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points every ~spacing_m along a closed path, the last one a spacing short of the start; and their s."""
    n = round(truth.length_m / spacing_m)
    s = np.arange(n) * truth.length_m / n
    q = truth.sample(s)
    return q.x, q.y, s


def test_closed_loop_with_7m_hairpin_and_5m_end_gap(tmp_path: pathlib.Path) -> None:
    truth = hairpin_loop()
    x, y, _ = loop_points(truth, 5.0)
    assert math.hypot(x[-1] - x[0], y[-1] - y[0]) == pytest.approx(5.0, rel=0.05)
    p = load_track_csv(points_csv(tmp_path, [x, y], "x,y\n"))
    assert p.closed
    assert p.length_m == pytest.approx(truth.length_m, rel=2e-3)
    assert 1.0 / np.max(np.abs(p.table[:, 3])) == pytest.approx(HAIRPIN_R_M, rel=0.1)
    on_straight = truth.sample(np.linspace(20.0, STRAIGHT_M - 20.0, 30))
    assert np.max(np.abs(p.project(on_straight.x, on_straight.y).e_y)) < 0.02
    assert not load_track_csv(points_csv(tmp_path, [x, y], "x,y\n"), closed=False).closed


def test_open_course_ending_beside_its_start_is_not_closed() -> None:
    out = np.arange(0.0, 100.0, 5.0)                    # out along y = 0, a 2 m U-turn, back along y = 4
    turn = np.radians([-60.0, 0.0, 60.0])
    x = np.concatenate((out, 100.0 + 2.0 * np.cos(turn), out[::-1]))
    y = np.concatenate((np.zeros(out.size), 2.0 + 2.0 * np.sin(turn), np.full(out.size, 4.0)))
    gap = math.hypot(x[-1] - x[0], y[-1] - y[0])
    assert gap < csv_loader.CLOSED_GAP_SPACINGS * 5.0
    assert not csv_loader.detect_closed(x, y)                        # the chord is square to the end direction
    assert csv_loader.detect_closed(x[:-1], y[:-1]) is False


def figure_eight(n: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    return 100.0 * np.sin(t), 40.0 * np.sin(2.0 * t)


def test_figure_eight_with_a_bridge(tmp_path: pathlib.Path) -> None:
    x, y = figure_eight(400)
    f = points_csv(tmp_path, [x, y], "# x_m, y_m\n", fmt="{:.17g}")
    with pytest.raises(ValueError, match=r"crosses itself \(segment lines .*\); fix: .*allow_self_crossing=True"):
        load_track_csv(f)
    p = load_track_csv(f, allow_self_crossing=True)
    assert p.closed and p.self_intersects()
    s_cross = p.project(np.array([0.0]), np.array([0.0]), s_guess=np.array([0.5 * p.length_m])).s[0]
    assert s_cross == pytest.approx(0.5 * p.length_m, abs=0.5)   # the second pass over the bridge
    # a car driving over the crossing keeps its station when the guess follows it
    for s0 in (0.5 * p.length_m - 3.0, 2.0):
        q = p.sample(np.array([s0 + 2.0]))
        guess = np.array([s0])
        pr = p.project(q.x + 0.3 * np.sin(q.psi), q.y - 0.3 * np.cos(q.psi), s_guess=guess)
        assert pr.s[0] == pytest.approx(s0 + 2.0, abs=1e-3) and pr.e_y[0] == pytest.approx(-0.3, abs=1e-3)


def ellipse(a: float, b: float, spacing_m: float) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 2.0 * math.pi, 400001)
    x, y = a * np.cos(t), b * np.sin(t)
    s = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
    n = int(s[-1] / spacing_m)
    tt = np.interp(np.arange(n) * s[-1] / n, s, t)
    return a * np.cos(tt), b * np.sin(tt)


@pytest.mark.parametrize("decimals", [2, 3])
def test_dense_rounded_points_give_curvature_within_a_few_percent(tmp_path: pathlib.Path, decimals: int) -> None:
    a, b = 60.0, 25.0                                    # radii of curvature 10.4 m .. 144 m
    x, y = ellipse(a, b, 0.1)
    assert x.size > 2500
    p = load_track_csv(points_csv(tmp_path, [x, y], "x_m,y_m\n", fmt=f"{{:.{decimals}f}}"))
    assert p.closed
    q = p.sample(p.s_m)
    th = np.arctan2(q.y / b, q.x / a)
    kappa_true = a * b / (a * a * np.sin(th) ** 2 + b * b * np.cos(th) ** 2) ** 1.5
    assert np.max(np.abs(q.kappa / kappa_true - 1.0)) < 0.03
    assert csv_loader.rounding_quantum_m(x.round(decimals), y.round(decimals)) == pytest.approx(10.0 ** -decimals)


def test_full_precision_points_are_interpolated() -> None:
    x, y = ellipse(60.0, 25.0, 5.0)
    assert csv_loader.auto_smoothing_m(x, y) == 0.0
    assert csv_loader.auto_smoothing_m(np.round(x, 2), np.round(y, 2)) == pytest.approx(0.01 / math.sqrt(6.0))


def test_racetrack_database_layout_with_widths_and_speed(tmp_path: pathlib.Path) -> None:
    truth = hairpin_loop()
    x, y, s = loop_points(truth, 2.0)
    right = 4.0 + np.sin(2.0 * math.pi * s / truth.length_m)
    left = 3.0 + 0.5 * np.cos(2.0 * math.pi * s / truth.length_m)
    f = points_csv(tmp_path, [x, y, right, left], "# x_m,y_m,w_tr_right_m,w_tr_left_m\n", fmt="{:.4f}")
    p = load_track_csv(f)
    assert p.closed and p.widths_m is not None and p.v_ref_mps is None
    assert p.half_width_m == pytest.approx(min(right.min(), left.min()), abs=1e-3)
    s_pts = p.project(x, y).s
    got_left, got_right = p.half_widths(s_pts)
    assert np.max(np.abs(got_left - left)) < 0.01 and np.max(np.abs(got_right - right)) < 0.01
    assert load_track_csv(f, half_width_m=2.0).half_widths(np.array([5.0])) == (2.0, 2.0)
    v = 10.0 + s / 50.0
    g = points_csv(tmp_path, [x, y, left, right, v], "x;y;w_left_m;w_right_m;v_mps\n".replace(";", ","),
                   fmt="{:.4f}", name="with_speed.csv")
    q = load_track_csv(g)
    assert q.v_ref_mps is not None and np.allclose(q.half_widths(s_pts)[0], left, atol=0.01)


def test_semicolon_separated_file_loads(tmp_path: pathlib.Path) -> None:
    x, y = ellipse(60.0, 25.0, 4.0)
    text = "# x_m; y_m\n" + "\n".join(f"{a:.17g}; {b:.17g}" for a, b in zip(x, y, strict=True))
    assert load_track_csv(write(tmp_path, text)).closed


@pytest.mark.parametrize(("text", "message"), [
    ("# x_m, y_m, w_tr_right_m\n0,0,3\n10,0,3\n20,1,3\n30,3,3\n",
     r"road\.csv, line 1: the header names w_tr_right_m without the other half width; fix: name both"),
    ("x,y,curb\n0,0,1\n10,0,1\n20,1,1\n30,3,1\n",
     r"road\.csv, line 1: header must name the columns x, y .*unknown column\(s\) \['curb'\]\); fix: rename"),
    ("# x_m,y_m,w_tr_right_m,w_tr_left_m\n0,0,3\n10,0,3\n20,1,3\n30,3,3\n",
     r"road\.csv, line 2: expected 4 columns as named by the header on line 1 \(got 3\); fix: make the header"),
    ("0,0,3,3\n10,0,3,3\n20,1,3,3\n30,3,3,3\n",
     r"line 1: expected 2 \(x, y\) or 3 \(x, y, z\) columns \(got 4\); fix: name the columns in a header line"),
    ("x,y,w_tr_right_m,w_tr_left_m\n0,0,3,3\n10,0,-1,3\n20,1,3,3\n30,3,3,3\n",
     r"road\.csv, line 3: half width w_tr_right_m = -1\.0 m is outside \(0, 100\.0\] m"),
    ("x,y,v_mps\n0,0,3\n10,0,3\n20,1,0\n30,3,3\n", r"line 4: speed v_mps = 0\.0 m/s is outside"),
    ("x,y,x_m\n0,0,3\n10,0,3\n20,1,3\n30,3,3\n", r"line 1: header must name .*a column is named twice"),
    ("# survey export\n# easting, northing, w_tr_right_m\n0,0,3\n10,0,3\n20,1,3\n30,3,3\n",
     r"line 2: header must name .*unknown column\(s\) \['easting', 'northing'\]"),
])
def test_refusals_name_the_line_and_the_fix(tmp_path: pathlib.Path, text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_track_csv(write(tmp_path, text))


def test_size_and_point_caps(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    x, y = ellipse(60.0, 25.0, 4.0)
    f = points_csv(tmp_path, [x, y], "x,y\n")
    monkeypatch.setattr(csv_loader, "MAX_POINTS", 50)
    with pytest.raises(ValueError, match=r"road\.csv, line 52: more than 50 points; fix: thin the points"):
        load_track_csv(f)
    monkeypatch.setattr(csv_loader, "MAX_FILE_BYTES", 1000)
    with pytest.raises(ValueError, match=r"road\.csv: the file is .* MiB; at most 0 MiB"):
        load_track_csv(f)


def test_self_crossing_check_work_is_linear_and_clusters_are_refused(tmp_path: pathlib.Path) -> None:
    work = []
    for n in (10_000, 100_000):
        t = np.linspace(0.0, 2.0 * math.pi, n + 1)
        xy = np.column_stack((1000.0 * np.cos(t), 400.0 * np.sin(t) + 50.0 * np.sin(7.0 * t)))
        res = segment_intersections(xy, closed=True)
        assert res.pairs.shape == (0, 2)
        work.append(res.candidates / n)
    assert work[1] < 2.0 * work[0] + 1.0 and work[1] < 10.0          # tests per segment do not grow with n
    rng = np.random.default_rng(1)
    tangle = rng.uniform(0.0, 0.05, (5000, 2))                          # 5000 points on 5 cm: quadratic if allowed
    with pytest.raises(TooDenseError):
        segment_intersections(tangle, closed=False)
    spike = np.vstack((np.column_stack((np.linspace(0.0, 100.0, 2000), np.zeros(2000))), [[50.0, 50.0]],
                       tangle[:3000] + np.array([120.0, 0.0])))
    f = points_csv(tmp_path, [spike[:, 0], spike[:, 1]], "x,y\n", fmt="{:.17g}")
    with pytest.raises(ValueError, match=r"road\.csv, lines \d+-\d+: .*cell.*; fix: thin or remove those points"):
        load_track_csv(f, closed=False)


def test_segment_intersections_match_brute_force() -> None:
    from vtrack_gym.tracks.geometry import segments_intersect

    rng = np.random.default_rng(7)
    for trial in range(200):
        m = int(rng.integers(4, 30))
        xy = rng.normal(size=(m, 2)) * rng.uniform(0.1, 100.0)
        if trial % 3 == 0:
            xy = np.round(xy)                                   # collinear and touching cases
        closed = bool(trial % 2)
        if closed:
            xy = np.vstack((xy, xy[:1]))
        i, j = np.triu_indices(xy.shape[0] - 1, 2)
        if closed:
            keep = ~((i == 0) & (j == xy.shape[0] - 2))
            i, j = i[keep], j[keep]
        hit = segments_intersect(xy[i], xy[i + 1], xy[j], xy[j + 1])
        expected = set(zip(i[hit].tolist(), j[hit].tolist(), strict=True))
        assert set(map(tuple, segment_intersections(xy, closed).pairs.tolist())) == expected


def test_path_widths_validation_and_pickle() -> None:
    import pickle

    base = Path.from_curvature([(100.0, 0.0)], ds_m=1.0)
    n = base.n_samples
    widths = np.column_stack((np.full(n, 3.0), np.linspace(2.0, 5.0, n)))
    p = Path(base.table, 1.0, widths_m=widths, v_ref_mps=np.full(n, 12.0))
    assert np.array_equal(p.half_widths_rows(), widths) and np.all(base.half_widths_rows() == base.half_width_m)
    left, right = p.half_widths(np.array([0.0, 50.5, 100.0, 500.0]))
    assert np.allclose(left, 3.0) and np.allclose(right, [2.0, 3.515, 5.0, 5.0])
    q = pickle.loads(pickle.dumps(p))
    assert np.array_equal(q.widths_m, widths) and not q.widths_m.flags.writeable
    assert path_digest(q) == path_digest(p) != path_digest(base)
    with pytest.raises(ValueError, match=r"Path\.widths_m must have shape \(101, 2\)"):
        Path(base.table, 1.0, widths_m=widths[:-1])
    with pytest.raises(ValueError, match=r"Path\.widths_m must be in \(0\.0, 100\.0\] m \(row 3"):
        Path(base.table, 1.0, widths_m=np.where(np.arange(n)[:, None] == 3, -1.0, widths))
    with pytest.raises(ValueError, match=r"Path\.v_ref_mps must have shape \(101,\)"):
        Path(base.table, 1.0, v_ref_mps=np.ones(3))


def test_load_track_resolves_names_files_and_paths(tmp_path: pathlib.Path) -> None:
    hc = handling_course()
    assert np.array_equal(load_track("handling_course").table, hc.table)
    assert load_track(hc) is hc
    assert track_names()[:2] == ("handling_course", "double_lane_change") and "iso3888_1" in track_names()
    assert load_track("iso3888_1").length_m > 0  # one registry: a manoeuvre is a built-in track too
    with pytest.raises(ValueError, match=r"nurburgring: track file not found \(built-in tracks: handling_course, "):
        load_track("nurburgring")
    with pytest.raises(ValueError, match="track must be a CSV file path"):
        load_track(3.0)  # type: ignore[arg-type]
    x, y = ellipse(60.0, 25.0, 4.0)
    assert load_track(points_csv(tmp_path, [x, y], "x,y\n", fmt="{:.17g}")).closed
