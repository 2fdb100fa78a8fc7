"""Score policies on a suite: rollouts, metrics, leaderboard rows, figures (what ``vtrack benchmark`` runs)."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym

from vtrack_gym.evaluation.board import build_board
from vtrack_gym.evaluation.episode_score import (  # noqa: F401  (re-exported: benchmark.score_episode & co.)
    policy_factories,
    policy_preset,
    score_episode,
    success_metrics,
    vehicle_label,
)
from vtrack_gym.evaluation.store import ResultRow, ResultStore
from vtrack_gym.evaluation.suites import Episode, base_suite, primary_metric, suite_episodes, suite_label, with_vehicle
from vtrack_gym.evaluation.trace import Trace

log = logging.getLogger(__name__)

CONTROL_COLUMNS: tuple[str, ...] = (
    "max_steering_rate_degps", "rms_steering_rate_degps", "max_steering_acc_degps2", "rms_steering_acc_degps2",
    "max_lateral_jerk_mps3", "rms_lateral_jerk_mps3", "max_yaw_rate_error_degps", "rms_yaw_rate_error_degps",
    "track_limit_violations", "min_edge_margin_m",
)
"""The control metrics (``metrics.control_metrics``) and, on a track judged by ``track_limits=``, its excursions and
the body's least clearance to an edge (missing for the other rows)."""
LEADERBOARD_COLUMNS: tuple[str, ...] = (
    "rms_e_y_m", "max_e_y_m", "rms_e_phi_deg", "rms_hand_wheel_deg", "max_hand_wheel_deg", "max_a_y_mps2",
    "max_roll_deg", "itae", "cones_hit", "comfort_a_v_mps2", "steering_reversals_per_s",
    "policy_time_p50_us", "policy_time_p95_us", "policy_time_max_us", "policy_real_time_factor", "solver_failures",
    *CONTROL_COLUMNS,
)
"""Every suite's leaderboard columns (every table format and the HTML board): the paper's metrics, then the policy's
own compute per decision (``metrics.compute_metrics``: p50/p95/max [us], real-time factor at the control period)
and its failed solves, then ``CONTROL_COLUMNS``."""
ENTRY_SPEED_COLUMNS: tuple[str, ...] = ("max_entry_speed_kmh", "entry_speed_bound_kmh", "entry_speed_fraction",
                                         "above_physical_bound")
"""The ISO 3888-1/-2 rows' entry-speed search (``entry_speed.max_entry_speed_kmh``): the highest passing entry speed
[km/h], the car's physical bound [km/h], their ratio [-] and whether some speed above the bound passed (0/1)."""
SUITE_COLUMNS: dict[str, tuple[str, ...]] = {"maneuvers": ("max_steady_a_y_mps2", "grip_limit_a_y_mps2",
                                                            "mu_g_mps2", *ENTRY_SPEED_COLUMNS)}
"""Extra leaderboard columns of a suite: ISO 4138's lateral acceleration reached on the circle and mu g, the ISO
3888 entry-speed search (``ENTRY_SPEED_COLUMNS``; missing for the other manoeuvres)."""


def suite_columns(suite: str) -> tuple[str, ...]:
    """The leaderboard columns of ``suite``: ``LEADERBOARD_COLUMNS`` plus its ``SUITE_COLUMNS``."""
    return LEADERBOARD_COLUMNS + SUITE_COLUMNS.get(base_suite(suite), ())


def episode_scorer(suite: str, make: Any) -> Any:
    """What scores one episode of ``suite`` for the policy factory ``make`` (``parallel.EpisodeTask.score``):
    ``score_episode``, and on the ``maneuvers`` suite ``entry_speed.EntrySpeedScore`` (the same row, plus the
    entry-speed search on the ISO 3888 episodes, with fresh policies from ``make``)."""
    if base_suite(suite) != "maneuvers":
        return score_episode
    from vtrack_gym.evaluation.entry_speed import EntrySpeedScore

    return EntrySpeedScore(make)


def score_policy(name: str, make: Any, episodes: Sequence[Episode], suite: str,
                 progress: Any = None) -> tuple[list[ResultRow], list[Trace]]:
    """Run ``make(env) -> policy`` on every episode; returns the leaderboard rows and the traces."""
    rows, traces = [], []
    for ep in episodes:
        env = gym.make(ep.env_id, **ep.make_kwargs)
        try:
            row, trace = episode_scorer(suite, make)(name, make(env), env, ep, suite)
        finally:
            env.close()
        log.debug("%s on %s seed %s: %s", name, ep.env_id, ep.seed, row.termination)
        rows.append(row)
        traces.append(trace)
        if progress is not None:
            progress.update(1)
    return rows, traces


def run_benchmark(suite: str = "paper", store: ResultStore | None = None, policies: Sequence[str] | None = None,
                  figures_dir: str | Path | None = None, quick: bool = False,
                  show_progress: bool = True, seeds: Sequence[int] | None = None,
                  vehicle: str | None = None, workers: int | None = 1, backend: str = "local") -> dict[str, Any]:
    """Score every policy on ``suite``; write rows to ``store`` and figures under ``figures_dir``.

    ``vehicle``: the car (a name of ``vehicle.list_vehicles()`` or a vehicle file; default the paper's car).

    ``seeds`` replaces the suite's seeds (``suite_episodes``; default: seed 0 for ``paper``, which is deterministic
    without sensor noise, five fixed seeds for ``robust``).

    Rows are stored under ``suite_label(suite, quick, seeds)``: the suite's name for its standard episodes, else
    e.g. ``robust[seeds=7]`` or ``robust[quick]`` (``result["suite"]``), never ranked with the standard board.

    ``workers``/``backend``: where the episodes run (``vtrack_gym.evaluation.parallel.run_tasks``; the rows are
    the same for any number of workers). The figures go to this run's own folder under ``figures_dir``
    (``figure_runs.run_folder``: suite, policy set, car and envs), recorded in every row's ``options["figures"]``.

    Returns ``{"rows": [...], "traces": {env_id: [Trace, ...]}, "figures": [paths], "suite": label}``.
    """
    from vtrack_gym.evaluation.parallel import EpisodeTask

    episodes = with_vehicle(suite_episodes(suite, quick=quick, seeds=seeds), vehicle)
    label = suite_label(suite, quick, seeds)
    factories = policy_factories(policies)
    tasks = [EpisodeTask(name, make, ep, label, episode_scorer(label, make),
                         keep_trace=ep.seed == episodes[0].seed or suite == "paper")
             for name, make in factories.items() for ep in episodes]
    all_rows, traces_by_env, folder = score_tasks(tasks, figures_dir, vehicle, workers, backend,
                                                  f"vtrack benchmark ({suite})" if show_progress else None)
    if store is not None:
        store.add(all_rows)
    figures = (write_figures(traces_by_env, all_rows, folder, vehicle=vehicle,
                             maneuvers=suite == "maneuvers") if folder is not None else [])
    return {"rows": all_rows, "traces": traces_by_env, "figures": figures, "suite": label}


def score_tasks(tasks: Sequence[Any], figures_dir: str | Path | None, vehicle: str | None, workers: int | None,
                backend: str, progress_label: str | None,
                ) -> tuple[list[ResultRow], dict[str, list[Trace]], Path | None]:
    """Run ``tasks`` (``parallel.EpisodeTask``); their rows (tagged with the run's figure folder when
    ``figures_dir`` is given), the kept traces by env, and that folder (None without ``figures_dir``)."""
    from vtrack_gym._progress import progress_bar
    from vtrack_gym.evaluation.figure_runs import FIGURES_OPTION, run_folder
    from vtrack_gym.evaluation.parallel import run_tasks

    folder_name = None
    if figures_dir is not None and tasks:
        folder_name = run_folder(tasks[0].suite, [t.policy_id for t in tasks], vehicle_label(vehicle),
                                 [t.episode.env_id for t in tasks])
    with progress_bar(total=len(tasks), desc=progress_label or "", unit="episode",
                      disable=progress_label is None) as bar:
        results = run_tasks(tasks, workers, backend, progress=bar)
    rows: list[ResultRow] = []
    traces_by_env: dict[str, list[Trace]] = {}
    for row, trace in results:
        if folder_name is not None:
            row = dataclasses.replace(row, options={**row.options, FIGURES_OPTION: folder_name})
        rows.append(row)
        if trace is not None:
            traces_by_env.setdefault(trace.env_id, []).append(trace)
    return rows, traces_by_env, None if folder_name is None else Path(figures_dir) / folder_name


def write_figures(traces_by_env: dict[str, list[Trace]], rows: Sequence[ResultRow], figures_dir: str | Path,
                  vehicle: str | None = None, maneuvers: bool = False) -> list[Path]:
    """Trajectory and signal figures per env, and SMC-vs-MPC deviation-rate bars (the episode of the traces' seed)
    when both were scored; ``maneuvers``: one ``plots.plot_maneuver`` figure per manoeuvre instead
    (``<env>_maneuver.png``). When a policy has more than one episode in an env (a multi-seed suite such as
    ``robust``), also ``policy_summary.png`` (``plots.plot_policy_summary``): per env the primary metric over the
    successful episodes with its 95 % bootstrap interval and the success rate, per policy."""
    from vtrack_gym.evaluation import plots

    out = Path(figures_dir)
    files = []
    for env_id, traces in traces_by_env.items():
        env = gym.make(env_id, **({} if vehicle is None else {"vehicle": vehicle}))
        env.reset(seed=traces[0].seed or 0)
        stem = env_id.replace("/", "_").replace("-", "_").lower()
        if maneuvers:
            files.append(plots.plot_maneuver(traces, env.unwrapped.current_path, out / f"{stem}_maneuver.png",
                                             title=f"{env_id}: trajectories, steering and lateral acceleration"))
            env.close()
            continue
        files.append(plots.plot_trajectories(traces, env.unwrapped.current_path, out / f"{stem}_trajectories.png"))
        files.append(plots.plot_signals(traces, out / f"{stem}_signals.png"))
        env.close()
        by_policy = {r.policy_id: r.metrics for r in rows if r.env_id == env_id and r.seed == traces[0].seed}
        if "smc" in by_policy and "mpc" in by_policy:
            prefix = "max_" if env_id.startswith("DLC") else "rms_"
            keys = [f"{prefix}{k}" for k in ("hand_wheel_deg", "e_y_m", "e_phi_deg", "a_y_mps2", "roll_deg")]
            files.append(plots.plot_deviation_rates("smc", by_policy["smc"], "mpc", by_policy["mpc"], keys,
                                                    out / f"{stem}_mpc_vs_smc.png", env_id=env_id,
                                                    seed=traces[0].seed))
    episodes: dict[tuple[str, str, str, str], int] = {}
    for r in rows:
        key = (r.env_id, r.policy_id, r.policy_preset, r.policy_hash)
        episodes[key] = episodes.get(key, 0) + 1
    if rows and max(episodes.values()) > 1:
        suites = {r.suite for r in rows}
        primary = primary_metric(suites.pop() if len(suites) == 1 else "")
        files.append(plots.plot_policy_summary(summarise(rows, (primary,)), primary, out / "policy_summary.png"))
    return files


def summarise(rows: Sequence[ResultRow], columns: Sequence[str] = LEADERBOARD_COLUMNS) -> list[dict[str, Any]]:
    """Leaderboard entries straight from result rows: the same policy keys, success verdicts, ranking,
    aggregation and NaN rule as ``ResultStore.leaderboard`` (``vtrack_gym.evaluation.board``; primary metric of
    the rows' suite)."""
    suites = {r.suite for r in rows}
    primary = primary_metric(suites.pop() if len(suites) == 1 else "")
    return build_board((row_record(r) for r in rows), columns, primary)


def row_record(r: ResultRow) -> dict[str, Any]:
    """A fresh row as the record ``build_board`` aggregates (the fields of a stored row it reads)."""
    return {"env_id": r.env_id, "options": r.options, "policy_id": r.policy_id, "policy_preset": r.policy_preset,
            "policy_hash": r.policy_hash, "completed": int(r.termination == "completed"), "success": int(r.verdict()),
            "termination": r.termination, "wall_time_per_step_s": r.wall_time_per_step_s, "metrics": r.metrics,
            "suite": r.suite, "seed": r.seed}
