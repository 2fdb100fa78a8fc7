"""Score policies on a suite: rollouts, metrics, leaderboard rows, figures (what ``vtrack benchmark`` runs)."""

from __future__ import annotations

import dataclasses
import hashlib
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym

from vtrack_gym.evaluation.board import build_board, failure_reason
from vtrack_gym.evaluation.fingerprint import policy_hash
from vtrack_gym.evaluation.metrics import evaluate_trace
from vtrack_gym.evaluation.rollout import rollout
from vtrack_gym.evaluation.store import ResultRow, ResultStore
from vtrack_gym.evaluation.suites import Episode, base_suite, primary_metric, suite_episodes, suite_label, with_vehicle
from vtrack_gym.evaluation.trace import Trace
from vtrack_gym.tracks.sources import source_digest

log = logging.getLogger(__name__)

LEADERBOARD_COLUMNS: tuple[str, ...] = (
    "rms_e_y_m", "max_e_y_m", "rms_e_phi_deg", "rms_hand_wheel_deg", "max_hand_wheel_deg", "max_a_y_mps2",
    "max_roll_deg", "itae", "cones_hit", "comfort_a_v_mps2", "steering_reversals_per_s",
    "policy_time_p50_us", "policy_time_p95_us", "policy_time_max_us", "policy_real_time_factor", "solver_failures",
)
"""Every suite's leaderboard columns (every table format and the HTML board): the paper's metrics, then the policy's
own compute per decision (``metrics.compute_metrics``: p50/p95/max [us], real-time factor at the control period)
and its failed solves."""
SUITE_COLUMNS: dict[str, tuple[str, ...]] = {"maneuvers": ("max_steady_a_y_mps2", "grip_limit_a_y_mps2",
                                                            "mu_g_mps2")}
"""Extra leaderboard columns of a suite: ISO 4138's lateral acceleration reached on the circle and mu g."""


def suite_columns(suite: str) -> tuple[str, ...]:
    """The leaderboard columns of ``suite``: ``LEADERBOARD_COLUMNS`` plus its ``SUITE_COLUMNS``."""
    return LEADERBOARD_COLUMNS + SUITE_COLUMNS.get(base_suite(suite), ())


def policy_preset(policy: Any) -> str:
    """Name of the baseline preset whose config ``policy`` runs ("default" first), "custom" for another config,
    "" for a policy without presets (an agent: its identity is the weights hash)."""
    cfg = getattr(policy, "config", None)
    names = getattr(type(policy), "preset_names", None)
    if cfg is None or names is None:
        return ""
    ordered = sorted(names(), key=lambda n: n != "default")
    for name in ordered:
        try:
            if type(policy).make_config(name) == cfg:
                return name
        except ValueError:  # a file preset that is missing or invalid
            continue
    return "custom"


def success_metrics(env: gym.Env) -> dict[str, float]:
    """The leaderboard figures of ``env``'s last episode computed by its scenario's success criterion
    (``envs.criteria``: ``cones_hit`` on a gated course, the ISO 4138 figures on the circle); empty for an env
    without criteria (another package's)."""
    figures = getattr(env.unwrapped, "success_metrics", None)
    return dict(figures()) if callable(figures) else {}


def vehicle_label(vehicle: str | None) -> str | None:
    """What a row records of the car in ``options["vehicle"]``: ``None`` for the default car (or a vehicle equal to
    it), a shipped vehicle's name, or ``<file stem>-<sha256[:10]>`` of a vehicle file (two files never mix)."""
    if vehicle is None:
        return None
    from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle
    from vtrack_gym.vehicle.params import VehicleParams

    if load_vehicle(vehicle) == VehicleParams():
        return None
    if str(vehicle) in list_vehicles():
        return str(vehicle)
    file = Path(vehicle)
    return f"{file.stem}-{hashlib.sha256(file.read_bytes()).hexdigest()[:10]}"


def score_episode(name: str, policy: Any, env: gym.Env, ep: Episode, suite: str,
                  digest: str | None = None) -> tuple[ResultRow, Trace]:
    """Run ``policy`` for one episode on ``env`` (reset with ``ep``'s seed and options); its row and trace.

    The row's ``success`` is the env's verdict (the last info's ``"success"``; a row of an env without one is
    judged by completion, ``ResultRow.verdict``) and its metrics carry the success criterion's own figures
    (``success_metrics``).
    The row's ``options`` carry ``ep``'s reset options and the car (``vehicle_label(ep.vehicle)``, when not the
    default car), so cars never mix on the leaderboard, and on a track file the SHA-256 of the bytes this env read
    and drove (``track_sha256``). Its ``policy_hash`` is ``digest`` if given, else the
    policy's fingerprint taken before the rollout (a policy that changes its attributes while driving keeps one
    hash)."""
    digest = digest or policy_hash(policy)
    trace = rollout(policy, env, seed=ep.seed, options=ep.options)
    trace.policy_id = name
    metrics = evaluate_trace(trace)
    metrics.update(success_metrics(env))
    label = vehicle_label(ep.vehicle)
    options = dict(ep.options) if label is None else {**ep.options, "vehicle": label}
    driven = source_digest(tuple(getattr(env.unwrapped, "paths", ())))
    if driven is not None:   # a track file: the content this env read and drove (never the file's later state)
        options["track_sha256"] = driven
    row = ResultRow(suite=suite, env_id=ep.env_id, policy_id=name, policy_hash=digest, seed=ep.seed,
                    metrics=metrics, termination=trace.termination,
                    wall_time_per_step_s=trace.wall_time_per_step_s, options=options,
                    policy_preset=policy_preset(policy),
                    success=trace.success)
    if not row.verdict():  # the figures' legends name the reason
        trace.meta["failure_reason"] = failure_reason(trace.termination, metrics)
    return row, trace


def score_policy(name: str, make: Any, episodes: Sequence[Episode], suite: str,
                 progress: Any = None) -> tuple[list[ResultRow], list[Trace]]:
    """Run ``make(env) -> policy`` on every episode; returns the leaderboard rows and the traces."""
    rows, traces = [], []
    for ep in episodes:
        env = gym.make(ep.env_id, **ep.make_kwargs)
        try:
            row, trace = score_episode(name, make(env), env, ep, suite)
        finally:
            env.close()
        log.debug("%s on %s seed %s: %s", name, ep.env_id, ep.seed, row.termination)
        rows.append(row)
        traces.append(trace)
        if progress is not None:
            progress.update(1)
    return rows, traces


def policy_factories(names: Sequence[str] | dict[str, Any] | None = None) -> dict[str, Any]:
    """``{policy id: make(env) -> policy}`` for every baseline (default presets) and shipped agent, or for
    ``names`` (policy specs, see ``vtrack_gym.baselines.resolve``; all checked before any is returned; a dict of
    factories built already, e.g. of user code, is returned as is).

    Ids are canonical (``resolve.canonical_spec``: ``lqr:default`` is ``lqr``); ``ValueError`` when two names are
    the same policy (a policy is never ranked against itself)."""
    from vtrack_gym.baselines.resolve import canonical_ids, policy_factory, policy_names

    if isinstance(names, dict):  # factories already built: {policy id: make(env) -> policy}
        return dict(names)
    specs = [str(n).strip() for n in names] if names else list(policy_names())
    return {key: policy_factory(spec) for key, spec in canonical_ids(specs).items()}


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
    tasks = [EpisodeTask(name, make, ep, label, score_episode,
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
    from tqdm.auto import tqdm

    from vtrack_gym.evaluation.figure_runs import FIGURES_OPTION, run_folder
    from vtrack_gym.evaluation.parallel import run_tasks

    folder_name = None
    if figures_dir is not None and tasks:
        folder_name = run_folder(tasks[0].suite, [t.policy_id for t in tasks], vehicle_label(vehicle),
                                 [t.episode.env_id for t in tasks])
    with tqdm(total=len(tasks), desc=progress_label or "", unit="episode", disable=progress_label is None) as bar:
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
