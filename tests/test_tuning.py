"""GA tuning (vtrack_gym.tuning): search spaces, batched population controllers, reproducibility, presets."""

from __future__ import annotations

import json
import pickle

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines import preset_files as P
from vtrack_gym.baselines.mpc import MPCConfig, gain_table
from vtrack_gym.baselines.mpc_gains import population_gain_tables
from vtrack_gym.baselines.mpc_tuning import MPC_PAPER
from vtrack_gym.baselines.registry import make_policy
from vtrack_gym.baselines.smc import SMC, SMCConfig
from vtrack_gym.baselines.smc_tuning import SMC_PAPER, SMC_WORKING, PopulationSMC
from vtrack_gym.envs.pdflc import PDFLCConfig
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import itae
from vtrack_gym.tuning.ga import tune
from vtrack_gym.tuning.population import FitnessConfig, PopulationEvaluator, configs_from_vector
from vtrack_gym.tuning.spaces import BUDGETS, Budget, search_space

QUICK = Budget("quick", 3, 4)
STEPS = 400  # episodes cut at 4 s: keeps the GA tests fast (the full Case 1 lap is ~21 500 steps)


def test_paper_search_spaces_match_table_2():
    smc = {p.name: (p.low, p.high) for p in SMC_PAPER.params}
    assert smc == {"p": (0.01, 0.1), "eta": (500.0, 1000.0), "Delta": (0.1, 1.0), "G1": (0.1, 5.0),
                   "G2": (0.01, 0.1), "G3": (0.1, 1.0), "G4": (1.0, 300.0)}
    assert [p.field for p in SMC_PAPER.params] == ["pole_radps", "reaching_gain", "boundary_layer", "g1", "g2",
                                                   "g3", "g4"]
    assert [(p.name, p.low, p.high, p.index) for p in MPC_PAPER.params] == [
        (f"w{i + 1}", 0.0, 1.0, i) for i in range(12)]
    assert (BUDGETS[("smc", "paper")].generations, BUDGETS[("smc", "paper")].pop_size) == (100, 10)
    assert (BUDGETS[("mpc", "paper")].generations, BUDGETS[("mpc", "paper")].pop_size) == (200, 20)
    work = {p.name: (p.low, p.high) for p in SMC_WORKING.params}
    assert work["p"] == (1.0, 15.0) and work["G4"] == (1.0, 300.0)
    with pytest.raises(ValueError, match="unknown search space"):
        search_space("lqr", "paper")


def test_vector_maps_onto_config_fields():
    cfg, speed = configs_from_vector(SMC_WORKING, [5.0, 10.0, 0.2, 1.0, 0.05, 0.5, 100.0],
                                     SMC.make_config("hand"), PDFLCConfig())
    assert (cfg.pole_radps, cfg.reaching_gain, cfg.boundary_layer, cfg.sideslip_shift) == (5.0, 10.0, 0.2, True)
    assert (speed.g1, speed.g2, speed.g3, speed.g4) == (1.0, 0.05, 0.5, 100.0)
    mcfg, _ = configs_from_vector(MPC_PAPER, np.linspace(0, 1, 12), MPCConfig(input_weight=100.0), PDFLCConfig())
    assert mcfg.weights == tuple(np.linspace(0, 1, 12)) and mcfg.input_weight == 100.0


def test_population_smc_equals_individual_smcs():
    env = gym.make("LateralTracking-v0")
    design = env.unwrapped.design_model
    rng = np.random.default_rng(0)
    obs = rng.normal(size=(3, env.unwrapped.observation_layout.size))
    obs[:, 0] = [5.0, 10.9, 25.0]  # v_x, one inside the singular-speed guard band
    params = [(8.0, 5.0, 0.1), (3.0, 40.0, 0.02), (12.0, 1.0, 0.9)]
    pop = PopulationSMC(design, SMCConfig(), *map(np.array, zip(*params, strict=True)))
    got, _ = pop.act(obs, None)
    for i, (p, eta, delta) in enumerate(params):
        single = SMC(design, SMCConfig(pole_radps=p, reaching_gain=eta, boundary_layer=delta))
        want, _ = single.act(obs[i:i + 1], None)
        assert got[i] == pytest.approx(want[0], rel=1e-12, abs=1e-12)


def test_population_mpc_tables_equal_gain_table():
    env = gym.make("LateralTracking-v0")
    design, layout = env.unwrapped.design_model, env.unwrapped.observation_layout
    cfg = MPCConfig(input_weight=100.0, n_speeds=6)
    w = np.vstack([cfg.weights, np.random.default_rng(1).uniform(0, 1, 12)])
    speeds, tables = population_gain_tables(design, cfg, w, layout)
    for i in range(2):
        ref = gain_table(design, MPCConfig(weights=tuple(w[i]), input_weight=100.0, n_speeds=6), layout)
        np.testing.assert_allclose(speeds, ref.speeds)
        np.testing.assert_allclose(tables[i], ref.runtime, rtol=1e-9, atol=1e-12)


def test_evaluator_itae_equals_evaluation_metric():
    default = [8.0, 5.0, 0.1, 1.3187, 0.1, 0.5225, 161.5577]  # default SMC, default PD-FLC
    res = PopulationEvaluator(SMC_WORKING, max_steps=STEPS)(np.array([default, default]))
    env = gym.make("LateralTracking-v0")
    trace = rollout(make_policy("smc", env), env, seed=0, max_steps=STEPS)
    ref = itae(trace["time_s"], trace["e_y_m"])
    assert res.itae == pytest.approx([ref, ref], rel=1e-6)
    assert not res.completed.any() and np.all(res.remaining_m > 0)  # cut at STEPS: penalised as incomplete
    assert np.all(res.fitness > 1e5)


@pytest.mark.parametrize("space", [MPC_PAPER, SMC_PAPER])
def test_population_rollout_runs(space):
    X = np.random.default_rng(0).uniform(space.lower, space.upper, (2, len(space.params)))
    res = PopulationEvaluator(space, max_steps=50, also_complete=("DLC120-v0",))(X)
    assert res.fitness.shape == (2,) and np.all(np.isfinite(res.fitness)) and res.steps == 50
    assert set(res.also_completed) == {"DLC120-v0"} and "completed_DLC120-v0" in res.row(0)
    assert "max_abs_e_y_m_DLC120-v0" in res.row(0) and np.all(res.also_max_abs_e_y_m["DLC120-v0"] >= 0)


def test_constraint_scenario_error_bound_is_penalised():
    """An individual that completes the DLC but leaves its gates (max|e_y| > 0.25 m) pays per metre above it."""
    X = np.array([[8.0, 5.0, 0.1, 1.3187, 0.1, 0.5225, 161.5577]])
    strict = PopulationEvaluator(SMC_WORKING, max_steps=800, also_complete=("DLC120-v0",),
                                 fitness=FitnessConfig(also_max_e_y_m=0.0))(X)
    loose = PopulationEvaluator(SMC_WORKING, max_steps=800, also_complete=("DLC120-v0",),
                                fitness=FitnessConfig(also_max_e_y_m=5.0))(X)
    excess = strict.also_max_abs_e_y_m["DLC120-v0"][0]
    assert excess > 0.0
    assert strict.fitness[0] - loose.fitness[0] == pytest.approx(1e4 * excess, rel=1e-9)


@pytest.fixture(scope="module")
def quick_runs():
    return [tune(SMC_WORKING, QUICK, seed=7, progress=False, max_steps=STEPS) for _ in range(2)]


def test_same_seed_same_result(quick_runs):
    a, b = quick_runs
    np.testing.assert_array_equal(a.best_x, b.best_x)
    assert a.best_fitness == b.best_fitness and a.history == b.history
    assert a.episodes == QUICK.generations * QUICK.pop_size


def test_quick_run_improves_or_equals_initial_best(quick_runs):
    r = quick_runs[0]
    assert r.best_fitness <= r.initial_best_fitness
    assert all(x >= y for x, y in zip(r.history, r.history[1:], strict=False))
    assert np.all(r.best_x >= SMC_WORKING.lower) and np.all(r.best_x <= SMC_WORKING.upper)


def test_preset_round_trip(tmp_path, quick_runs):
    r = quick_runs[0]
    path = P.save_preset(tmp_path / "smc.json", "smc", r.best_config, r.best_speed_config,
                         {"seed": 7, "best_fitness": r.best_fitness, "budget": {"generations": 3}})
    loaded = P.load_preset(path)
    assert loaded["controller"] == "smc" and loaded["config"] == r.best_config
    assert loaded["speed_controller"] == {k: getattr(r.best_speed_config, k) for k in ("g1", "g2", "g3", "g4")}
    assert loaded["provenance"]["seed"] == 7 and "package_version" in loaded["provenance"]
    mpc = P.save_preset(tmp_path / "mpc.json", "mpc", MPCConfig(input_weight=100.0))
    assert P.load_preset(mpc)["config"] == MPCConfig(input_weight=100.0)


def test_make_policy_tuned_preset(tmp_path, monkeypatch):
    env = gym.make("LateralTracking-v0")
    monkeypatch.setattr(P, "PACKAGED_DIR", tmp_path)
    with pytest.raises(ValueError, match="no tuned smc preset"):
        make_policy("smc", env, preset="tuned")
    P.save_preset(tmp_path / "smc_tuned.json", "smc", SMCConfig(pole_radps=6.0))
    pol = make_policy("smc", env, preset="tuned")
    assert isinstance(pol, SMC) and pol.config.pole_radps == 6.0
    assert make_policy("smc", env, preset="tuned", reaching_gain=7.0).config.reaching_gain == 7.0
    with pytest.raises(ValueError, match="unknown"):
        make_policy("smc", env, preset="tuned", bogus=1)
    (tmp_path / "smc_tuned.json").write_text("!!python/object/apply:os.system ['echo pwned']")
    with pytest.raises(ValueError, match="not valid JSON"):
        make_policy("smc", env, preset="tuned")


def _valid() -> dict:
    return P.preset_dict("smc", SMCConfig(), PDFLCConfig(), {"seed": 0})


@pytest.mark.parametrize("text", [
    "config:\n  pole_radps: 8.0\n",                                         # YAML
    "!!python/object/apply:os.system ['echo pwned']",                      # YAML tag
    pickle.dumps({"controller": "smc"}),                                    # pickle bytes
    b"\x80\x04\x95\x00\xff",                                                # binary garbage
    "[1, 2, 3]",
    json.dumps({**_valid(), "exec": "import os"}),                          # unknown top-level key
    json.dumps({**_valid(), "config": {**_valid()["config"], "evil": 1}}),   # unknown config field
    json.dumps({**_valid(), "speed_controller": {"g1": 1.0, "g9": 2.0}}),   # unknown speed key
    json.dumps({**_valid(), "provenance": {"seed": 0, "shell": "rm -rf"}}),  # unknown provenance key
    json.dumps(_valid()).replace('"pole_radps": 8.0', '"pole_radps": NaN'),
    json.dumps(_valid()).replace('"pole_radps": 8.0', '"pole_radps": Infinity'),
    json.dumps(_valid()).replace('"pole_radps": 8.0', '"pole_radps": 1e999'),
    json.dumps(_valid()).replace('"pole_radps": 8.0', '"pole_radps": "8"'),
    json.dumps(_valid()).replace('"pole_radps": 8.0', '"pole_radps": true'),
    json.dumps(_valid()).replace('"pole_radps": 8.0', '"pole_radps": -1.0'),
    json.dumps(_valid()).replace('"seed": 0', '"seed": -Infinity'),
    json.dumps({**_valid(), "controller": "lqr"}),
    json.dumps({**_valid(), "format_version": 2}),
    "[" * 100000 + "]" * 100000,
])
def test_malicious_presets_refused(tmp_path, text):
    path = tmp_path / "bad.json"
    (path.write_bytes if isinstance(text, bytes) else path.write_text)(text)
    with pytest.raises(P.PresetError):
        P.load_preset(path)


def test_valid_preset_text_accepted():
    assert P.parse_preset(json.dumps(_valid()))["config"] == SMCConfig()


def test_cli_tune_quick(tmp_path):
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.storage.store import ResultStore

    out, store = tmp_path / "p.json", tmp_path / "s.sqlite"
    assert main(["tune", "--controller", "smc", "--budget", "quick", "--space", "working", "--generations", "1",
                 "--pop-size", "2", "--max-steps", "50", "--no-progress", "--out", str(out),
                 "--store", str(store)]) == 0
    prov = P.load_preset(out)["provenance"]
    assert prov["budget"] == {"name": "custom", "generations": 1, "pop_size": 2}
    assert prov["command"].startswith("vtrack tune --controller smc")
    rows = ResultStore(store).rows("tuning")
    assert len(rows) == 1 and rows[0]["policy_id"] == "smc_tuned"


@pytest.mark.parametrize("space,X", [
    (SMC_WORKING, np.array([[8.0, 5.0, 0.1, 1.3187, 0.1, 0.5225, 161.5577], [3.0, 40.0, 0.02, 1.0, 0.05, 0.5, 100.0]])),
    (MPC_PAPER, np.vstack([MPCConfig().weights, np.random.default_rng(0).uniform(0, 1, 12)])),
])
def test_compiled_rollout_equals_numpy_controllers(space, X):
    fast = PopulationEvaluator(space, max_steps=300)(X)
    ref = PopulationEvaluator(space, max_steps=300, compiled=False)(X)
    np.testing.assert_allclose(fast.itae, ref.itae, rtol=1e-7)
    np.testing.assert_allclose(fast.max_abs_a_y_mps2, ref.max_abs_a_y_mps2, rtol=1e-7)


def test_packaged_tuned_smc_preset_if_present():
    path = P.packaged_preset_path("smc")
    if not path.is_file():
        pytest.skip("no packaged smc_tuned.json")
    loaded = P.load_preset(path)
    env = gym.make("LateralTracking-v0")
    assert make_policy("smc", env, preset="tuned").config == loaded["config"]


def test_compiled_smc_rollout_is_bit_identical_to_reference_with_comfort():
    X = np.array([[8.0, 5.0, 0.1, 1.3187, 0.1, 0.5225, 161.5577], [1.0, 1.0, 0.02, 1.0, 0.05, 0.5, 100.0]])
    fit = FitnessConfig(comfort_weight=1.0)
    fast = PopulationEvaluator(SMC_WORKING, max_steps=400, fitness=fit)(X)
    ref = PopulationEvaluator(SMC_WORKING, max_steps=400, fitness=fit, compiled=False)(X)
    for name in ("fitness", "itae", "completed", "termination", "remaining_m", "max_abs_a_y_mps2", "min_fz_n",
                 "duration_s", "comfort_a_v_mps2"):
        assert np.array_equal(getattr(fast, name), getattr(ref, name), equal_nan=True), name
    assert np.all(np.isfinite(fast.comfort_a_v_mps2)) and fast.steps == ref.steps


@pytest.mark.parametrize("space", [SMC_WORKING, MPC_PAPER])
def test_individual_result_does_not_depend_on_its_batch(space):
    """A row's result is the same alone or in any population (what makes the Ray split exact)."""
    X = np.random.default_rng(3).uniform(space.lower, space.upper, size=(5, len(space.params)))
    whole = PopulationEvaluator(space, max_steps=300)(X)
    for i in (0, 3):
        alone = PopulationEvaluator(space, max_steps=300)(X[i:i + 1])
        for name in ("fitness", "itae", "max_abs_a_y_mps2", "min_fz_n", "termination", "remaining_m"):
            assert getattr(alone, name)[0] == getattr(whole, name)[i], name
