"""The one comparison of recorded episodes with their pins (``tests/pin_compare.py``), on small made-up episodes:
the rules the id, numerics and control-mode pins share, and where the last two differ (``same_signals``)."""

from __future__ import annotations

import numpy as np
import pytest
from env_fingerprint import Episode
from pin_compare import ATOL, BLOCK_STEPS, FLOAT32_RTOL, RTOL, episode_mismatches, pin_mismatches


def _episode(signals: list[str], sums: np.ndarray, end_metrics: dict[str, float] | None = None) -> Episode:
    return Episode({"seed": 0, "steps": 100}, signals, np.array([s.startswith("obs[") for s in signals]), sums,
                   np.abs(sums), end_metrics or {})


def _pin(ep: Episode, **extra: object) -> dict[str, object]:
    return {"exact": dict(ep.exact), "signals": list(ep.signals), "blocks": "k", **extra}


SUMS = np.array([[1.0, 2.0], [3.0, 4.0]])


def test_the_tolerances_are_the_pins() -> None:
    assert (RTOL, FLOAT32_RTOL, ATOL, BLOCK_STEPS) == (1e-9, 2.0 ** -22, 1e-11, 50)


def test_an_unchanged_episode_matches_and_each_part_is_checked() -> None:
    ep = _episode(["obs[0]", "reward"], SUMS, {"rms": 0.5})
    pin = _pin(ep, end_metrics={"rms": 0.5})
    assert episode_mismatches(ep, pin, SUMS.copy()) == []
    moved = dict(pin, exact={"seed": 0, "steps": 99})
    assert episode_mismatches(ep, moved, SUMS) == [f"discrete outcome {ep.exact} != pinned {moved['exact']}"]
    assert episode_mismatches(ep, dict(pin, end_metrics={"rms": 0.5 * (1 + 1e-6)}), SUMS)[0].startswith("rms")


def test_float32_and_float64_signals_have_their_own_tolerance() -> None:
    ep = _episode(["obs[0]", "reward"], SUMS)
    within32 = SUMS + np.array([[1.0 * FLOAT32_RTOL * 0.5, 0.0], [0.0, 0.0]])
    assert episode_mismatches(ep, _pin(ep), within32) == []
    beyond64 = SUMS + np.array([[0.0, 0.0], [0.0, 4.0 * 1e-6]])
    assert [m.split(":")[0] for m in episode_mismatches(ep, _pin(ep), beyond64)] == ["reward"]


@pytest.mark.parametrize("same_signals", [False, True])
def test_a_signal_added_later_only_fails_when_the_signals_must_be_the_same(same_signals: bool) -> None:
    old = _episode(["obs[0]", "reward"], SUMS)
    now = _episode(["obs[0]", "reward", "new"], np.hstack([SUMS, np.ones((2, 1))]))
    found = episode_mismatches(now, _pin(old), SUMS, same_signals=same_signals)
    assert found == ([f"signals {now.signals} != pinned {old.signals}"] if same_signals else [])
    gone = _episode(["obs[0]"], SUMS[:, :1])
    assert episode_mismatches(gone, _pin(old), SUMS) == ["pinned signals missing: ['reward']"]


def test_pin_mismatches_numbers_the_episodes(tmp_path) -> None:
    ep = _episode(["obs[0]", "reward"], SUMS)
    np.savez(tmp_path / "b.npz", k=SUMS, off=SUMS * 2.0)
    assert pin_mismatches([ep, ep], [_pin(ep), _pin(ep)], tmp_path / "b.npz") == []
    found = pin_mismatches([ep, ep], [_pin(ep), dict(_pin(ep), blocks="off")], tmp_path / "b.npz")
    assert found and all(m.startswith("episode 1: ") for m in found)
