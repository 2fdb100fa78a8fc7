"""The exact gate judge reads only its own rows: its verdicts do not depend on the memory behind them.

``tracks.gate_judge`` used ``tracks.judge.reach_m`` on its 3-entry body row (front, rear, half width); that kernel
reads an 11-entry row (the wheel points too), so it read 8 floats beyond the array, and the branch and bound's
Lipschitz bound, and with it the least clearance found, depended on whatever lay there. The planned -v2 lines
(their margin re-plans read that clearance) and the -v2 ids' behaviour then changed with the process's memory
layout. Here the memory behind the row is filled with large values, and the pinned -v2 episodes run in processes
whose memory is laid out otherwise."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.tracks.gate_judge import path_gate_clearance_m, rect_reach_m, sweep_gate

TESTS = Path(__file__).resolve().parent
BODY = (1.915, -2.835, 0.958)
GATE = np.array([100.0, 0.0, 0.0, 12.0, 1.1788, -1.1788])


def _body_followed_by(value: float) -> np.ndarray:
    """The body row as a 3-entry view of a longer array whose further entries are ``value``."""
    backing = np.full(16, value)
    backing[:3] = BODY
    return backing[:3]


def test_rect_reach_is_the_farthest_corner() -> None:
    assert rect_reach_m(np.array(BODY)) == math.hypot(2.835, 0.958)


@pytest.mark.parametrize("behind", [0.0, 1e3, -7.5])
def test_sweep_does_not_read_beyond_the_body_row(behind: float) -> None:
    pose0, pose1 = np.array([95.0, 0.55, 0.02]), np.array([96.4, 0.62, 0.09])
    want = sweep_gate(pose0, pose1, np.array(BODY), GATE, 1e-3, 0.05)
    assert sweep_gate(pose0, pose1, _body_followed_by(behind), GATE, 1e-3, 0.05) == want


def test_kernels_stay_in_bounds() -> None:
    """numba's bounds checks on: the judge's kernels raise on any read beyond an array (fresh kernel cache)."""
    code = ("import numpy as np\nfrom vtrack_gym.tracks.gate_judge import sweep_gate\n"
            f"b = np.array({BODY!r}); g = np.array({GATE.tolist()!r})\n"
            "print(sweep_gate(np.array([95., .55, .02]), np.array([96.4, .62, .09]), b, g, 1e-3, 0.05))\n")
    env = {**os.environ, "NUMBA_BOUNDSCHECK": "1", "NUMBA_CACHE_DIR": str(TESTS.parent / ".pytest_cache" / "bc")}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]


RECORD = """import json, sys
junk = [bytearray(k * {step}) for k in range(1, {count})]
sys.path.insert(0, {tests!r})
from env_fingerprint import mismatches, record
print(json.dumps({{i: mismatches(i, record(i)) for i in {ids!r}}}))
"""


@pytest.mark.slow
@pytest.mark.parametrize("count,step", [(7, 24), (40, 8)])
def test_v2_pins_hold_in_other_memory_layouts(count: int, step: int) -> None:
    ids = ["vtrack/ISO3888-1-v2", "vtrack/ISO3888-2-v2"]
    code = RECORD.format(step=step, count=count, tests=str(TESTS), ids=ids)
    env = {**os.environ, "PYTHONHASHSEED": str(count)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {i: [] for i in ids}


def test_offline_clearance_independent_of_row_memory() -> None:
    from vtrack_gym.tracks.feasibility import planned_maneuver
    from vtrack_gym.vehicle.catalog import resolve_vehicle

    path = planned_maneuver("iso3888_2", resolve_vehicle(None), 0.02, 2).path
    plain = path_gate_clearance_m(path, np.array(BODY), step_m=0.05)
    assert np.array_equal(path_gate_clearance_m(path, _body_followed_by(1e3), step_m=0.05), plain)


@pytest.mark.parametrize("into", [0.001, -0.001])
def test_a_side_one_millimetre_into_a_cone_line_between_two_steps(into: float) -> None:
    """Driving straight along a lane, the body's left side 1 mm beyond (or short of) the left cone line: the
    swept clearance is -1 mm (or +1 mm) exactly, though no control step's pose starts inside the lane."""
    front, rear, half = BODY
    y = GATE[4] - half + into
    pose0, pose1 = np.array([GATE[0] - front - 0.2, y, 0.0]), np.array([GATE[0] - front + 0.133, y, 0.0])
    assert sweep_gate(pose0, pose1, np.array(BODY), GATE, 1e-3, 0.05) == pytest.approx(-into, abs=1e-12)
