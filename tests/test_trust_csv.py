"""Bounded reading of track CSVs: line, field and message length bounded before parsing, one error type
(ValueError naming file and line), plus the loader's special cases (FIFO and device tracks, decimal commas and
quotes, U+2028 and \\v, non-ASCII digits and '_', a loop closed past 200 km, a header-less x,y,v file)."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vtrack_gym.tracks.csv_loader import MAX_LINE_CHARS, load_track_csv

ROOT = Path(__file__).resolve().parents[1]
SQUARE = "0,0\n100,0\n100,100\n0,100\n0,50\n"


def _csv(tmp_path: Path, text: str, name: str = "t.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


_MEASURE = """
import resource, sys
sys.path.insert(0, {root!r})
from vtrack_gym.tracks.csv_loader import load_track_csv
try:
    load_track_csv({path!r})
except ValueError as exc:
    print(len(str(exc)))
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
"""


def test_a_64_mib_one_line_csv_is_refused_in_bounded_memory_with_a_short_message(tmp_path):
    big = tmp_path / "one_line.csv"
    with big.open("w") as fh:
        chunk = "1.5," * (1 << 18)
        for _ in range(63):                    # just under the 64 MiB file limit
            fh.write(chunk)
    script = _MEASURE.format(root=str(ROOT), path=str(big))
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout.split()
    big.unlink()
    message_chars, peak_mib = int(out[0]), int(out[1])
    assert message_chars < 400
    assert peak_mib < 800, f"peak resident memory {peak_mib} MiB"


@pytest.mark.parametrize(("text", "expected"), [
    ("x,y\n" + "1" * 5000 + ",2\n", f"line 2: the line is 5002 characters long \\(at most {MAX_LINE_CHARS}\\)"),
    ("x,y\n" + "1" * 70 + ",2\n", "line 2, column 1: a field of 70 characters"),
    ("x;y\n1,5;2,5\n", "line 2: expected 2 columns .*decimal commas"),
    ("x y\n1,5 2,5\n0 0\n", "line 2: expected 2 columns .*decimal commas"),
    ('x,y\n"1.0","2.0"\n', "line 2, column 1: not a number .*remove the quotes"),
    ("x,y\n3_0,1\n", "line 2, column 1: not a number .*digits 0-9"),
    ("x,y\n\u0663,1\n", "line 2, column 1: not a number .*digits 0-9"),
    ("x,y\n0,0\u20281,1\n2,2\n3,3\n4,4\n", "line 2: the character U\\+2028"),
    ("x,y\n0,0\x0b1,1\n2,2\n3,3\n4,4\n", "line 2: the character U\\+000B"),
    ("x,y\n0,0\x1b[2J\n", "line 2: the character U\\+001B"),
])
def test_bad_lines_name_file_line_and_fix(tmp_path, text, expected):
    path = _csv(tmp_path, text)
    with pytest.raises(ValueError, match=expected) as info:
        load_track_csv(path)
    assert str(path) in str(info.value) and len(str(info.value)) < 600


def test_a_header_of_many_long_names_gives_a_bounded_message(tmp_path):
    path = _csv(tmp_path, ",".join(f"column{k}" * 5 for k in range(100)) + "\n0,0\n")
    with pytest.raises(ValueError, match="unknown column") as info:
        load_track_csv(path)
    assert len(str(info.value)) < 1500


@pytest.mark.parametrize(("kind", "said"), [("fifo", "a FIFO"), ("device", "a character device")])
def test_fifo_and_device_tracks_are_named_as_such(tmp_path, kind, said):
    path = tmp_path / "t.csv"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")
    with pytest.raises(ValueError, match=said):
        load_track_csv(path)


def test_a_four_point_file_closing_past_200_km_is_refused(tmp_path):
    side = 60_000.0
    path = _csv(tmp_path, f"x,y\n0,0\n{side},0\n{side},{side}\n0,{side}\n")
    for closed in (None, True):
        with pytest.raises(ValueError, match="closing the loop makes the centre-line 240 km long"):
            load_track_csv(path, closed=closed)


def test_a_header_less_third_column_warns_that_it_is_read_as_elevation(tmp_path):
    rows = "".join(f"{x},{y},20.0\n" for x, y in ((0, 0), (100, 0), (200, 10), (300, 40), (400, 90)))
    with pytest.warns(UserWarning, match="third column is read as an elevation"):
        load_track_csv(_csv(tmp_path, rows), closed=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_track_csv(_csv(tmp_path, "x_m,y_m,v_mps\n" + rows, "named.csv"), closed=False)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.text(alphabet=st.characters(codec="utf-8"), max_size=6000), min_size=1, max_size=6))
def test_property_any_text_gives_a_path_or_one_short_valueerror(tmp_path, lines):
    path = _csv(tmp_path, "\n".join(lines))
    try:
        load_track_csv(path)
    except ValueError as exc:
        assert str(path) in str(exc) and len(str(exc)) < 2000
