"""benchmarks/control_modes.py and benchmarks/smc_held_speed.py: the steer / steer_accel table of the Control modes
page and the smc lane-change diagnosis measure what they say, through the public entry points."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import control_modes
import smc_held_speed


def test_the_table_compares_each_mode_with_the_steering_figure() -> None:
    """lqr on DLC120-v0: the steer row is the paper's mode (the PD-FLC's 0.515 m/s RMS), the steer_accel row within
    25 % of it with the speed law's RMS speed error; the target reads met."""
    (row,) = control_modes.table(("lqr",), ("DLC120-v0",))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:2] == ["lqr", "DLC120-v0"]
    steer_ey, steer_ev, steer_ok = (c.strip() for c in cells[2].split("/"))
    accel_ey, accel_ev, accel_ok = (c.strip() for c in cells[3].split("/"))
    assert steer_ok == accel_ok == "yes" and float(steer_ev) > 0.5 > float(accel_ev)
    assert float(cells[4]) == pytest.approx(float(accel_ey) / float(steer_ey), abs=0.006) and cells[5] == "met"
    assert cells[6] == "-"                    # DLC120-v0 starts at speed: no launch


def test_a_failed_episode_is_not_met() -> None:
    steer = {"success": True, "max_ey": 0.2, "rms_ev": 0.5, "termination": "completed"}
    spun = {"success": False, "max_ey": float("nan"), "rms_ev": 0.3, "termination": "spin_out"}
    assert control_modes._verdict(steer, spun)[1] == "not met"
    assert control_modes._verdict(steer, {**steer, "max_ey": 0.26, "rms_ev": 0.1})[1] == "not met"   # 1.3x
    assert control_modes._verdict(steer, {**steer, "max_ey": 0.24, "rms_ev": 0.1})[1] == "met"


def test_the_smc_diagnosis_counts_the_steps_at_the_rate_limit() -> None:
    """The default smc at a held set speed where it spins out (33.5 m/s): a share of the steps at the steering
    actuator's rate limit and the command far ahead of the road wheel; at 33.33 m/s in steer it completes."""
    spun = smc_held_speed.run("DLC120-v0", "steer_accel", 33.5)
    assert not spun["ok"] and spun["why"] == "spin_out"
    assert 0.1 < spun["at_limit"] < 1.0 and spun["gap"] > 0.3
    passed = smc_held_speed.run("DLC120-v0", "steer", 120.0 / 3.6)
    assert passed["ok"] and passed["max_ey"] == pytest.approx(0.2455, abs=5e-4)


def test_the_speed_band_row_counts_the_completed_lane_changes() -> None:
    """Measurement 5: the accel preset's row over 31 to 35 m/s in steer_accel counts every episode completed."""
    cells = [c.strip() for c in smc_held_speed.band("accel", "steer_accel").strip("|").split("|")]
    assert cells[:3] == ["accel", "steer_accel", f"{len(smc_held_speed.BAND_MPS)} / {len(smc_held_speed.BAND_MPS)}"]
    assert cells[4] == "`" + "Y" * len(smc_held_speed.BAND_MPS) + "`" and 0.0 < float(cells[3]) < 1.0
