"""Shared fixtures: scene builders and paths."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

ROOT = Path(__file__).resolve().parents[1]
DATASETS = ROOT / "datasets"

def _shared() -> Path:
    """The shared source folder (``../shared`` of the checkout, or of the folder holding worktrees;
    ``ESCFIT_SHARED`` overrides)."""
    if os.environ.get("ESCFIT_SHARED"):
        return Path(os.environ["ESCFIT_SHARED"])
    for base in (ROOT.parent, ROOT.parent.parent):
        if (base / "shared").is_dir():
            return base / "shared"
    return ROOT.parent / "shared"


SHARED = _shared()

settings.register_profile("escfit", derandomize=True, deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "escfit"))


def balance_toml(*, omega0=10.0, theta0=1.0, swings=20, switching="angle", effects="") -> str:
    """A minimal balance scene as TOML text."""
    return (
        f'model = "balance"\nswitching = "{switching}"\n[oscillator]\nomega0 = {omega0!r}\ntheta0 = {theta0!r}\n'
        f"[run]\nswings = {swings}\n{effects}"
    )


@pytest.fixture
def make_scene():
    from escfit import load_scene

    def make(**kw):
        return load_scene("test.toml", text=balance_toml(**kw))

    return make


# -- measuring the false-failure rate of the sampler-based checks (benchmarks/false_failures.py) --

SEED_SHIFT = int(os.environ.get("ESCFIT_TEST_SEED_SHIFT", "0") or 0)


def pytest_configure(config):
    """With ``ESCFIT_TEST_SEED_SHIFT=k`` every emcee run of the tests draws with seed + k.

    Another library version changes the last bits of a log-probability and, through emcee's
    accept/reject steps, the whole chain after it: a fixed seed does not fix a sampler's draws
    across versions.  Running the sampler-based tests with shifted seeds shows how often they
    would fail in such an environment (benchmarks/false_failures.py); without the variable
    nothing changes.
    """
    if not SEED_SHIFT:
        return
    import importlib

    mcmc = importlib.import_module("escfit.inference.mcmc")
    real = mcmc.run_emcee

    def shifted(*args, seed: int = 0, **kwargs):
        return real(*args, seed=(int(seed) + SEED_SHIFT) % 2**32, **kwargs)

    # before the test modules are collected, so that their own imports get the shifted one
    for name in ("escfit.inference.mcmc", "escfit.inference.fit", "escfit.inference"):
        module = importlib.import_module(name)
        if getattr(module, "run_emcee", None) is real:
            module.run_emcee = shifted
    # the fit layer checks a checkpoint's seed before sampling: with the seed the sampler will use
    fit_module = importlib.import_module("escfit.inference.fit")
    real_resumable = fit_module.resumable

    def resumable(*args, seed: int = 0, **kwargs):
        return real_resumable(*args, seed=(int(seed) + SEED_SHIFT) % 2**32, **kwargs)

    fit_module.resumable = resumable


# -- the long tests --------------------------------------------------------------------------------
# Tests that cost about ten seconds or more each (a whole fit, an emcee run, a subprocess that
# imports and compiles, a sweep of hard scenes), measured with ``--durations`` on two workers.
# They carry the ``long`` mark: the README's test command leaves them out so that it runs in a few
# minutes; CI runs them in its second step (``python -m pytest -m long``, .ci/run).  A key is
# ``file::function`` (every parametrisation) or ``file::function[id]`` (one); the module fixtures
# they share (a fitted example, a set of reports) then cost nothing in the default run.
# tests/test_layout.py checks that every key names a test that exists.
LONG = {
    # whole fits through the command line or the API
    "test_long_waveform.py::test_a_five_thousand_period_decay_is_fitted_in_blocks",
    "test_long_waveform.py::test_a_record_of_thousands_of_periods_is_fitted_again_from_one_period_later",
    "test_kernel_store.py::test_the_examples_first_runs_compile_nothing[fits/real/encoder_pendulum_jensen.toml]",
    "test_kernel_store.py::test_the_examples_first_runs_compile_nothing[fits/monday_unit3.toml]",
    "test_cli_recordings.py::test_record_fit_summary_round_trip[timegrapher-t.json-timegrapher_scene.toml-None]",
    "test_cli_recordings.py::test_record_fit_summary_round_trip[timegrapher-t.csv-timegrapher_scene.toml-None]",
    "test_family_conformance.py::test_parse_simulate_read[verge]",
    "test_family_conformance.py::test_fit_summary_report",
    "test_family_conformance.py::test_derived_quantities_are_rows",
    "test_family_conformance.py::test_fit_many_in_process",
    "test_family_conformance.py::test_toy_family_recovers_its_truth",
    "test_friction_monday.py::test_monday_materials_within_their_intervals",
    "test_friction_monday.py::test_monday_speed_and_load_findings",
    "test_friction_monday.py::test_least_squares_agrees_with_posterior",
    "test_fit_recovery.py::test_emcee_intervals_contain_truth_and_lsq_within_3_se",
    "test_fit_recovery.py::test_results_file_layout_and_readers",
    "test_fit_recovery.py::test_results_are_not_overwritten_without_force",
    "test_fit_recovery.py::test_phase_mode_posterior_lies_on_the_k_ridge",
    "test_report_pages.py::test_least_squares_table_says_best_fit_with_display_units",
    "test_report_pages.py::test_posterior_table_shows_angles_in_degrees_and_labels_the_noise",
    "test_report_pages.py::test_command_line_table_uses_display_units",
    "test_report_pages.py::test_title_is_the_given_one_else_the_scene_one_escaped",
    "test_report_pages.py::test_every_family_report_has_a_data_versus_model_figure",
    "test_report_pages.py::test_sections_and_units_on_the_page",
    "test_report_pages.py::test_markdown_writes_nothing_when_an_output_exists",
    "test_readers_timegrapher.py::test_posterior_amplitudes_only",
    "test_readers_pulses.py::test_posterior_of_passage_times_covers_truth",
    "test_geneva_family.py::test_terminal_speeds_recover_mu_and_torque_scale",
    "test_geneva_family.py::test_interrupted_emcee_run_resumes_to_the_same_draws",
    "test_geneva_family.py::test_shipped_trace_example_emcee_summary_and_report",
    "test_verge_family.py::test_interrupted_run_resumes_to_the_same_draws",
    "test_verge_inference.py::test_posterior_recovers_a_known_friction_coefficient",
    "test_friction_family.py::test_known_friction_law_geometry_and_noise_recovered",
    "test_friction_inference.py::test_interval_widens_with_geometry_uncertainty",
    "test_friction_inference.py::test_posterior_structure_and_reproducibility",
    "test_shared_mu.py::test_rig_posterior_sharpens_mu_from_decay_curves",
    "test_real_recordings.py::test_multiarm_pendulum_frequency_matches_the_authors_and_dry_friction_is_found",
    "test_real_recordings.py::test_cli_fits_a_raw_recording_with_a_scene",
    "test_init_starter.py::test_init_on_the_multiarm_free_swing_finds_the_authors_frequency",
    "test_cli.py::test_balance_emcee_run_interrupted_and_resumed_from_the_command_line",
    "test_cli.py::test_fit_recipe_summary_and_reports",
    "test_sampler_runs.py::test_an_interrupted_auto_run_resumes_to_the_same_length_and_draws",
    "test_report_words.py::test_corner_plot_keeps_all_nine_parameters_of_a_waveform_fit",
    "test_report_corner.py::test_report_figures_of_nine_parameters_name_every_one",
    # the sampler's moves and coordinates on test densities
    "test_moves.py::test_the_independence_move_alone_keeps_the_skewed_posterior",
    "test_moves.py::test_de_t_reproduces_a_ridge_and_a_skewed_marginal",
    "test_moves.py::test_de_t_mixes_faster_than_de_on_a_ridge",
    "test_sampler_coordinates.py::test_the_sampler_density_omitting_the_jacobian_is_caught",
    # sweeps of hard or random scenes through every solver
    "test_stability.py::test_hard_scenes_finite_energy_balanced_and_deterministic",
    "test_stability.py::test_scale_invariance",
    "test_stability.py::test_exact_agrees_with_solve_ivp_on_well_conditioned_scenes",
    "test_balance_hard_cases.py::test_near_critical_creep_is_a_stop_for_every_solver[rk4]",
    "test_geneva.py::test_frictionless_run_conserves_energy",
    "test_segments.py::test_wobbles_of_three_percent_are_never_taken_for_pushes",
    "test_pendulum_unit.py::test_small_swings_in_degrees_are_never_taken_for_radians",
    # subprocesses that import escfit cold, compile kernels or run a batch
    "test_kernel_cache.py::test_cache_is_used_when_nothing_compiled_in_changed",
    "test_kernel_cache.py::test_kernel_recompiles_after_an_edit_of_a_called_module",
    "test_kernel_cache.py::test_plain_njit_cache_returns_the_stale_helper",
    "test_first_hour.py::test_real_recording_fit_prints_no_warning",
    "test_first_hour.py::test_ctrl_c_during_emcee_tells_how_to_resume",
    "test_first_hour.py::test_broken_pipe_exits_quietly",
    "test_first_hour.py::test_pipe_into_head",
    "test_lmfit_path.py::test_only_the_lmfit_path_imports_lmfit",
    "test_lmfit_params.py::test_the_lmfit_notebook_runs",
    "test_study_batch.py::test_local_cluster_matches_in_process",
    "test_study_batch.py::test_failed_unit_is_reported_and_the_others_are_fitted",
    "test_study_lock.py::test_sigterm_stops_the_batch_like_ctrl_c",
    "test_study_lock.py::test_a_second_run_is_refused_while_the_folder_is_locked",
    "test_study_lock.py::test_two_batches_at_once_one_is_refused_and_the_folder_stays_consistent",
    "test_batch_bench.py::test_bench_quick_json_and_plot",
    "test_attack_table.py::test_the_console_shows_escfit_lines_only",
    "test_real_corpus.py::test_what_is_not_a_free_decay_is_read_and_refused_in_one_line",
    "test_command_imports.py::test_least_squares_fit_imports_no_signal_stats_or_pandas_before_the_fit",
    "test_balance_hard_cases.py::test_heavily_damped_visible_overshoot_is_a_swing_for_every_solver[rk4]",
    "test_agreement.py::test_a_hand_driven_start_fitted_as_free_is_flagged",
    # the fuze's published run (a module fixture simulating it) and the model comparison's posteriors
    "test_verge.py::test_m739_time_and_turns_to_arm",
    "test_verge.py::test_m739_maximum_contact_forces",
    "test_verge.py::test_m739_regime_cycle",
    "test_verge.py::test_json_summary_and_netcdf",
    "test_compare.py::test_loo_ranks_and_differences_agree_with_arviz_compare",
    "test_compare.py::test_cli_text_and_json",
    "test_compare.py::test_refusals",
    "test_compare.py::test_refuses_failed_draws",
}


@pytest.hookimpl(tryfirst=True)  # before -m deselects
def pytest_collection_modifyitems(config, items):
    """Mark the tests of :data:`LONG` ``long``."""
    for item in items:
        name = item.path.name
        if f"{name}::{item.name}" in LONG or f"{name}::{getattr(item, 'originalname', item.name)}" in LONG:
            item.add_marker(pytest.mark.long)
