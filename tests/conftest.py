"""The test tiers: ``SLOW`` lists the tests that need many seconds (long laps, training, whole-report runs, soaks,
doc-site builds), marked ``slow`` at collection.

``python -m pytest -m "not slow" -n 2`` is the fast tier for a local loop; ``python -m pytest -n 2`` runs every
test (CI does). A test is listed by ``file::function`` (every parameter of it) or by its full id with the
parameters (``file::function[param]``: that case only); ``@pytest.mark.slow`` on the test works as well.
``tests/test_slow_tier.py`` checks that every entry still names a test.
"""

from __future__ import annotations

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
    "test_dagger_agents.py::test_dagger_accel_laps_the_handling_course": "a lap",
    "test_dataset.py::test_dataset_round_trip": "Minari dataset of whole episodes, 16 s",
    "test_determinism.py::test_same_seed_bit_identical_in_two_processes[LateralTrackingRandom-v0]": "two laps",
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
}
"""Test (``file::function``, ``file::function[param]`` or a whole ``file``) -> why it is slow."""


def slow_reason(nodeid: str) -> str | None:
    """Why the test ``nodeid`` (``tests/file.py::name[param]``) is in the slow tier, or None."""
    file, _, rest = nodeid.partition("::")
    path = file.rsplit("/", 1)[-1]
    test = f"{path}::{rest}" if rest else path
    function = test.split("[", 1)[0]
    return SLOW.get(test) or SLOW.get(function) or SLOW.get(path)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if slow_reason(item.nodeid) is not None:
            item.add_marker(pytest.mark.slow)
