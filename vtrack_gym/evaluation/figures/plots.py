"""The paper's figures for any set of policies (matplotlib, imported lazily; files written as PNG).

- ``plot_trajectories``: paths driven over the track (paper Figs. 8 / 15); on a long course an overview plus
  zooms on the corners where the policies deviate most, legend outside the axes;
- ``plot_signals``: hand-wheel angle, lateral error, lateral acceleration, roll, throttle + brake over time
  (Figs. 9-12, 16-18), a panel only for signals that vary;
- ``plot_maneuver``: one figure per standard manoeuvre: trajectories with the cones at their true positions,
  hand-wheel angle and lateral acceleration over distance;
- ``plot_deviation_rates``: relative difference of each metric between two policies (Figs. 13 / 19), with value
  labels and a symmetric-log scale when bars differ by more than 20x (one episode per policy);
- ``plot_policy_summary``: per env, one bar per policy of an aggregate over successful episodes (board entries,
  ``evaluation.leaderboard.board``) with its 95 % bootstrap interval as error bars and the success rate on the bar.

Every figure is titled with the scenario, preset and seed; each policy keeps its colour (``envs.palette``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vtrack_gym.envs.palette import policy_colour
from vtrack_gym.evaluation.scoring.trace import Trace

LINESTYLES: tuple[str, ...] = ("-", "--", ":", "-.")
N_ZOOMS = 3
ZOOM_HALF_SPAN_M = 40.0  # station window of a corner zoom, either side [m]
LEGEND_ROW_IN = 0.19  # height of one row of an 8 pt figure legend [in]
VARIES_ABS: dict[str, float] = {"brake_n": 1.0, "throttle": 1e-3}  # below these ranges a signal "does not vary"


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _styles(names: Sequence[str]) -> list[tuple[str, str]]:
    """(colour, linestyle) per policy: the policy's colour; repeated colours get distinct line styles."""
    seen: dict[str, int] = {}
    out = []
    for n in names:
        c = policy_colour(n)
        out.append((c, LINESTYLES[seen.get(c, 0) % len(LINESTYLES)]))
        seen[c] = seen.get(c, 0) + 1
    return out


def figure_subtitle(env_id: str, seed: int | None, preset: str | None, agents: Sequence[str] = ()) -> str:
    """'<scenario> | preset <preset> | seed <seed>' (the line every figure title carries); a figure of RL agents
    only (``agents``: their names, no preset given) says 'agent <names>' instead of the preset."""
    who = f"agent {', '.join(agents)}" if agents and preset is None else f"preset {preset or 'default'}"
    return f"{env_id} | {who} | seed {seed if seed is not None else '-'}"


def _policy_ids(traces: Sequence[Trace]) -> tuple[list[str], list[str]]:
    """The distinct policy ids of ``traces`` in order, and those of them that are scripted baselines (which have
    presets: ``smc``, ``smc:paper``)."""
    from vtrack_gym.baselines.registry import available_policies

    ids = list(dict.fromkeys(t.policy_id for t in traces))
    return ids, [i for i in ids if i.partition(":")[0] in available_policies()]


def _agents_only(traces: Sequence[Trace]) -> list[str]:
    """The policy ids of ``traces`` when none of them is a scripted baseline, else []."""
    ids, baselines = _policy_ids(traces)
    return [] if baselines else ids


def run_label(trace: Trace) -> str:
    """Legend entry of one run: '<policy> (<termination>)' (off_road, spin_out, ... name the failure), or
    '<policy> (failed: <reason>)' for a completed run its scenario judged failed (the reason the leaderboard gives,
    e.g. cones_hit), never '(completed)' for it."""
    failed = trace.success is False or "failure_reason" in trace.meta
    if trace.termination == "completed" and failed:
        return f"{trace.policy_id} (failed: {trace.meta.get('failure_reason', 'env_verdict')})"
    return f"{trace.policy_id} ({trace.termination})"


def title_preset(traces: Sequence[Trace], preset: str | None) -> str | None:
    """The preset a figure's title names: ``preset`` when given; else the one the baselines among ``traces`` share
    ('default' for a plain id such as ``smc``, 'as in the legend' when they differ), followed by '(baselines)' when
    RL agents share the figure; None for a figure of agents only."""
    ids, baselines = _policy_ids(traces)
    if preset is not None or not baselines:
        return preset
    presets = {i.partition(":")[2] or "default" for i in baselines}
    named = presets.pop() if len(presets) == 1 else "as in the legend"
    return named if len(baselines) == len(ids) else f"{named} (baselines)"


def _title(fig: Any, head: str, traces: Sequence[Trace], preset: str | None) -> None:
    subtitle = figure_subtitle(traces[0].env_id, traces[0].seed, title_preset(traces, preset), _agents_only(traces))
    fig.suptitle(f"{head}\n{subtitle}", fontsize=10)


def hardest_stations(traces: Sequence[Trace], path: Any, n: int = N_ZOOMS, min_gap_m: float = 80.0) -> list[float]:
    """Stations [m] of the ``n`` largest across-policy |e_y| peaks, at least ``min_gap_m`` apart."""
    grid = np.arange(0.0, float(path.length_m), 1.0)
    worst = np.zeros_like(grid)
    for tr in traces:
        idx = np.clip(np.searchsorted(grid, np.mod(tr["station_m"], path.length_m)), 0, len(grid) - 1)
        np.maximum.at(worst, idx, np.abs(tr["e_y_m"]))
    chosen: list[float] = []
    for i in np.argsort(worst)[::-1]:
        s = float(grid[i])
        if worst[i] <= 0.0 or len(chosen) == n:
            break
        d = [abs(s - c) for c in chosen]
        if path.closed:
            d = [min(x, path.length_m - x) for x in d]
        if all(x >= min_gap_m for x in d):
            chosen.append(s)
    return sorted(chosen)


def _draw_track(ax: Any, path: Any, with_cones: bool = True) -> None:
    """Centre line, and road edges where the path has headings and a half width (a ``tracks.Path``; a foreign
    env's reference, such as highway-env's lanes, gives only x, y)."""
    tab = path.table
    hw = getattr(path, "half_width_m", None)
    if hw is not None and tab.shape[1] > 2:
        nx, ny = -np.sin(tab[:, 2]), np.cos(tab[:, 2])
        for side in (1.0, -1.0):
            ax.plot(tab[:, 0] + side * float(hw) * nx, tab[:, 1] + side * float(hw) * ny, color="0.35", lw=0.8,
                    label="road edge" if side > 0 else None)
    ax.plot(tab[:, 0], tab[:, 1], color="0.6", lw=2.5, label="reference path", zorder=1)
    if with_cones:
        _draw_cones(ax, path)


def _draw_cones(ax: Any, path: Any) -> None:
    """Cones at their true positions (``tracks.gate_boundaries``: an anchored gate's fixed cone lines)."""
    gates = getattr(path, "gates", ()) or ()
    if not gates:
        return
    from vtrack_gym.tracks import gate_boundaries

    for k, gate in enumerate(gates):
        for j, line in enumerate(gate_boundaries(path, gate)):
            ax.plot(line[:, 0], line[:, 1], "^", color="goldenrod", ms=4,
                    label="cones" if k == 0 and j == 0 else None)


def _draw_traces(ax: Any, traces: Sequence[Trace], lw: float = 1.2) -> None:
    for tr, (colour, ls) in zip(traces, _styles([t.policy_id for t in traces]), strict=True):
        ax.plot(tr["x_m"], tr["y_m"], lw=lw, color=colour, ls=ls, label=run_label(tr))


def _xy_panel(ax: Any, path: Any, traces: Sequence[Trace], equal_above: float, adjustable: str = "box") -> None:
    """Track, cones and driven paths in X-Y [m]; equal axes when the track's Y extent exceeds ``equal_above`` x
    its X extent (a long straight-ish test keeps a stretched Y axis, so centimetres show)."""
    _draw_track(ax, path)
    _draw_traces(ax, traces)
    ax.set_xlabel("X [m]")
    ax.set_ylabel("Y [m]")
    tab = path.table
    if np.ptp(tab[:, 1]) > equal_above * np.ptp(tab[:, 0]):
        ax.set_aspect("equal", adjustable=adjustable)
    ax.grid(alpha=0.3)


def plot_trajectories(traces: Sequence[Trace], path: Any, out_file: str | Path, title: str = "",
                      preset: str | None = None) -> Path:
    """Driven X-Y paths of ``traces`` over the track (road edges, cone gates if any).

    A closed course gets an overview plus, per corner with one of the ``N_ZOOMS`` largest |e_y| peaks, a zoom
    on the lateral offset e_y against station (the track straightened, so centimetres show); an open track
    one panel. The legend sits below the axes, never over the track.
    """
    plt = _pyplot()
    stations = hardest_stations(traces, path) if path.closed else []
    if stations:
        fig = plt.figure(figsize=(12, 7.5), dpi=110)
        grid = fig.add_gridspec(len(stations), 2, width_ratios=(1.6, 1.0))
        ax = fig.add_subplot(grid[:, 0])
        zooms = [fig.add_subplot(grid[k, 1]) for k in range(len(stations))]
    else:
        fig, ax = plt.subplots(figsize=(10, 5), dpi=110)
        zooms = []
    _xy_panel(ax, path, traces, equal_above=0.1)
    styles = _styles([t.policy_id for t in traces])
    for k, (zax, s) in enumerate(zip(zooms, stations, strict=True)):
        label = chr(ord("A") + k)
        row = path.sample(s)
        ax.plot(float(row.x), float(row.y), "o", ms=9, mfc="none", mec="k")
        ax.annotate(label, (float(row.x), float(row.y)), xytext=(6, 6), textcoords="offset points", fontsize=10,
                    weight="bold")
        _zoom_panel(zax, traces, styles, path, s)
        zax.set_title(f"{label}: around s = {s:.0f} m (|e_y| peak {k + 1})", fontsize=8)
    if zooms:
        zooms[-1].set_xlabel("station s - corner [m]", fontsize=8)
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=8, frameon=False)
    _title(fig, title or "Driven trajectories", traces, preset)
    rows = (len(labels) + 3) // 4  # the legend's rows, each ~0.19 in at 8 pt: the axes (and their label) stay above
    fig.tight_layout(rect=(0, min(0.02 + rows * LEGEND_ROW_IN / fig.get_figheight(), 0.4), 1, 1))
    return _save(fig, out_file, layout=False)


def _zoom_panel(ax: Any, traces: Sequence[Trace], styles: Sequence[tuple[str, str]], path: Any, s0: float) -> None:
    """Lateral offset e_y [m] against station within ``ZOOM_HALF_SPAN_M`` of ``s0`` (the track straightened)."""
    for tr, (colour, ls) in zip(traces, styles, strict=True):
        ds = np.mod(tr["station_m"] - s0 + 0.5 * path.length_m, path.length_m) - 0.5 * path.length_m \
            if path.closed else tr["station_m"] - s0
        near = np.abs(ds) <= ZOOM_HALF_SPAN_M
        ax.plot(ds[near], tr["e_y_m"][near], color=colour, ls=ls, lw=1.3)
    ax.axhline(0.0, color="0.6", lw=2.0, zorder=1)
    ax.set_xlim(-ZOOM_HALF_SPAN_M, ZOOM_HALF_SPAN_M)
    ax.set_ylabel("e_y [m]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)


SIGNAL_PANELS: tuple[tuple[str, str, float], ...] = (
    ("hand_wheel_angle_rad", "hand-wheel angle [deg]", float(np.degrees(1.0))),
    ("e_y_m", "lateral error e_y [m]", 1.0),
    ("a_y_mps2", "lateral acceleration [m/s^2]", 1.0),
    ("roll_rad", "roll angle [deg]", float(np.degrees(1.0))),
    ("throttle", "throttle [-]", 1.0),
    ("brake_n", "brake pedal force [N]", 1.0),
)


def signal_varies(traces: Sequence[Trace], name: str) -> bool:
    """True if ``name`` changes by more than its ``VARIES_ABS`` threshold (default 1e-9) in any trace."""
    tol = VARIES_ABS.get(name, 1e-9)
    return any(float(np.ptp(tr[name])) > tol for tr in traces if tr.n_steps)


def plot_signals(traces: Sequence[Trace], out_file: str | Path, title: str = "", preset: str | None = None) -> Path:
    """Panels of ``SIGNAL_PANELS`` against time, one line per trace; a panel only for a signal that varies,
    throttle and brake sharing one panel (brake on the right axis)."""
    plt = _pyplot()
    pedals = [n for n in ("throttle", "brake_n") if signal_varies(traces, n)]
    panels: list[Any] = [p for p in SIGNAL_PANELS
                         if p[0] not in ("throttle", "brake_n") and signal_varies(traces, p[0])]
    if pedals:
        panels.append("pedals")
    if not panels:
        panels = [SIGNAL_PANELS[1]]
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 1.9 * len(panels) + 1.0), dpi=110, sharex=True,
                             squeeze=False)
    axes = axes[:, 0]
    styles = _styles([t.policy_id for t in traces])
    for ax, panel in zip(axes, panels, strict=True):
        if panel == "pedals":
            _pedal_panel(ax, traces, styles, pedals)
            continue
        name, label, scale = panel
        for tr, (colour, ls) in zip(traces, styles, strict=True):
            ax.plot(tr["time_s"], tr[name] * scale, lw=0.9, color=colour, ls=ls, label=tr.policy_id)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=8, frameon=False)
    constant = [p[1].split(" [")[0] for p in SIGNAL_PANELS if not signal_varies(traces, p[0])]
    head = title or "Signals"
    if constant:
        head += f" (constant, not drawn: {', '.join(constant)})"
    _title(fig, head, traces, preset)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return _save(fig, out_file, layout=False)


MANEUVER_PANELS: tuple[tuple[str, str, float], ...] = (
    ("hand_wheel_angle_rad", "hand-wheel angle [deg]", float(np.degrees(1.0))),
    ("a_y_mps2", "lateral acceleration [m/s^2]", 1.0),
)


def plot_maneuver(traces: Sequence[Trace], path: Any, out_file: str | Path, title: str = "",
                  preset: str | None = None) -> Path:
    """One figure per manoeuvre: the driven X-Y paths with the road and the cones at their true positions, then
    hand-wheel angle [deg] and lateral acceleration [m/s^2] against distance along the path (station) [m]."""
    plt = _pyplot()
    fig = plt.figure(figsize=(11, 8), dpi=110)
    grid = fig.add_gridspec(3, 1, height_ratios=(1.6, 1.0, 1.0))
    ax = fig.add_subplot(grid[0])
    _xy_panel(ax, path, traces, equal_above=0.3, adjustable="datalim")
    styles = _styles([t.policy_id for t in traces])
    first = None
    for k, (name, label, scale) in enumerate(MANEUVER_PANELS):
        pax = fig.add_subplot(grid[k + 1], sharex=first)
        first = first or pax
        for tr, (colour, ls) in zip(traces, styles, strict=True):
            pax.plot(tr["station_m"], tr[name] * scale, lw=0.9, color=colour, ls=ls)
        pax.set_ylabel(label, fontsize=8)
        pax.grid(alpha=0.3)
    pax.set_xlabel("distance along the path s [m]")
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=8, frameon=False)
    _title(fig, title or "Manoeuvre", traces, preset)
    rows = (len(labels) + 3) // 4
    fig.tight_layout(rect=(0, 0.03 * rows, 1, 1))
    return _save(fig, out_file, layout=False)


def _pedal_panel(ax: Any, traces: Sequence[Trace], styles: Sequence[tuple[str, str]], pedals: Sequence[str]) -> None:
    """Throttle on the left axis (solid), brake force on the right axis (dotted), same colour per policy."""
    if "throttle" in pedals:
        for tr, (colour, ls) in zip(traces, styles, strict=True):
            ax.plot(tr["time_s"], tr["throttle"], lw=0.9, color=colour, ls=ls, label=tr.policy_id)
        ax.set_ylabel("throttle [-] (solid)", fontsize=8)
    ax.grid(alpha=0.3)
    if "brake_n" in pedals:
        bx = ax.twinx() if "throttle" in pedals else ax
        for tr, (colour, _) in zip(traces, styles, strict=True):
            bx.plot(tr["time_s"], tr["brake_n"], lw=0.9, color=colour, ls=":")
        bx.set_ylabel("brake pedal force [N] (dotted)", fontsize=8)


def deviation_rates(reference: dict[str, float], other: dict[str, float], keys: Sequence[str]) -> dict[str, float]:
    """(other - reference) / |reference| x 100 % for every key (the paper's 'deviation rate')."""
    out = {}
    for k in keys:
        ref = reference.get(k, np.nan)
        out[k] = 100.0 * (other.get(k, np.nan) - ref) / abs(ref) if ref else np.nan
    return out


_UNIT_SUFFIXES: tuple[tuple[str, str], ...] = (("_mps2", "m/s^2"), ("_deg", "deg"), ("_rad", "rad"), ("_mps", "m/s"),
                                               ("_m", "m"), ("_s", "s"), ("_n", "N"))


def metric_label(key: str) -> str:
    """'max_hand_wheel_deg' -> 'max hand-wheel [deg]', 'rms_e_y_m' -> 'rms e_y [m]'."""
    stem, unit = key, ""
    for suffix, u in _UNIT_SUFFIXES:
        if key.endswith(suffix):
            stem, unit = key[: -len(suffix)], f" [{u}]"
            break
    head, _, rest = stem.replace("hand_wheel", "hand-wheel").partition("_")
    return f"{head} {rest}{unit}" if rest else f"{head}{unit}"


def plot_deviation_rates(reference_name: str, reference: dict[str, float], other_name: str,
                         other: dict[str, float], keys: Sequence[str], out_file: str | Path, *,
                         env_id: str = "", seed: int | None = None, preset: str | None = None) -> Path:
    """Bar chart of ``deviation_rates`` (negative: ``other`` is lower than ``reference``), each bar labelled
    with its value; a symmetric-log axis when the largest bar is over 20x the smallest non-zero one."""
    plt = _pyplot()
    rates = deviation_rates(reference, other, keys)
    vals = np.array([rates[k] for k in keys], dtype=np.float64)
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=110)
    colours = ["tab:green" if v < 0 else "tab:red" for v in vals]
    shown = np.nan_to_num(vals)
    ax.bar(range(len(keys)), shown, color=colours)
    finite = np.abs(vals[np.isfinite(vals) & (vals != 0)])
    if finite.size and finite.max() > 20.0 * finite.min():
        ax.set_yscale("symlog", linthresh=max(float(finite.min()), 0.1))
    for i, v in enumerate(vals):
        text = "n/a" if not np.isfinite(v) else (f"{v:+.2f} %" if abs(v) < 1.0 else f"{v:+.1f} %")
        ax.annotate(text, (i, shown[i]), xytext=(0, 3 if shown[i] >= 0 else -3), textcoords="offset points",
                    ha="center", va="bottom" if shown[i] >= 0 else "top", fontsize=8)
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo * 1.25 if lo < 0 else lo, hi * 1.25 if hi > 0 else hi)
    ax.set_xticks(range(len(keys)), [metric_label(k) for k in keys], rotation=25, ha="right", fontsize=8)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_ylabel(f"({other_name} - {reference_name}) / |{reference_name}| [%]")
    subtitle = figure_subtitle(env_id, seed, preset) if env_id else f"preset {preset or 'default'}"
    ax.set_title(f"Deviation rate of {other_name} relative to {reference_name} (below 0: {other_name} lower)\n"
                 f"{subtitle} | 1 episode per policy, no interval", fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    return _save(fig, out_file)


def ci_label(counts: Sequence[int]) -> str:
    """What an aggregate bar shows: 'mean and 95 % bootstrap CI over N episodes', '1 episode' (no interval), or
    the range of N when the bars aggregate different numbers of episodes."""
    from vtrack_gym.evaluation.leaderboard.board import CONFIDENCE_LEVEL

    n = sorted(set(counts))
    if n == [1]:
        return "1 episode (no interval)"
    over = f"{n[0]} episodes" if len(n) == 1 else f"{n[0]}-{n[-1]} episodes (n per bar)"
    tail = "; n=1: no interval" if 1 in n else ""
    return f"mean and {100 * CONFIDENCE_LEVEL:.0f} % bootstrap CI over {over}{tail}"


def plot_policy_summary(entries: Sequence[dict[str, Any]], primary: str, out_file: str | Path,
                        title: str = "") -> Path:
    """Per env (one panel each), a bar per policy of ``primary``'s aggregate over its successful episodes.

    ``entries``: leaderboard entries (``board.build_board`` / ``benchmark.summarise``), whose ``primary`` value is
    a ``board.Estimate``: a bar aggregating more than one episode carries its 95 % bootstrap interval (lo, hi) as
    an error bar; a bar of one episode has none. The success rate is written on each bar; a policy without a
    successful episode gets no bar, only its success rate. Colours: ``envs.palette``.
    """
    plt = _pyplot()
    envs = list(dict.fromkeys(e["env_id"] for e in entries))
    fig, axes = plt.subplots(1, len(envs), figsize=(max(4.5, 0.9 * max(
        sum(e["env_id"] == env for e in entries) for env in envs)) * len(envs), 4.2), dpi=110, squeeze=False)
    counts = []
    for ax, env in zip(axes[0], envs, strict=True):
        same = [e for e in entries if e["env_id"] == env]
        n_ok = [int(e["episodes"]) - int(e["failed"]) for e in same]
        counts.extend(n for n in n_ok if n > 0)
        names = [e["policy_id"] + (f":{e['preset']}" if e["preset"] not in ("", "default") else "") for e in same]
        means = np.array([float(e[primary]) for e in same], dtype=np.float64)
        shown = np.nan_to_num(means)
        ax.bar(range(len(same)), shown, color=[policy_colour(e["policy_id"]) for e in same])
        for i, (e, n) in enumerate(zip(same, n_ok, strict=True)):
            est = e[primary]
            lo, hi = getattr(est, "lo", np.nan), getattr(est, "hi", np.nan)
            if n > 1 and np.isfinite(lo) and np.isfinite(hi):
                ax.errorbar([i], [means[i]], yerr=[[means[i] - lo], [hi - means[i]]], fmt="none", ecolor="k",
                            capsize=4, lw=1.0)
            ax.annotate(f"success {float(e['success_rate']):.0%}\nn={n}", (i, shown[i] / 2 if shown[i] else 0.0),
                        ha="center", va="center" if shown[i] else "bottom", fontsize=7)
        ax.set_xticks(range(len(same)), names, rotation=25, ha="right", fontsize=8)
        ax.set_title(env, fontsize=9)
        ax.set_ylabel(f"{metric_label(primary)}, successful episodes", fontsize=8)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"{title or metric_label(primary) + ' per policy'}\n{ci_label(counts or [1])}", fontsize=10)
    return _save(fig, out_file)


def _save(fig: Any, out_file: str | Path, layout: bool = True) -> Path:
    """Write ``fig`` to ``out_file`` through the output gate (``vtrack_gym._io.atomic_output``: checked first,
    a temporary file renamed into place, nothing left on a full or read-only disk)."""
    import matplotlib.pyplot as plt

    from vtrack_gym._io import atomic_output

    out = Path(out_file)
    try:
        if layout:
            fig.tight_layout()
        with atomic_output(out) as tmp:
            fig.savefig(tmp, format=out.suffix.lstrip(".").lower() or None)
    finally:
        plt.close(fig)
    return out
