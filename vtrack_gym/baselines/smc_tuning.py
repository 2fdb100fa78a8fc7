"""The SMC's GA tuning declaration: search spaces (paper Table 2 and documented working spaces), budgets and the
population law (``SMC`` with per-row p, eta, Delta), compiled row by row through ``laws.smc_row``.

Spaces:

* ``paper``: Table 2 exactly: p [0.01, 0.1], eta [500, 1000], Delta [0.1, 1], G1 [0.1, 5], G2 [0.01, 0.1],
  G3 [0.1, 1], G4 [1, 300]; base preset ``paper`` (no sideslip shift). With the corrected equations no p in
  [0.01, 0.1] tracks a path (paper-math 5.6.2/5.6.4: c1 ~ p^3, no e_y feedback), and at T_c = 10 ms the SMC's
  ``limit_layer_rate`` rule widens Delta to eta T_c (5..10 rad/s), so this space is kept for faithfulness.
* ``working``: p [1, 15] rad/s (p ~ 3..10 tracks, paper-math 5.6 OPTION 1), eta [1, 50] rad/s^2 and
  Delta [0.02, 1] rad/s (adapted to the 10 ms control period: eta/Delta <= 1/T_c is enforced by the SMC's
  layer-widening rule, paper-math 5.6.3 OPTION 4), the same G1..G4 bounds; base preset ``hand`` (OPTION 2
  sideslip shift on).
* ``steering``: the ``working`` p, eta, Delta bounds only; the PD-FLC gains stay the env's. Its result is a
  pure steering preset: ``make_policy("smc", env, preset="tuned")`` reproduces the tuned closed loop on any env
  (a ``working`` result does so only with its G1..G4 put into ``EnvConfig(speed_controller=...)``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.laws import SMCLaw, smc_row
from vtrack_gym.baselines.smc import SMC, SMCConfig
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

_G = (Parameter("G1", 0.1, 5.0, "speed", "g1"), Parameter("G2", 0.01, 0.1, "speed", "g2"),
      Parameter("G3", 0.1, 1.0, "speed", "g3"), Parameter("G4", 1.0, 300.0, "speed", "g4"))

SMC_PAPER = SearchSpace(
    "smc", "paper", "paper",
    (Parameter("p", 0.01, 0.1, "controller", "pole_radps"),
     Parameter("eta", 500.0, 1000.0, "controller", "reaching_gain"),
     Parameter("Delta", 0.1, 1.0, "controller", "boundary_layer"), *_G),
    "Table 2 of the paper (does not track with the corrected equations, paper-math 5.6)")

SMC_WORKING = SearchSpace(
    "smc", "working", "hand",
    (Parameter("p", 1.0, 15.0, "controller", "pole_radps"),
     Parameter("eta", 1.0, 50.0, "controller", "reaching_gain"),
     Parameter("Delta", 0.02, 1.0, "controller", "boundary_layer"), *_G),
    "p adapted to the corrected equations, eta/Delta to the 10 ms control period; Table-2 G1..G4")

SMC_STEERING = SearchSpace(
    "smc", "steering", "hand", SMC_WORKING.params[:3],
    "the working p/eta/Delta bounds with the env's PD-FLC gains fixed: a steering-only preset, usable as "
    "make_policy(..., preset='tuned') on any env")


@kernel
def smc_population_row(law: SMCLaw, obs: np.ndarray, i: int, memory: np.ndarray) -> float:
    """Road-wheel angle [rad] of individual ``i`` (stateless: ``memory`` has no columns)."""
    delta, _, _ = smc_row(law, obs, i)
    return delta


register_population_row(SMCLaw, smc_population_row)


class PopulationSMC(SMC):
    """SMC with per-row p [rad/s], eta [rad/s^2], Delta [rad/s] (arrays of shape (P,)); the limit_layer_rate
    rule applied per row, silently. A single observation is refused."""

    def __init__(self, design: DesignModel, config: SMCConfig, pole: np.ndarray, eta: np.ndarray,
                 delta: np.ndarray, layout: ObservationLayout = OBS, control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s, rows=(pole, eta, delta))
        self.rows = self.law.pole.size

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        check_population_rows("PopulationSMC", self.rows, obs)
        return super()._act_batch(obs, state)

    def compiled_rows(self, obs: np.ndarray) -> CompiledRows:
        """The compiled per-row law (``baselines.tunable``); a NaN command steers neutral."""
        return CompiledRows(self.law, np.zeros((obs.shape[0], 0)), True)


def smc_population(design: DesignModel, base: SMCConfig, configs: Sequence[Any], layout: ObservationLayout,
                   control_period_s: float) -> PopulationSMC:
    """The population SMC of one config per individual (their p, eta, Delta; the rest from ``base``)."""
    return PopulationSMC(design, base, np.array([c.pole_radps for c in configs]),
                         np.array([c.reaching_gain for c in configs]),
                         np.array([c.boundary_layer for c in configs]), layout, control_period_s)


SMC_TUNING = ControllerTuning(
    spaces={"paper": SMC_PAPER, "working": SMC_WORKING, "steering": SMC_STEERING},
    budgets={"paper": Budget("paper", 100, 10), "quick": QUICK},
    population=smc_population)
"""The SMC's tuning declaration (``SMC.tuning()``)."""
