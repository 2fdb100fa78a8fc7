"""Population controllers: the baselines' own SMC and MPC laws with one parameter row per individual.

* ``PopulationSMC``: ``SMC`` with per-row p, eta, Delta (the ``limit_layer_rate`` rule applied per row, silently).
* ``PopulationMPC``: ``MPC`` with one gain table per row (``vtrack_gym.tuning.gains.population_gain_tables``).

Both evaluate a whole population (observation row i = individual i) through the law's public parameters
(``policy.law``, see ``vtrack_gym.baselines.laws``); a single observation is refused.
"""

from __future__ import annotations

import numpy as np

from vtrack_gym.baselines.mpc import MPC, MPCConfig
from vtrack_gym.baselines.smc import SMC, SMCConfig
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.tuning.gains import population_gain_tables
from vtrack_gym.vehicle.params import DesignModel


def _check_rows(name: str, rows: int, obs: np.ndarray) -> None:
    if obs.shape[0] != rows:
        raise ValueError(f"{name} evaluates a whole population: pass ({rows}, obs_dim) observations "
                         f"(got {obs.shape[0]} rows)")


class PopulationSMC(SMC):
    """SMC with per-row p [rad/s], eta [rad/s^2], Delta [rad/s] (arrays of shape (P,))."""

    def __init__(self, design: DesignModel, config: SMCConfig, pole: np.ndarray, eta: np.ndarray,
                 delta: np.ndarray, layout: ObservationLayout = OBS, control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s, rows=(pole, eta, delta))
        self.rows = self.law.pole.size

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        _check_rows("PopulationSMC", self.rows, obs)
        return super()._act_batch(obs, state)


class PopulationMPC(MPC):
    """MPC with one weight vector (and gain table) per row."""

    def __init__(self, design: DesignModel, config: MPCConfig, weights: np.ndarray, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        _, tables = population_gain_tables(design, config, weights, layout)
        super().__init__(design, config, layout, control_period_s, tables=tables)
        self.rows = tables.shape[0]

    def _act_batch(self, obs: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _check_rows("PopulationMPC", self.rows, obs)
        return super()._act_batch(obs, state)
