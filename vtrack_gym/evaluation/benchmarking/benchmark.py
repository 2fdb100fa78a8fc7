"""Score policies on a suite: rollouts, metrics, leaderboard rows, figures (what ``vtrack benchmark`` runs)."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym

from vtrack_gym.evaluation.leaderboard.board import build_board
from vtrack_gym.evaluation.rollouts.episode_score import (  # noqa: F401  (re-exported: benchmark.score_episode & co.)
    policy_factories,
    policy_preset,
    score_episode,
    success_metrics,
    vehicle_label,
)
from vtrack_gym.evaluation.scoring.rows import ResultRow
from vtrack_gym.evaluation.scoring.trace import Trace
from vtrack_gym.evaluation.storage.commit import RowCommit
from vtrack_gym.evaluation.storage.store import ResultStore
from vtrack_gym.evaluation.suite.suites import (
    Episode,
    extra_columns,
    find_suite,
    get_suite,
    primary_metric,
    suite_label,
    then_metrics,
    with_control,
    with_latency,
    with_launch,
    with_numerics,
    with_vehicle,
)

log = logging.getLogger(__name__)

CONTROL_COLUMNS: tuple[str, ...] = (
    "max_steering_rate_degps", "rms_steering_rate_degps", "max_steering_acc_degps2", "rms_steering_acc_degps2",
    "max_lateral_jerk_mps3", "rms_lateral_jerk_mps3", "max_yaw_rate_error_degps", "rms_yaw_rate_error_degps",
    "track_limit_violations", "min_edge_margin_m",
)
"""The control metrics (``metrics.control_metrics``) and, on a track judged by ``track_limits=``, its excursions and
the body's least clearance to an edge (missing for the other rows)."""
TIMING_COLUMNS: tuple[str, ...] = (
    "rms_e_v_mps", "max_e_v_mps", "time_lag_s", "comfort_a_wx_mps2", "best_lap_s", "mean_lap_s",
)
"""Tracking in time (``metrics.speed_metrics``, ``metrics.timing_metrics``): the speed error's RMS and peak [m/s],
the time lag behind the timed reference at the end [s], the ISO 2631-1 longitudinal comfort value [m/s^2] and, on a
closed path, the best and mean lap [s] (missing on an open one and in rows stored before these columns)."""
LEADERBOARD_COLUMNS: tuple[str, ...] = (
    "rms_e_y_m", "max_e_y_m", "rms_e_phi_deg", "rms_hand_wheel_deg", "max_hand_wheel_deg", "max_a_y_mps2",
    "max_roll_deg", "itae", "cones_hit", "comfort_a_v_mps2", "steering_reversals_per_s", *TIMING_COLUMNS,
    "policy_time_p50_us", "policy_time_p95_us", "policy_time_max_us", "policy_real_time_factor", "solver_failures",
    "late_decision_share", *CONTROL_COLUMNS,
)
"""Every suite's leaderboard columns (every table format and the HTML board): the paper's metrics, ``TIMING_COLUMNS``,
then the policy's own compute per decision (``metrics.compute_metrics``: p50/p95/max [us], real-time factor at the
control period), its failed solves and, with compute charged in the loop (``latency``), the share of its decisions
that were late, then ``CONTROL_COLUMNS``."""


def suite_columns(suite: str) -> tuple[str, ...]:
    """The leaderboard columns of ``suite``: ``LEADERBOARD_COLUMNS`` plus its own (``Suite.columns``)."""
    return LEADERBOARD_COLUMNS + extra_columns(suite)


def episode_scorer(suite: str, make: Any) -> Any:
    """What scores one episode of ``suite`` for the policy factory ``make`` (``parallel.EpisodeTask.score``): the
    registered suite's ``Suite.score(make)``, else ``score_episode``."""
    found = find_suite(suite)
    return score_episode if found is None else found.score(make)


def _factory_scorer(score: Any) -> Any:
    """The scorer of one policy factory's episodes in a run: ``score_episode`` becomes an ``episode_score
    .FactoryScorer`` (one fingerprint per identity, the same rows); a suite's own scorer is kept."""
    from vtrack_gym.evaluation.rollouts.episode_score import FactoryScorer

    return FactoryScorer() if score is score_episode else score


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
                  vehicle: str | None = None, workers: int | None = 1, backend: str = "local",
                  latency: str | float | None = None, control: str | None = None,
                  launch: str | None = None, numerics: str | None = None) -> dict[str, Any]:
    """Score every policy on ``suite``; write rows to ``store`` (each committed as its episode ends) and figures
    under ``figures_dir``.

    ``vehicle``: the car (a name of ``vehicle.list_vehicles()`` or a vehicle file; default the paper's car).

    ``latency``: charge each decision's compute in the loop (``envs.latency``): ``"measured"`` (the policy call's
    time) or a fixed budget in seconds; the rows record it (``options["latency"]`` / ``["latency_s"]``) and rank
    apart from the ideal ones, beside them on the board (``None``: ideal, instant decisions).

    ``control``: the control mode (``envs.control``; ``None``: each episode's own, ``steer`` for every built-in
    suite but ``trajectory``); the rows record a mode other than ``steer`` (``options["control"]``), ranked apart.

    ``launch``: how the reference of an episode that holds one set speed from rest leaves the start
    (``envs.launch``; ``"powertrain"`` in a longitudinal mode), the other episodes as they are (``episodes.
    with_launch`` with ``where_it_applies``); the rows record it (``options["protocol"]``), ranked apart.

    ``numerics``: the plant kernel (``vehicle.numerics``: ``"default"``, pinned, or ``"fast"``, SIMD; ``None``:
    the default); the rows record ``"fast"`` (``options["env_config"]["numerics"]``), ranked apart.

    ``suite``: a registered suite (``suites.suite_names()``); ``seeds`` replaces its seeds (default: its own,
    ``Suite.seeds``; ``quick``: ``Suite.quick_seeds``).

    Rows are stored under ``suite_label(suite, quick, seeds)``: the suite's name for its standard episodes, else
    e.g. ``robust[seeds=7]`` or ``robust[quick]`` (``result["suite"]``), never ranked with the standard board.

    ``workers``/``backend``: where the episodes run (``vtrack_gym.evaluation.rollouts.parallel.run_tasks``; the rows are
    the same for any number of workers). The figures go to this run's own folder under ``figures_dir``
    (``figure_runs.run_folder``: suite, policy set, car and envs), recorded in every row's ``options["figures"]``.

    Returns ``{"rows": [...], "traces": {env_id: [Trace, ...]}, "figures": [paths], "suite": label, "lost":
    [lines], "store_error": text or None}``; ``lost`` names each episode whose worker died
    (``parallel.run_tasks``), the others are all there; ``store_error``: why the store stopped taking rows (a full
    disk; logged as an error), None when every row was stored.
    """
    from vtrack_gym.baselines.resolve import recorded_id
    from vtrack_gym.evaluation.rollouts.parallel import EpisodeTask
    from vtrack_gym.vehicle.catalog import read_vehicle_once

    chosen = get_suite(suite)
    vehicle = read_vehicle_once(vehicle)   # a vehicle file: its envs and rows use the bytes read here
    episodes = with_vehicle(chosen.episodes_for(quick, seeds), vehicle)
    episodes = with_numerics(with_control(with_latency(episodes, latency), control), numerics)
    episodes = with_launch(episodes, launch, where_it_applies=True)
    label = suite_label(suite, quick, seeds)
    factories = policy_factories(policies, {ep.control for ep in episodes}, [ep.env_id for ep in episodes])
    tasks = [EpisodeTask(recorded_id(name, make), make, ep, label, score,
                         keep_trace=ep.seed == episodes[0].seed or chosen.trace_every_seed)
             for name, make in factories.items() for score in [_factory_scorer(chosen.score(make))]
             for ep in episodes]
    scored = score_tasks(tasks, figures_dir, vehicle, workers, backend,
                         f"vtrack benchmark ({suite})" if show_progress else None, store=store)
    figures = (write_figures(scored.traces_by_env, scored.rows, scored.folder, vehicle=vehicle,
                             maneuvers=chosen.figures == "maneuver") if scored.folder is not None else [])
    return {"rows": scored.rows, "traces": scored.traces_by_env, "figures": figures, "suite": label,
            "lost": scored.lost, "store_error": scored.store_error}


RowFinish = Callable[[ResultRow], ResultRow]
"""What a caller adds to each row before it is stored (e.g. a track's provenance)."""


def score_tasks(tasks: Sequence[Any], figures_dir: str | Path | None, vehicle: str | None, workers: int | None,
                backend: str, progress_label: str | None, store: ResultStore | None = None,
                finish: RowFinish | None = None) -> ScoredTasks:
    """Run ``tasks`` (``parallel.EpisodeTask``); their rows (tagged with the run's figure folder when
    ``figures_dir`` is given, then passed through ``finish``), the kept traces by env, that folder (None without
    ``figures_dir``) and the lost episodes. With ``store``, each row is committed as its episode ends, before the
    next result is waited for: an episode that finished is stored whatever happens later."""
    from vtrack_gym._progress import progress_bar
    from vtrack_gym.evaluation.figures.figure_runs import FIGURES_OPTION, run_folder
    from vtrack_gym.evaluation.rollouts.parallel import lost_line, run_tasks

    folder_name = None
    if figures_dir is not None and tasks:
        folder_name = run_folder(tasks[0].suite, [t.policy_id for t in tasks], vehicle_label(vehicle),
                                 [t.episode.env_id for t in tasks])

    def tagged(row: ResultRow) -> ResultRow:
        if folder_name is not None:
            row = dataclasses.replace(row, options={**row.options, FIGURES_OPTION: folder_name})
        return row if finish is None else finish(row)

    commit = RowCommit(store, tagged, len(tasks))   # each row stored as its episode ends
    with progress_bar(total=len(tasks), desc=progress_label or "", unit="episode",
                      disable=progress_label is None) as bar:
        try:
            results = run_tasks(tasks, workers, backend, progress=bar,
                                on_result=lambda index, result: commit(result[0], index))
        except BaseException as exc:
            commit.mark_stopped(exc)
            raise
    traces_by_env: dict[str, list[Trace]] = {}
    lost = []
    for index, result in enumerate(results):
        if index not in commit.rows:
            lost.append(lost_line(tasks[index], result))
        elif result[1] is not None:
            traces_by_env.setdefault(result[1].env_id, []).append(result[1])
    return ScoredTasks(commit.ordered(), traces_by_env,
                       None if folder_name is None else Path(figures_dir) / folder_name, lost,
                       None if commit.error is None else str(commit.error))


@dataclasses.dataclass(frozen=True)
class ScoredTasks:
    """What ``score_tasks`` returns: the rows in task order, the kept traces by env, the run's figure folder (or
    None), one line per lost episode (``parallel.lost_line``) and the store's error (None: every row stored)."""

    rows: list[ResultRow]
    traces_by_env: dict[str, list[Trace]]
    folder: Path | None
    lost: list[str]
    store_error: str | None = None


def write_figures(traces_by_env: dict[str, list[Trace]], rows: Sequence[ResultRow], figures_dir: str | Path,
                  vehicle: str | None = None, maneuvers: bool = False) -> list[Path]:
    """Trajectory and signal figures per env, and SMC-vs-MPC deviation-rate bars (the episode of the traces' seed)
    when both were scored; ``maneuvers``: one ``plots.plot_maneuver`` figure per manoeuvre instead
    (``<env>_maneuver.png``). When a policy has more than one episode in an env (a multi-seed suite such as
    ``robust``), also ``policy_summary.png`` (``plots.plot_policy_summary``): per env the primary metric over the
    successful episodes with its 95 % bootstrap interval and the success rate, per policy."""
    from vtrack_gym.evaluation.figures import plots

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
    aggregation and NaN rule as ``ResultStore.leaderboard`` (``vtrack_gym.evaluation.leaderboard.board``; primary metric
    of the rows' suite)."""
    suites = {r.suite for r in rows}
    suite = suites.pop() if len(suites) == 1 else ""
    return build_board((row_record(r) for r in rows), columns, primary_metric(suite), then_metrics(suite))


def row_record(r: ResultRow) -> dict[str, Any]:
    """A fresh row as the record ``build_board`` aggregates (the fields of a stored row it reads)."""
    return {"env_id": r.env_id, "options": r.options, "policy_id": r.policy_id, "policy_preset": r.policy_preset,
            "policy_hash": r.policy_hash, "completed": int(r.termination == "completed"), "success": int(r.verdict()),
            "termination": r.termination, "wall_time_per_step_s": r.wall_time_per_step_s, "metrics": r.metrics,
            "suite": r.suite, "seed": r.seed}
