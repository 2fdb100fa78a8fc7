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
from vtrack_gym.evaluation.figures import plots
from vtrack_gym.evaluation.rollouts.rollout import rollout


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


def _rows(max_e_y: dict[str, list[float | None]]) -> list:
    """Robust-suite rows of DLC120-v0, one per seed; a None metric is a failed (off-road) episode."""
    from vtrack_gym.evaluation.storage.store import ResultRow

    return [ResultRow(suite="robust", env_id="DLC120-v0", policy_id=name, policy_hash=name[:4], seed=seed,
                      metrics={"max_e_y_m": v if v is not None else 3.0}, success=v is not None,
                      termination="completed" if v is not None else "off_road", wall_time_per_step_s=1e-4)
            for name, values in max_e_y.items() for seed, v in enumerate(values)]


def test_policy_summary_draws_the_board_interval_as_error_bars(monkeypatch, tmp_path) -> None:
    from matplotlib.container import ErrorbarContainer

    from vtrack_gym.evaluation.benchmarking.benchmark import write_figures
    from vtrack_gym.evaluation.leaderboard.board import estimate

    values = {"smc": [0.10, 0.14, 0.12, 0.20], "mpc": [0.30, None, 0.26, 0.28]}
    figs = _capture(monkeypatch)
    files = write_figures({}, _rows(values), tmp_path)  # several seeds per policy: the summary figure is written
    assert [f.name for f in files] == ["policy_summary.png"]
    ax = figs[0].axes[0]
    bars = {p.get_x() + p.get_width() / 2: p for p in ax.patches}
    names = [t.get_text() for t in ax.get_xticklabels()]
    errorbars = [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
    assert len(errorbars) == 2
    for name in ("smc", "mpc"):
        i = names.index(name)
        ok = [v for v in values[name] if v is not None]
        est = estimate(ok)
        assert est.lo < float(est) < est.hi
        bar = bars[i]
        assert bar.get_height() == pytest.approx(float(est))
        assert bar.get_facecolor()[:3] == pytest.approx(tuple(c / 255 for c in
                                                              bytes.fromhex(policy_colour(name)[1:])))
        (segments,) = [c.lines[2][0].get_segments() for c in errorbars if c.lines[0] is None
                       and c.lines[2][0].get_segments()[0][0][0] == pytest.approx(i)]
        (x0, y0), (x1, y1) = segments[0]
        assert (x0, x1) == (pytest.approx(i), pytest.approx(i))
        assert (y0, y1) == (pytest.approx(est.lo), pytest.approx(est.hi))  # board.py's interval, not another one
    texts = [t.get_text() for t in ax.texts]
    assert texts[names.index("smc")] == "success 100%\nn=4" and texts[names.index("mpc")] == "success 75%\nn=3"
    assert "mean and 95 % bootstrap CI over 3-4 episodes" in figs[0]._suptitle.get_text()


def test_policy_summary_with_one_episode_has_no_error_bar(monkeypatch, tmp_path) -> None:
    from matplotlib.container import ErrorbarContainer

    from vtrack_gym.evaluation.benchmarking.benchmark import summarise

    figs = _capture(monkeypatch)
    plots.plot_policy_summary(summarise(_rows({"smc": [0.1], "mpc": [0.2]}), ("max_e_y_m",)), "max_e_y_m",
                              tmp_path / "p.png")
    ax = figs[0].axes[0]
    assert not [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
    assert [p.get_height() for p in ax.patches] == pytest.approx([0.1, 0.2])
    assert "1 episode (no interval)" in figs[0]._suptitle.get_text()
