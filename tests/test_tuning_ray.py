"""The Ray backend of GA tuning (vtrack_gym.tuning.backends) gives the local backend's results bit for bit."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

# Ray resolves 127.0.0.1 to the machine's external address on Linux and binds its servers there; this switch (read
# when ray is imported) makes it use the loopback address, as it does on macOS/Windows: the test cluster stays on
# 127.0.0.1.
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
ray = pytest.importorskip("ray")

from vtrack_gym.baselines.mpc_tuning import MPC_PAPER  # noqa: E402
from vtrack_gym.baselines.smc_tuning import SMC_WORKING  # noqa: E402
from vtrack_gym.tuning.backends import RayPopulationEvaluator, make_evaluator, merge_results  # noqa: E402
from vtrack_gym.tuning.ga import tune  # noqa: E402
from vtrack_gym.tuning.population import PopulationEvaluator, PopulationResult  # noqa: E402
from vtrack_gym.tuning.spaces import Budget  # noqa: E402

STEPS = 300
ARRAYS = [f.name for f in dataclasses.fields(PopulationResult)
          if f.name not in ("steps", "wall_s", "also_completed", "also_max_abs_e_y_m")]


@pytest.fixture(scope="module")
def ray_cluster():
    """A local 2-CPU Ray instance on 127.0.0.1 (no dashboard), shut down after the module."""
    if ray.is_initialized():
        pytest.skip("Ray is already initialised in this process")
    ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        yield ray
    finally:
        ray.shutdown()


def _population(n: int) -> np.ndarray:
    rng = np.random.default_rng(3)
    return SMC_WORKING.lower + rng.uniform(size=(n, len(SMC_WORKING.params))) * (SMC_WORKING.upper - SMC_WORKING.lower)


def _result(n: int, offset: float, scenarios: tuple[str, ...] = ()) -> PopulationResult:
    a = offset + np.arange(n, dtype=np.float64)
    return PopulationResult(a, a + 0.5, a > offset, a.astype(np.int64), a, a, a, a, a, a, steps=n * 10,
                            wall_s=offset, also_completed={s: a > offset + 1 for s in scenarios},
                            also_max_abs_e_y_m={s: a + 2 for s in scenarios})


def test_merge_results_concatenates_in_order():
    parts = [_result(2, 0.0, ("DLC120-v0",)), _result(3, 10.0, ("DLC120-v0",))]
    m = merge_results(parts)
    for name in ARRAYS:
        assert np.array_equal(getattr(m, name), np.concatenate([getattr(p, name) for p in parts])), name
    assert m.termination.dtype == np.int64 and m.completed.dtype == np.bool_
    assert np.array_equal(m.also_completed["DLC120-v0"], [False, False, False, False, True])
    assert np.array_equal(m.also_max_abs_e_y_m["DLC120-v0"], [2.0, 3.0, 12.0, 13.0, 14.0])
    assert (m.steps, m.wall_s) == (30, 10.0)  # longest chunk, parallel wall time
    with pytest.raises(ValueError, match="also_completed"):
        merge_results([_result(1, 0.0, ("DLC120-v0",)), _result(1, 0.0)])
    with pytest.raises(ValueError, match="at least one"):
        merge_results([])


def test_unknown_backend_refused():
    with pytest.raises(ValueError, match=r"backend must be one of 'local', 'ray' \(got 'dask'\)"):
        make_evaluator("dask", SMC_WORKING)
    with pytest.raises(ValueError, match="backend 'ray' only"):
        make_evaluator("local", SMC_WORKING, num_workers=2)


def test_ray_evaluator_equals_local(ray_cluster):
    X = _population(5)  # 2 workers: chunks of 3 and 2 rows
    local = PopulationEvaluator(SMC_WORKING, max_steps=STEPS, also_complete=("DLC120-v0",))
    ref = local(X)
    with RayPopulationEvaluator(SMC_WORKING, max_steps=STEPS, also_complete=("DLC120-v0",), num_workers=2) as ev:
        assert ev.num_workers == 2
        res = ev(X)
        assert (ev.episodes, ev.car_steps) == (local.episodes, local.car_steps)
    for name in ARRAYS:
        assert np.array_equal(getattr(res, name), getattr(ref, name), equal_nan=True), name
    assert np.array_equal(res.also_completed["DLC120-v0"], ref.also_completed["DLC120-v0"])
    assert res.steps == ref.steps
    assert ray.is_initialized()  # the evaluator did not shut down the cluster it did not start


def test_tune_ray_backend_equals_local(ray_cluster):
    b = Budget("t", 2, 4)
    local = tune(SMC_WORKING, b, seed=0, max_steps=STEPS, progress=False)
    dist = tune(SMC_WORKING, b, seed=0, backend="ray", max_steps=STEPS, progress=False)
    assert np.array_equal(dist.best_x, local.best_x)
    assert dist.best_fitness == local.best_fitness
    assert dist.history == local.history and dist.best_metrics == local.best_metrics
    assert (dist.backend, dist.workers, local.backend) == ("ray", 2, "local")
    assert ray.is_initialized()


def test_ray_evaluator_equals_local_mpc(ray_cluster):
    X = np.random.default_rng(1).uniform(size=(5, len(MPC_PAPER.params)))
    ref = PopulationEvaluator(MPC_PAPER, max_steps=STEPS)(X)
    with RayPopulationEvaluator(MPC_PAPER, max_steps=STEPS, num_workers=2) as ev:
        res = ev(X)
    for name in ARRAYS:
        assert np.array_equal(getattr(res, name), getattr(ref, name), equal_nan=True), name
