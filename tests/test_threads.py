"""The thread policy: one thread below ``PARALLEL_MIN_N`` cars, passive waiting above, an environment override."""

from __future__ import annotations

import pytest

from vtrack_gym.envs.config import EnvConfig
from vtrack_gym.envs.scenarios import resolve_scenario
from vtrack_gym.envs.sim import BatchSim
from vtrack_gym.vehicle.plant import Plant
from vtrack_gym.vehicle.threads import MIN_N_VARIABLE, PARALLEL_MIN_N, parallel_min_n, use_parallel


def test_small_batches_stay_on_one_thread(monkeypatch) -> None:
    monkeypatch.delenv(MIN_N_VARIABLE, raising=False)
    assert parallel_min_n() == PARALLEL_MIN_N
    assert not use_parallel(PARALLEL_MIN_N - 1)
    assert use_parallel(PARALLEL_MIN_N)


def test_parallel_asks_for_passive_waiting_unless_set(monkeypatch) -> None:
    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    use_parallel(1)
    import os

    assert os.environ.get("OMP_WAIT_POLICY") is None          # one thread: nothing changed
    monkeypatch.setenv(MIN_N_VARIABLE, "1")
    assert use_parallel(1)
    assert os.environ["OMP_WAIT_POLICY"] == "PASSIVE"
    monkeypatch.setenv("OMP_WAIT_POLICY", "ACTIVE")
    use_parallel(1)
    assert os.environ["OMP_WAIT_POLICY"] == "ACTIVE"          # the user's choice is kept


def test_the_override_selects_the_kernel_of_plant_and_env(monkeypatch) -> None:
    from vtrack_gym.envs import kernels as envk
    from vtrack_gym.vehicle import kernels as vehk

    monkeypatch.setenv(MIN_N_VARIABLE, "4")
    assert Plant(n=4)._step is vehk.step_batch_parallel and Plant(n=3)._step is vehk.step_batch_serial
    sim = BatchSim(resolve_scenario("DLC120-v0"), EnvConfig(), 4)
    assert sim._step_kernel is envk.step_parallel
    monkeypatch.setenv(MIN_N_VARIABLE, "1000000000")
    assert BatchSim(resolve_scenario("DLC120-v0"), EnvConfig(), 4)._step_kernel is envk.step_serial


@pytest.mark.parametrize("text", ["0", "-3", "many", "1.5"])
def test_a_bad_override_is_refused_naming_the_variable(monkeypatch, text) -> None:
    monkeypatch.setenv(MIN_N_VARIABLE, text)
    with pytest.raises(ValueError, match=MIN_N_VARIABLE):
        parallel_min_n()
