"""Figures: titles name scenario, preset and seed; constant signals get no panel; bars carry value labels."""

from __future__ import annotations

import dataclasses
import itertools

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("matplotlib")

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.registry import make_policy
from vtrack_gym.envs.palette import policy_colour
from vtrack_gym.evaluation import plots
from vtrack_gym.evaluation.rollout import rollout


@pytest.fixture(scope="module")
def case1():
    env = gym.make("LateralTracking-v0")
    traces = [rollout(make_policy(name, env), "LateralTracking-v0", seed=0, max_steps=3000)
              for name in ("lqr", "stanley")]
    return traces, env.unwrapped.current_path


def _capture(monkeypatch) -> list:
    """Keep the figures ``plots`` saves (instead of closing them)."""
    figs: list = []

    def save(fig, out_file, layout=True):
        figs.append(fig)
        return out_file

    monkeypatch.setattr(plots, "_save", save)
    return figs


def test_case1_trajectories_zoom_on_the_largest_errors_with_legend_outside(case1, monkeypatch, tmp_path) -> None:
    traces, path = case1
    stations = plots.hardest_stations(traces, path)
    assert 1 <= len(stations) <= plots.N_ZOOMS
    assert all(abs(a - b) >= 80.0 for a, b in itertools.pairwise(stations))
    worst = max(float(np.abs(t["e_y_m"]).max()) for t in traces)
    peaks = [max(float(np.abs(t["e_y_m"][np.abs(t["station_m"] - s) < 1.0]).max(initial=0.0)) for t in traces)
             for s in stations]
    assert max(peaks) == pytest.approx(worst, rel=0.05)  # the largest |e_y| of all is among the zooms
    figs = _capture(monkeypatch)
    plots.plot_trajectories(traces, path, tmp_path / "t.png", preset="default")
    fig = figs[0]
    assert len(fig.axes) == 1 + len(stations)
    assert "LateralTracking-v0" in fig._suptitle.get_text() and "seed 0" in fig._suptitle.get_text()
    assert fig.legends and not fig.axes[0].get_legend()  # the legend is the figure's, below the axes
    lines = {ln.get_label(): ln.get_color() for ln in fig.axes[0].get_lines()}
    assert lines["lqr (max_steps)"] == policy_colour("lqr")


def test_signals_skip_constant_panels_and_pair_throttle_with_brake(case1, monkeypatch, tmp_path) -> None:
    traces, _ = case1
    zero_brake = [dataclasses.replace(t, signals={**t.signals, "brake_n": np.zeros(t.n_steps)}) for t in traces]
    assert not plots.signal_varies(zero_brake, "brake_n") and plots.signal_varies(zero_brake, "throttle")
    figs = _capture(monkeypatch)
    plots.plot_signals(zero_brake, tmp_path / "s.png")
    labels = [ax.get_ylabel() for ax in figs[0].axes]
    assert not any("brake" in lab for lab in labels)
    assert "throttle [-] (solid)" in labels
    assert len(figs[0].axes) == 5  # hand-wheel, e_y, a_y, roll, throttle
    assert "constant, not drawn: brake pedal force" in figs[0]._suptitle.get_text()
    with_brake = [dataclasses.replace(t, signals={**t.signals, "brake_n": np.linspace(0, 50, t.n_steps)})
                  for t in traces]
    plots.plot_signals(with_brake, tmp_path / "s2.png")
    assert len(figs[1].axes) == 6  # throttle and brake share a panel (twin axis)
    assert any("brake" in ax.get_ylabel() for ax in figs[1].axes)


def test_deviation_bars_have_labels_and_a_scale_for_small_bars(monkeypatch, tmp_path) -> None:
    ref = {"rms_e_y_m": 0.1, "rms_hand_wheel_deg": 10.0, "rms_roll_deg": 1.0}
    other = {"rms_e_y_m": 0.4, "rms_hand_wheel_deg": 9.98, "rms_roll_deg": 1.001}
    figs = _capture(monkeypatch)
    plots.plot_deviation_rates("smc", ref, "mpc", other, list(ref), tmp_path / "d.png", env_id="DLC120-v0", seed=3,
                               preset="tuned")
    ax = figs[0].axes[0]
    texts = [t.get_text() for t in ax.texts]
    assert texts == ["+300.0 %", "-0.20 %", "+0.10 %"]
    assert ax.get_yscale() == "symlog"  # 300 % next to 0.1 %: a linear axis would hide the small bars
    assert "DLC120-v0 | preset tuned | seed 3" in ax.get_title()
    assert [t.get_text() for t in ax.get_xticklabels()] == ["rms e_y [m]", "rms hand-wheel [deg]", "rms roll [deg]"]
    plots.plot_deviation_rates("smc", ref, "mpc", {"rms_e_y_m": 0.12, "rms_hand_wheel_deg": 11.0,
                                                   "rms_roll_deg": 1.1}, list(ref), tmp_path / "d2.png")
    assert figs[1].axes[0].get_yscale() == "linear"  # 20 %, 10 %, 10 %: comparable bars


def test_figures_are_written(case1, tmp_path) -> None:
    traces, path = case1
    files = [plots.plot_trajectories(traces, path, tmp_path / "t.png"), plots.plot_signals(traces, tmp_path / "s.png")]
    assert all(f.exists() and f.stat().st_size > 10_000 for f in files)
