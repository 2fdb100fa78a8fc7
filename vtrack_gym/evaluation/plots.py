"""The paper's figures for any set of policies (matplotlib, imported lazily; files written as PNG).

- ``plot_trajectories``: paths driven over the track (paper Figs. 8 / 15);
- ``plot_signals``: hand-wheel angle, lateral acceleration, roll, throttle and brake over time (Figs. 9-12, 16-18);
- ``plot_deviation_rates``: relative difference of each metric between two policies (Figs. 13 / 19).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vtrack_gym.evaluation.trace import Trace


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


POLICY_COLOURS: tuple[str, ...] = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
                                   "tab:pink", "tab:olive", "tab:cyan", "black", "navy", "gold")
"""Line colours per policy, in order: matplotlib's tab10 without its grey (the reference path's colour)."""


def _colour(k: int) -> str:
    return POLICY_COLOURS[k % len(POLICY_COLOURS)]


def plot_trajectories(traces: Sequence[Trace], path: Any, out_file: str | Path, title: str = "") -> Path:
    """Driven X-Y paths of ``traces`` over the track centre-line (and cone gates if the track has them)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 6), dpi=110)
    tab = path.table
    ax.plot(tab[:, 0], tab[:, 1], color="0.6", lw=3, label="reference path")
    for k, gate in enumerate(getattr(path, "gates", ()) or ()):
        s = np.linspace(gate.s_start_m, gate.s_end_m, 6)
        row = path.sample(s)
        for lat in (gate.y_left_m, gate.y_right_m):
            ax.plot(row.x - lat * np.sin(row.psi), row.y + lat * np.cos(row.psi), "^", color="tab:orange", ms=4,
                    label="cones" if k == 0 and lat == gate.y_left_m else None)
    for k, tr in enumerate(traces):
        ax.plot(tr["x_m"], tr["y_m"], lw=1.2, color=_colour(k), label=f"{tr.policy_id} ({tr.termination})")
    ax.set_xlabel("X [m]")
    ax.set_ylabel("Y [m]")
    if np.ptp(tab[:, 1]) > 0.1 * np.ptp(tab[:, 0]):
        ax.set_aspect("equal")
    ax.legend(fontsize=8)
    ax.set_title(title or f"Trajectories on {traces[0].env_id}")
    ax.grid(alpha=0.3)
    return _save(fig, out_file)


SIGNAL_PANELS: tuple[tuple[str, str, float], ...] = (
    ("hand_wheel_angle_rad", "hand-wheel angle [deg]", float(np.degrees(1.0))),
    ("e_y_m", "lateral error e_y [m]", 1.0),
    ("a_y_mps2", "lateral acceleration [m/s^2]", 1.0),
    ("roll_rad", "roll angle [deg]", float(np.degrees(1.0))),
    ("throttle", "throttle [-]", 1.0),
    ("brake_n", "brake pedal force [N]", 1.0),
)


def plot_signals(traces: Sequence[Trace], out_file: str | Path, title: str = "") -> Path:
    """One panel per signal of ``SIGNAL_PANELS`` against time, one line per trace."""
    plt = _pyplot()
    fig, axes = plt.subplots(len(SIGNAL_PANELS), 1, figsize=(9, 2.0 * len(SIGNAL_PANELS)), dpi=110, sharex=True)
    for ax, (name, label, scale) in zip(axes, SIGNAL_PANELS, strict=True):
        for k, tr in enumerate(traces):
            ax.plot(tr["time_s"], tr[name] * scale, lw=0.9, color=_colour(k), label=tr.policy_id)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=min(len(traces), 4))
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title or f"Signals on {traces[0].env_id}")
    return _save(fig, out_file)


def deviation_rates(reference: dict[str, float], other: dict[str, float], keys: Sequence[str]) -> dict[str, float]:
    """(other - reference) / |reference| x 100 % for every key (the paper's 'deviation rate')."""
    out = {}
    for k in keys:
        ref = reference.get(k, np.nan)
        out[k] = 100.0 * (other.get(k, np.nan) - ref) / abs(ref) if ref else np.nan
    return out


def plot_deviation_rates(reference_name: str, reference: dict[str, float], other_name: str,
                         other: dict[str, float], keys: Sequence[str], out_file: str | Path) -> Path:
    """Bar chart of ``deviation_rates`` (negative: ``other`` is lower than ``reference``)."""
    plt = _pyplot()
    rates = deviation_rates(reference, other, keys)
    fig, ax = plt.subplots(figsize=(8, 4), dpi=110)
    vals = [rates[k] for k in keys]
    ax.bar(range(len(keys)), vals, color=["tab:green" if v < 0 else "tab:red" for v in vals])
    ax.set_xticks(range(len(keys)), keys, rotation=30, ha="right", fontsize=8)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_ylabel(f"{other_name} vs {reference_name} [%]")
    ax.set_title(f"Deviation rate of {other_name} relative to {reference_name}")
    ax.grid(axis="y", alpha=0.3)
    return _save(fig, out_file)


def _save(fig: Any, out_file: str | Path) -> Path:
    out = Path(out_file)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return out
