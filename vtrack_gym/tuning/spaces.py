"""GA search spaces as data (paper Table 2 and a documented ``working`` SMC space).

A ``Parameter`` maps one GA variable onto a controller config field (``SMCConfig`` / ``MPCConfig``; ``index``
selects an entry of a tuple field such as ``MPCConfig.weights``) or onto a PD-FLC speed-loop gain
(``target="speed"``, ``PDFLCConfig.g1..g4``). ``SearchSpace.base_preset`` names the controller preset whose
other fields are kept fixed.

Spaces:

* ``smc/paper``: Table 2 exactly: p [0.01, 0.1], eta [500, 1000], Delta [0.1, 1], G1 [0.1, 5], G2 [0.01, 0.1],
  G3 [0.1, 1], G4 [1, 300]; base preset ``paper`` (no sideslip shift). With the corrected equations no p in
  [0.01, 0.1] tracks a path (paper-math 5.6.2/5.6.4: c1 ~ p^3, no e_y feedback), and at T_c = 10 ms the SMC's
  ``limit_layer_rate`` rule widens Delta to eta T_c (5..10 rad/s), so this space is kept for faithfulness.
* ``smc/working``: p [1, 15] rad/s (p ~ 3..10 tracks, paper-math 5.6 OPTION 1), eta [1, 50] rad/s^2 and
  Delta [0.02, 1] rad/s (adapted to the 10 ms control period: eta/Delta <= 1/T_c is enforced by the SMC's
  layer-widening rule, paper-math 5.6.3 OPTION 4), the same G1..G4 bounds; base preset ``hand`` (OPTION 2
  sideslip shift on).
* ``smc/steering``: the ``working`` p, eta, Delta bounds only; the PD-FLC gains stay the env's. Its result is a
  pure steering preset: ``make_policy("smc", env, preset="tuned")`` reproduces the tuned closed loop on any env
  (a ``working`` result does so only with its G1..G4 put into ``EnvConfig(speed_controller=...)``).
* ``mpc/paper``: w1..w12 in [0, 1] (Table 2); base preset ``hand`` (W2 = 100 I: the paper does not give
  W2, and the ``paper`` preset's 0.1 oscillates in the nonlinear env, see ``vtrack_gym.baselines.mpc``).
  ``mpc/working`` is the same space.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

TARGETS = ("controller", "speed")
SPEED_FIELDS = ("g1", "g2", "g3", "g4")


@dataclass(frozen=True)
class Parameter:
    """One GA variable: ``name`` (the paper's symbol), bounds [low, high] and where it goes."""

    name: str
    low: float
    high: float
    target: str  # "controller" (SMCConfig/MPCConfig field) or "speed" (PDFLCConfig field)
    field: str
    index: int | None = None  # entry of a tuple-valued field (MPCConfig.weights)

    def __post_init__(self) -> None:
        if self.target not in TARGETS:
            raise ValueError(f"Parameter.target must be one of {TARGETS} (got {self.target!r})")
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise ValueError(f"Parameter {self.name}: need finite low < high (got [{self.low}, {self.high}])")
        if self.target == "speed" and self.field not in SPEED_FIELDS:
            raise ValueError(f"Parameter {self.name}: speed-loop field must be one of {SPEED_FIELDS}")


@dataclass(frozen=True)
class SearchSpace:
    """The variables of one GA problem (``controller``: ``smc`` or ``mpc``)."""

    controller: str
    name: str
    base_preset: str
    params: tuple[Parameter, ...]
    description: str = ""

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    @property
    def lower(self) -> np.ndarray:
        return np.array([p.low for p in self.params], dtype=np.float64)

    @property
    def upper(self) -> np.ndarray:
        return np.array([p.high for p in self.params], dtype=np.float64)

    def as_dict(self) -> dict:
        """JSON-safe summary (for provenance)."""
        return {"controller": self.controller, "name": self.name, "base_preset": self.base_preset,
                "bounds": {p.name: [p.low, p.high] for p in self.params}}


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

MPC_PAPER = SearchSpace(
    "mpc", "paper", "hand",
    tuple(Parameter(f"w{i + 1}", 0.0, 1.0, "controller", "weights", i) for i in range(12)),
    "Table 2 of the paper: w1..w12 in [0, 1] (W2 = 100 I from the hand preset)")

SPACES: dict[tuple[str, str], SearchSpace] = {
    ("smc", "paper"): SMC_PAPER,
    ("smc", "working"): SMC_WORKING,
    ("smc", "steering"): SMC_STEERING,
    ("mpc", "paper"): MPC_PAPER,
    ("mpc", "working"): MPC_PAPER,
}


def search_space(controller: str, name: str = "paper") -> SearchSpace:
    """The registered space (``ValueError`` listing the valid ones if unknown)."""
    key = (controller, name)
    if key not in SPACES:
        raise ValueError(f"unknown search space {controller}/{name}; valid: "
                         f"{', '.join(f'{c}/{s}' for c, s in SPACES)}")
    return SPACES[key]


@dataclass(frozen=True)
class Budget:
    """GA budget: generations x population size (paper Table 2 for ``paper``)."""

    name: str
    generations: int
    pop_size: int

    def __post_init__(self) -> None:
        if self.generations < 1 or self.pop_size < 2:
            raise ValueError(f"Budget needs generations >= 1 and pop_size >= 2 (got {self.generations}, "
                             f"{self.pop_size})")

    @property
    def evaluations(self) -> int:
        """Episodes evaluated: the initial population plus one offspring batch per further generation."""
        return self.generations * self.pop_size


BUDGETS: dict[tuple[str, str], Budget] = {
    ("smc", "paper"): Budget("paper", 100, 10),
    ("mpc", "paper"): Budget("paper", 200, 20),
    ("smc", "quick"): Budget("quick", 3, 4),
    ("mpc", "quick"): Budget("quick", 3, 4),
}

CROSSOVER_PROB = 0.8
"""SBX crossover probability per mating (Table 2)."""
MUTATION_PROB = 0.1
"""Polynomial-mutation probability per variable (Table 2's 0.1, read as a per-gene rate)."""


def budget(controller: str, name: str) -> Budget:
    key = (controller, name)
    if key not in BUDGETS:
        raise ValueError(f"unknown budget {name!r} for {controller}; valid: "
                         f"{', '.join(b for c, b in BUDGETS if c == controller)}")
    return BUDGETS[key]


def configs_from_vector(space: SearchSpace, x: np.ndarray, base_config: Any, base_speed: Any) -> tuple[Any, Any]:
    """(controller config, PDFLCConfig) of one GA vector ``x`` (fields not in the space from the bases)."""
    ctrl: dict[str, Any] = {}
    speed: dict[str, float] = {}
    weights = list(getattr(base_config, "weights", ()))
    for p, value in zip(space.params, np.asarray(x, dtype=np.float64).tolist(), strict=True):
        if p.target == "speed":
            speed[p.field] = value
        elif p.index is not None:
            weights[p.index] = value
        else:
            ctrl[p.field] = value
    if any(p.index is not None for p in space.params):
        ctrl["weights"] = tuple(weights)
    return dataclasses.replace(base_config, **ctrl), dataclasses.replace(base_speed, **speed)
