"""The MPC's GA tuning declaration: the search space (paper Table 2), budgets and the population law (``MPC``
with one gain table per individual, ``mpc_gains.population_gain_tables``), compiled row by row through
``laws.mpc_row``.

Space ``paper`` (also named ``working``): w1..w12 in [0, 1] (Table 2); base preset ``hand`` (W2 = 100 I: the paper
does not give W2, and the ``paper`` preset's 0.1 oscillates in the nonlinear env, see ``baselines.mpc``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.laws import MPC_STATE_SIZE, MPCLaw, mpc_row
from vtrack_gym.baselines.mpc import MPC, MPCConfig
from vtrack_gym.baselines.mpc_gains import population_gain_tables
from vtrack_gym.baselines.tunable import (
    QUICK,
    Budget,
    CompiledRows,
    ControllerTuning,
    Parameter,
    SearchSpace,
    check_population_rows,
    register_population_row,
)
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

MPC_PAPER = SearchSpace(
    "mpc", "paper", "hand",
    tuple(Parameter(f"w{i + 1}", 0.0, 1.0, "controller", "weights", i) for i in range(12)),
    "Table 2 of the paper: w1..w12 in [0, 1] (W2 = 100 I from the hand preset)")


@kernel
def mpc_population_row(law: MPCLaw, obs: np.ndarray, i: int, memory: np.ndarray) -> float:
    """Road-wheel angle [rad] of individual ``i``; ``memory``: its MPC memory (``MPC_STATE_SIZE``) then the
    law's scratch row."""
    return mpc_row(law, obs, i, memory[:MPC_STATE_SIZE], memory[MPC_STATE_SIZE:])


register_population_row(MPCLaw, mpc_population_row)


class PopulationMPC(MPC):
    """MPC with one weight vector (and gain table) per row. A single observation is refused."""

    def __init__(self, design: DesignModel, config: MPCConfig, weights: np.ndarray, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        _, tables = population_gain_tables(design, config, weights, layout)
        super().__init__(design, config, layout, control_period_s, tables=tables)
        self.rows = tables.shape[0]

    def _act_batch(self, obs: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        check_population_rows("PopulationMPC", self.rows, obs)
        return super()._act_batch(obs, state)

    def compiled_rows(self, obs: np.ndarray) -> CompiledRows:
        """The compiled per-row law (``baselines.tunable``): memory = initial MPC state, then zeroed scratch."""
        memory = np.zeros((obs.shape[0], MPC_STATE_SIZE + self.law.tables.shape[2]))
        memory[:, :MPC_STATE_SIZE] = self.initial_state(obs)
        return CompiledRows(self.law, memory, False)


def mpc_population(design: DesignModel, base: MPCConfig, configs: Sequence[Any], layout: ObservationLayout,
                   control_period_s: float) -> PopulationMPC:
    """The population MPC of one config per individual (their weights; the rest from ``base``)."""
    return PopulationMPC(design, base, np.array([c.weights for c in configs]), layout, control_period_s)


MPC_TUNING = ControllerTuning(
    spaces={"paper": MPC_PAPER, "working": MPC_PAPER},
    budgets={"paper": Budget("paper", 200, 20), "quick": QUICK},
    population=mpc_population)
"""The MPC's tuning declaration (``MPC.tuning()``)."""
