"""The test tiers: ``SLOW`` lists the tests that need many seconds (long laps, training, whole-report runs, soaks,
doc-site builds), marked ``slow`` at collection.

``python -m pytest -m "not slow" -n 2`` is the fast tier for a local loop; ``python -m pytest -n 2`` runs every
test (CI does). A test is listed by ``file::function`` (every parameter of it) or by its full id with the
parameters (``file::function[param]``: that case only); ``@pytest.mark.slow`` on the test works as well.
A grid listed whole can keep a few cases in the fast tier (``KEEP_FAST``, each with why it stands for the rest),
so that the fast tier still drives the code it tests while the slow tier runs the whole grid.
``tests/test_slow_tier.py`` checks that every entry still names a test.

``SB3_LOGDIR`` points stable-baselines3's default logger (a test's ``learn()`` without a logger of its own, a page
example run) into the session's pytest temporary folder, not a new ``SB3-<date>`` folder in ``$TMPDIR`` per call.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

SLOW: dict[str, str] = {
    "test_race.py::test_raceline_laps_within_limits_near_the_bound_and_beats_centreline[vtrack/Race-v0]":
        "two laps of the handling course per baseline",
    "test_race.py::test_cli_benchmark_race_suite": "two laps of both circuits per baseline",
    "test_agent_read_once.py::test_workers_drive_the_loaded_agent_without_opening_its_files[ray]": "starts Ray",
    "test_agents.py::test_behaviour_cloning_warm_start": "training",
    "test_agents.py::test_gsde_policies_export_and_agree": "training",
    "test_agents.py::test_offpolicy_train_export_agreement": "trains SAC and TD3",
    "test_baselines_closed_loop.py::test_default_baseline_completes[LateralTracking-v0-nmpc]": "NMPC lap, 28 s",
    "test_baselines_closed_loop.py::test_default_baseline_completes[LateralTracking-v0-pure_pursuit]": "a lap",
    "test_board_fixes.py::test_benchmark_with_other_seeds_is_ranked_apart": "two benchmarks",
    "test_board_runs.py::test_ray_backend_gives_the_rows_of_one_process": "starts Ray",
    "test_cli_output.py::test_log_lines_never_break_into_progress_bars": "a benchmark process",
    "test_cli_quiet.py::test_leaderboard_into_a_closed_pipe_exits_141_without_traceback": "a benchmark process",
    "test_cli_quiet.py::test_shell_pipe_to_head": "a benchmark through a shell pipe",
    "test_cli_quiet.py::test_sigint_during_a_forked_run_drops_the_queued_episodes": "forked benchmark processes",
    "test_dagger_agents.py::test_cli_dagger_race_runs_on_training_circuits": "two racing lines solved, 30 s",
    "test_dagger_agents.py::test_dagger_accel_laps_the_handling_course": "two laps",
    "test_race_agent.py::test_race_agent_laps_the_handling_course_within_track_limits": "a lap, 2328 m each",
    "test_race_finetune.py::test_cli_race_finetune_runs_end_to_end": "a demonstration lap and 400 SAC steps, 26 s",
    "test_dataset.py::test_dataset_round_trip": "Minari dataset of whole episodes, 16 s",
    "test_docs.py::test_page_examples_run[maneuvers.md]": "drives every manoeuvre",
    "test_docs.py::test_page_examples_run[tutorials/evaluate-your-agent.md]": "scores policies, 10 s",
    "test_docs_site.py::test_docs_site_builds_strict": "builds the MkDocs site",
    "test_entry_speed.py::test_entry_speed_bounds_of_the_shipped_cars": "a bound search per car",
    "test_entry_speed.py::test_evaluate_on_the_maneuvers_suite_gives_the_benchmarks_entry_speed_metrics": "a suite run",
    "test_entry_speed.py::test_maneuvers_suite_json_rows_carry_the_entry_speed_columns": "a suite run",
    "test_evaluate_parallel_rows.py::test_on_ray_each_row_is_stored_as_its_episode_ends": "starts Ray",
    "test_hairpin_circuit.py::test_default_baseline_laps_a_6m_hairpin_circuit[nmpc]": "NMPC lap",
    "test_kernel_cache.py::test_old_cache_directories_are_pruned": "six interpreters compiling",
    "test_maneuver_suite.py::test_maneuvers_suite_rows_and_one_figure_per_maneuver": "the manoeuvres suite",
    "test_observer.py::test_observer_mpc_completes_both_paper_scenarios": "laps",
    "test_peers_contracts.py::test_single_equals_batch_over_a_closed_loop[nmpc]": "NMPC closed loop",
    "test_plain_loop.py::test_plain_loop_equals_sb3_loop[nmpc-DLC120-v0]": "NMPC closed loop",
    "test_plain_loop.py::test_plain_loop_equals_sb3_loop[nmpc-LateralTracking-v0]": "NMPC lap, 14 s",
    "test_policy_api.py::test_verbose_logs_every_episode": "a whole suite, 11 s",
    "test_progress_lines.py::test_benchmark_progress_in_a_log_file_is_whole_lines": "a benchmark process",
    "test_random_circuits.py::test_lqr_and_mpc_lap_a_fast_circuit_at_93_percent_of_the_cars_limit": "laps",
    "test_regularised_sac.py::test_smoothness_terms_flatten_the_actor": "training",
    "test_reproduce.py::test_report_is_deterministic_apart_from_timestamp": "a second paper reproduction, 15 s",
    "test_rl_recipes.py::test_readme_plain_sb3_recipe_runs_at_smoke_size": "training",
    "test_rl_recipes.py::test_recipe_trains_exports_and_drives": "training",
    "test_scenarios.py::test_track_env_follows_the_speed_profile_and_completes_a_lap": "a lap",
    "test_store.py::test_ten_concurrent_writers_lose_nothing": "a soak of ten processes",
    "test_store_trust.py::test_byte_flip_fuzz_reads_identically_or_raises": "a fuzz of every byte region",
    "test_train_fixes.py::test_warm_start_keeps_fixed_observation_scales": "training",
    "test_trust_store.py::test_reads_while_another_process_writes_never_report_corruption": "a soak",
    "test_tuning.py::test_compiled_rollout_equals_numpy_controllers[space1-X1]": "numpy rollouts, 9 s",
    "test_tuning.py::test_evaluator_itae_equals_evaluation_metric": "whole episodes both ways, 6.5 s",
    "test_tuning.py::test_population_rollout_runs[space0]": "the MPC population on the paper budget, 8 s",
    "test_tuning_protocol.py::test_ga_tunes_a_controller_declared_through_the_protocol": "a GA run, 10 s",
    "test_numerics_pins.py": "the fast numerics' pins: two recorded episodes per id, the fast kernels compiled",
    "test_nmpc_coupled.py::test_closed_loop_lane_change_tracks_path_and_speed": "coupled NMPC episodes, 20 s+",
    "test_nmpc_coupled.py::test_the_cli_evaluates_it": "a coupled NMPC episode in a CLI run",
    "test_nmpc_coupled.py::test_the_coupled_race_form_laps_the_ring_within_the_wheels_rule": "a two-lap race",
    "test_docs.py::test_page_examples_run[baselines/nmpc_coupled.md]": "the page's coupled NMPC episodes",
    "test_tuning_ray.py": "Ray start-up in every test",
    "test_others_trust.py::test_a_crashed_ray_worker_costs_only_its_episode": "Ray start-up and a killed worker",
    "test_others_trust.py::test_ray_with_a_track_edited_during_the_run_is_a_clear_error": "Ray start-up",
    "test_cli_quiet.py::test_sigint_during_a_run_exits_130_without_traceback": "a real CLI process, kernels loaded",
    "test_maneuver_feasibility.py::test_every_registered_maneuver_is_feasible_for_every_car":
        "an env and its planned line for each of 36 manoeuvre ids x cars, up to 60 s each",
    "test_maneuver_feasibility.py::test_the_driven_exact_line_is_within_five_percent_of_the_least_curvature":
        "three exact line plans per case, 25 s each",
    "test_maneuver_feasibility.py::test_the_exact_bound_is_where_the_exact_curvature_meets_the_cars_limit":
        "an exact entry-speed bisection per case",
    "test_maneuver_feasibility.py::test_perfect_follower_of_the_planned_line_clears_every_gate":
        "a planned line per manoeuvre and car, 13 s each",
    "test_exact_margin.py::test_the_shipped_margin_is_the_planners_and_the_largest_within_the_ratio":
        "the least and the driven exact line planned per case (and the next millimetre's where cut), 6-15 s of CPU",
    "test_exact_margin.py::test_a_car_not_shipped_is_computed_on_the_machine": "three exact lines planned, 10 s",
    "test_exact_line.py::test_the_line_holds_without_numpys_avx512_code": "a fresh interpreter plans the line, 40 s",
    "test_exact_line.py::test_one_line_for_inputs_a_last_bit_apart": "the exact line planned twice, 35 s",
    "test_determinism.py::test_policy_batch_and_single_paths_agree[mpc-1e-12]": "MPC episodes both ways, 35 s",
    "test_determinism.py::test_parallel_kernel_130_matches_single_envs": "130 cars against 130 single envs",
    "test_control_modes.py::test_vector_env_car_i_is_the_single_env_seeded_seed_plus_i":
        "a vector of cars against single envs per mode, up to 60 s",
    "test_tune_registered.py::test_vtrack_tune_tunes_a_registered_controller_and_saves_its_preset": "a GA run",
    "test_tuning_protocol.py::test_package_laws_load_the_cached_kernel_in_a_fresh_process": "fresh interpreters",
    "test_race.py::test_raceline_drives_the_steering_rate_mode": "a lap",
    "test_race.py::test_cutting_a_corner_earns_less_than_staying_on": "laps",
    "test_race.py::test_raceline_laps_within_limits_near_the_bound_and_beats_centreline": "two laps per baseline",
    "test_baselines_closed_loop.py::test_default_baseline_completes": "a lap or a lane change per baseline",
    "test_docs.py::test_page_examples_run[tutorials/own-track.md]": "the page's laps, 18 s",
    "test_docs.py::test_page_examples_run[formula-student.md]": "the page's laps, 11 s",
    "test_bounded_inputs.py::test_csv_worst_cases_bounded[too_many_points]": "a worst-case CSV read, 14 s",
    "test_bounded_inputs.py::test_csv_worst_cases_bounded[long_segment]": "a worst-case CSV read, 12 s",
    "test_kernel_cache.py::test_plain_numba_cache_would_have_run_the_stale_callee": "interpreters compiling",
    "test_kernel_cache_scope.py::test_a_kernel_stays_cached_after_an_edit_elsewhere": "interpreters compiling",
    "test_env_docs.py::test_pages_follow_the_template": "every id's page built: every env made, 46 s of CPU",
    "test_exact_line.py::test_lane_change_reaches_the_bang_bang_peak_and_clears_the_cones_exactly":
        "the lane change's exact line planned, 10 s of CPU",
    "test_exact_line.py::test_the_exact_curvature_is_the_tables_at_its_rows_and_never_below_between_them":
        "an exact line planned, 10 s of CPU",
    "test_kernel_cache.py::test_editing_a_called_function_in_another_module_recompiles_the_caller":
        "interpreters compiling, 7 s of CPU",
    "test_kernel_cache.py::test_editing_a_package_kernel_module_reaches_its_callers": "interpreters compiling",
    "test_agents.py::test_ppo_train_export_load_without_torch": "trains PPO, 6.6 s of CPU",
    "test_bounded_cost.py::test_200k_point_gps_csv_fit_within_60_s_of_cpu": "a 200k-point fit, 9 s of CPU each",
    "test_agent_identity.py::test_two_agents_with_one_stem_in_one_run_are_two_rows": "a benchmark of two agents",
    "test_agent_identity.py::test_benchmark_by_relative_and_absolute_path_is_one_row": "two benchmarks",
    "test_dagger_agents.py::test_cli_dagger_tracking_runs_end_to_end": "DAgger training end to end",
    "test_maneuver_feasibility.py::test_iso3888_2_entry_speed_bound": "an entry-speed bisection per car, 3 s",
    "test_maneuver_feasibility.py::test_constant_speed_manoeuvres_ask_less_than_the_cars_limit":
        "a planned line per manoeuvre and car, 1-3 s each",
    "test_cli_quiet.py::test_log_lines_and_warnings_are_escaped_in_a_real_process": "a real CLI process",
    "test_determinism.py::test_same_seed_bit_identical_in_two_processes": "two fresh interpreters per id",
    "test_maneuver_suite.py::test_cli_maneuvers_suite_with_vehicle":
        "the manoeuvres suite for the SUV, its exact lines planned: 68 s of CPU",
    "test_finished_work.py::test_signal_ends_every_hanging_worker_within_seconds[15-143]":
        "two workers spinning until the signal (the SIGINT case stays fast)",
}
"""Test (``file::function``, ``file::function[param]`` or a whole ``file``) -> why it is slow."""

KEEP_FAST: dict[str, str] = {
    "test_maneuver_feasibility.py::test_every_registered_maneuver_is_feasible_for_every_car[vtrack/ISO3888-1-v1-suv]":
        "a gated id judged by the gates",
    "test_maneuver_feasibility.py::test_every_registered_maneuver_is_feasible_for_every_car"
    "[vtrack/ISO4138-Circle-v0-suv]": "the circle, whose ramp crosses the limit by design",
    "test_maneuver_feasibility.py::test_the_driven_exact_line_is_within_five_percent_of_the_least_curvature"
    "[iso3888_2-suv]": "one exact line against the least-curvature one",
    "test_maneuver_feasibility.py::test_the_exact_bound_is_where_the_exact_curvature_meets_the_cars_limit"
    "[iso3888_2-coast-suv]": "one exact bound",
    "test_maneuver_feasibility.py::test_perfect_follower_of_the_planned_line_clears_every_gate[slalom-suv]":
        "one planned line",
    "test_control_modes.py::test_vector_env_car_i_is_the_single_env_seeded_seed_plus_i[steer]": "the default mode",
    "test_maneuver_feasibility.py::test_iso3888_2_entry_speed_bound[suv]": "one bound",
    "test_maneuver_feasibility.py::test_constant_speed_manoeuvres_ask_less_than_the_cars_limit[slalom-suv]":
        "the line the follower case above plans",
    "test_race.py::test_raceline_laps_within_limits_near_the_bound_and_beats_centreline[vtrack/RaceRing-v0]":
        "the short ring",
    "test_baselines_closed_loop.py::test_default_baseline_completes[DLC120-v0-lqr]": "the lane change",
    "test_baselines_closed_loop.py::test_default_baseline_completes[DLC120-v0-smc]": "the paper's controller",
}
"""Cases of a grid listed in ``SLOW`` that stay in the fast tier -> what each stands for."""


def slow_reason(nodeid: str) -> str | None:
    """Why the test ``nodeid`` (``tests/file.py::name[param]``) is in the slow tier, or None."""
    file, _, rest = nodeid.partition("::")
    path = file.rsplit("/", 1)[-1]
    test = f"{path}::{rest}" if rest else path
    if test in KEEP_FAST:
        return None
    function = test.split("[", 1)[0]
    return SLOW.get(test) or SLOW.get(function) or SLOW.get(path)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if slow_reason(item.nodeid) is not None:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session", autouse=True)
def _sb3_default_logs_in_the_session_folder(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """SB3's default logger writes into one folder of the session (see the module docstring)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SB3_LOGDIR", str(tmp_path_factory.mktemp("sb3_default_logger")))
        yield
