"""The GA tunes any controller through the tuning protocol (``baselines.tunable``), never by name or type.

A tiny GA-tunable controller is written here in one file, from the public parts only, and tuned for a couple of
generations on the real Case-1 env, through both the compiled and the reference rollout.
"""

from __future__ import annotations

import ast
import pathlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np
import pytest
from numba import njit

from vtrack_gym.baselines.base import Policy
from vtrack_gym.baselines.tunable import (
    QUICK,
    Budget,
    CompiledRows,
    ControllerTuning,
    Parameter,
    SearchSpace,
    register_population_row,
)
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.tuning.ga import tune
from vtrack_gym.tuning.population import PopulationEvaluator
from vtrack_gym.tuning.spaces import search_space, tuning_of
from vtrack_gym.vehicle.params import DesignModel

STEPS = 300


# ---------------------------------------------------------------------------------- the tiny controller
@dataclass(frozen=True)
class TinyConfig:
    """Steering delta = l kappa - k_y e_y - k_phi e_phi."""

    k_y: float = 0.05     # [rad/m]
    k_phi: float = 0.5    # [rad/rad]


class TinyLaw(NamedTuple):
    i_ey: int
    i_ephi: int
    i_kappa: int
    k_y: np.ndarray       # (R,)
    k_phi: np.ndarray     # (R,)
    wheelbase_m: float


@njit(cache=False)
def tiny_row(law: TinyLaw, obs: np.ndarray, i: int, memory: np.ndarray) -> float:
    r = i if law.k_y.shape[0] > 1 else 0
    return law.wheelbase_m * obs[i, law.i_kappa] - law.k_y[r] * obs[i, law.i_ey] - law.k_phi[r] * obs[i, law.i_ephi]


register_population_row(TinyLaw, tiny_row)


class TinyGain(Policy):
    name: ClassVar[str] = "tiny_gain"
    PRESETS: ClassVar[dict[str, TinyConfig]] = {"default": TinyConfig()}
    config_type: ClassVar[type] = TinyConfig
    state_size = 0

    def __init__(self, design: DesignModel, config: TinyConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01, rows: tuple[Sequence[float], Sequence[float]] | None = None) -> None:
        super().__init__(design, config, layout, control_period_s)
        k_y, k_phi = rows if rows is not None else ([self.config.k_y], [self.config.k_phi])
        self.law = TinyLaw(layout.index("e_y"), layout.index("e_phi"), layout.index("curvature"),
                           np.asarray(k_y, dtype=np.float64), np.asarray(k_phi, dtype=np.float64),
                           float(design.wheelbase_m))

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        empty = np.zeros(0)
        return np.array([tiny_row(self.law, obs, i, empty) for i in range(obs.shape[0])]), None

    def compiled_rows(self, obs: np.ndarray) -> CompiledRows:
        return CompiledRows(self.law, np.zeros((obs.shape[0], 0)), True)

    @classmethod
    def tuning(cls) -> ControllerTuning:
        return TINY_TUNING


def tiny_population(design: DesignModel, base: TinyConfig, configs: Sequence[TinyConfig], layout: ObservationLayout,
                    control_period_s: float) -> TinyGain:
    return TinyGain(design, base, layout, control_period_s, rows=([c.k_y for c in configs], [c.k_phi for c in configs]))


TINY_SPACE = SearchSpace("tiny_gain", "gains", "default",
                         (Parameter("k_y", 0.0, 0.3, "controller", "k_y"),
                          Parameter("k_phi", 0.0, 2.0, "controller", "k_phi")), policy=TinyGain)
TINY_TUNING = ControllerTuning({"gains": TINY_SPACE}, {"quick": QUICK}, tiny_population)


# ---------------------------------------------------------------------------------------------- tests
def test_ga_tunes_a_controller_declared_through_the_protocol() -> None:
    budget = Budget("tiny", 2, 4)
    first = tune(TINY_SPACE, budget, seed=3, max_steps=STEPS, progress=False)
    again = tune(TINY_SPACE, budget, seed=3, max_steps=STEPS, progress=False)
    assert isinstance(first.best_config, TinyConfig)
    assert (first.best_config.k_y, first.best_config.k_phi) == tuple(first.best_x)
    assert np.all(first.best_x >= TINY_SPACE.lower) and np.all(first.best_x <= TINY_SPACE.upper)
    assert first.episodes == budget.evaluations and first.car_steps > 0
    assert first.history == sorted(first.history, reverse=True) and first.best_fitness <= first.initial_best_fitness
    assert np.isfinite(first.best_fitness)
    np.testing.assert_array_equal(first.best_x, again.best_x)  # same seed, same run
    assert first.history == again.history


def test_compiled_rollout_equals_the_reference_for_the_tiny_controller() -> None:
    X = np.array([[0.05, 0.5], [0.2, 1.5], [0.0, 0.0], [0.3, 2.0]])
    fast = PopulationEvaluator(TINY_SPACE, max_steps=STEPS)(X)
    ref = PopulationEvaluator(TINY_SPACE, max_steps=STEPS, compiled=False)(X)
    np.testing.assert_array_equal(fast.fitness, ref.fitness)
    np.testing.assert_array_equal(fast.itae, ref.itae)
    np.testing.assert_array_equal(fast.max_abs_e_y_m, ref.max_abs_e_y_m)
    assert fast.itae[0] < fast.itae[2]  # feedback tracks better than none


def test_a_population_without_compiled_rows_runs_the_reference_path() -> None:
    class Uncompiled(TinyGain):
        compiled_rows = None  # type: ignore[assignment]

        @classmethod
        def tuning(cls) -> ControllerTuning:
            return ControllerTuning({"gains": space}, {"quick": QUICK},
                                    lambda d, b, c, lay, p: Uncompiled(d, b, lay, p, rows=([x.k_y for x in c],
                                                                                       [x.k_phi for x in c])))

    space = SearchSpace("uncompiled", "gains", "default", TINY_SPACE.params, policy=Uncompiled)
    X = np.array([[0.05, 0.5], [0.2, 1.5]])
    ref = PopulationEvaluator(TINY_SPACE, max_steps=STEPS, compiled=False)(X)
    np.testing.assert_array_equal(PopulationEvaluator(space, max_steps=STEPS)(X).fitness, ref.fitness)


def test_registered_controllers_declare_their_spaces() -> None:
    assert tuning_of(search_space("smc", "steering")) is tuning_of("smc")
    assert set(tuning_of("mpc").spaces) == {"paper", "working"}
    assert tuning_of(TINY_SPACE) is TINY_TUNING
    with pytest.raises(ValueError, match="'stanley' is not GA-tunable"):
        tuning_of("stanley")


def _code_constants_and_names(source: str) -> tuple[set[str], set[str]]:
    """String constants outside docstrings, and identifiers, of a module's code."""
    tree = ast.parse(source)
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef)) and node.body
                  and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    strings = {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)
               and id(n) not in docstrings}
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} \
        | {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)} \
        | {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names}
    return strings, names


def test_tuning_never_dispatches_on_a_controller_name_or_type() -> None:
    import vtrack_gym.tuning as tuning_pkg

    for file in pathlib.Path(tuning_pkg.__file__).parent.glob("*.py"):
        strings, names = _code_constants_and_names(file.read_text())
        assert not {"smc", "mpc"} & {s.lower() for s in strings}, file.name
        controller_names = {n for n in names if n.upper().startswith(("SMC", "MPC", "POPULATIONSMC", "POPULATIONMPC"))}
        assert not controller_names, (file.name, controller_names)



def test_a_law_outside_the_package_stays_out_of_the_kernel_cache() -> None:
    """Numba keeps every signature of a cached kernel in one on-disk index; an entry naming this test module would
    make the index unreadable in a process that cannot import it (a Ray worker), for every law. The package's laws
    are loaded from that cache in a fresh process, not compiled again."""
    from vtrack_gym.tuning import _kernels as K

    PopulationEvaluator(TINY_SPACE, max_steps=20)(np.array([[0.05, 0.5], [0.1, 1.0]]))
    assert any("TinyLaw" in str(sig) for sig in K._UNCACHED.signatures)
    assert not any("TinyLaw" in str(sig) for sig in K._CACHED.signatures)


def test_package_laws_load_the_cached_kernel_in_a_fresh_process() -> None:
    import os
    import subprocess
    import sys

    code = ("import numpy as np; from vtrack_gym.tuning.population import PopulationEvaluator; "
            "from vtrack_gym.tuning.spaces import search_space; from vtrack_gym.tuning import _kernels as K; "
            "PopulationEvaluator(search_space('smc', 'steering'), max_steps=5)(np.array([[5.0, 10.0, 0.2]] * 2)); "
            "s = K._CACHED.stats; print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))")
    env = {**os.environ, "PYTHONPATH": str(pathlib.Path(__file__).resolve().parents[1])}
    for _ in range(2):  # the first run may fill the cache, the second must hit it
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    hits, misses = (int(v) for v in out.stdout.split()[-2:])
    assert (hits, misses) == (1, 0), out.stdout
