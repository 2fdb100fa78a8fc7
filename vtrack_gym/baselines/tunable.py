"""The GA tuning protocol: what a controller declares to be tunable by ``vtrack_gym.tuning``.

A GA-tunable controller (a ``Policy`` class) declares a ``ControllerTuning``: its search spaces and budgets (data)
and ``population``, which builds its batched law, one parameter row per individual, as a ``Policy`` evaluating
observation row i with individual i's config. A registered controller links its declaration in
``baselines.registry``; any other controller class is named by ``SearchSpace.policy`` and returns its declaration
from a classmethod ``tuning()``. The GA only ever calls these; it never looks at the controller's name or type.

The batched law runs one of two ways:

* the reference path: its ``Policy.act`` / ``initial_state`` on the whole population, one control period at a
  time (always available);
* the compiled path: if the population policy has ``compiled_rows(obs)`` returning a ``CompiledRows`` (its law's
  parameters ``law``, the initial ``memory`` (N, width) and the NaN rule), every car's whole episode runs in one
  compiled call, which steers car i by ``population_row(law, obs, i, memory[i])``. The controller registers its
  compiled row law for its law's type once, with ``register_population_row(LawType, row)``; the kernel is then
  compiled (and cached on disk) per law type. Without ``compiled_rows`` (absent or None) the reference path is
  used.

A new GA-tunable controller is therefore its policy module (the law), the module of its declaration (as
``smc_tuning`` / ``mpc_tuning``; it may sit in the policy module) and its registry entries.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from vtrack_gym.envs.observation import ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

TARGETS = ("controller", "speed")
SPEED_FIELDS = ("g1", "g2", "g3", "g4")


@dataclass(frozen=True)
class Parameter:
    """One GA variable: ``name`` (the paper's symbol), bounds [low, high] and where it goes: a field of the
    controller's config (``target="controller"``; ``index`` selects an entry of a tuple-valued field) or a PD-FLC
    speed-loop gain (``target="speed"``, ``PDFLCConfig.g1..g4``)."""

    name: str
    low: float
    high: float
    target: str
    field: str
    index: int | None = None

    def __post_init__(self) -> None:
        if self.target not in TARGETS:
            raise ValueError(f"Parameter.target must be one of {TARGETS} (got {self.target!r})")
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise ValueError(f"Parameter {self.name}: need finite low < high (got [{self.low}, {self.high}])")
        if self.target == "speed" and self.field not in SPEED_FIELDS:
            raise ValueError(f"Parameter {self.name}: speed-loop field must be one of {SPEED_FIELDS}")
        if self.index is not None and (self.target != "controller" or self.index < 0):
            raise ValueError(f"Parameter {self.name}: index must be >= 0 and address a controller field")


@dataclass(frozen=True)
class SearchSpace:
    """The variables of one GA problem of controller ``controller`` (its registry name); ``base_preset`` names
    the preset whose other config fields stay fixed. ``policy``: the controller class itself, for one that is not
    in the registry (None: the registry's class of ``controller``)."""

    controller: str
    name: str
    base_preset: str
    params: tuple[Parameter, ...]
    description: str = ""
    policy: type | None = field(default=None, compare=False, repr=False)

    def policy_class(self) -> type:
        """The controller class this space tunes (its ``make_config(preset)`` gives the base config)."""
        if self.policy is not None:
            return self.policy
        from vtrack_gym.baselines.registry import policy_class

        return policy_class(self.controller)

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


QUICK = Budget("quick", 3, 4)
"""The smoke-test budget every tunable controller offers."""


class CompiledRows(NamedTuple):
    """A population's compiled per-row law (see the module docstring)."""

    law: Any             # the law's parameters (a NamedTuple of arrays and scalars; its row law registered)
    memory: np.ndarray   # (N, width) float64 per-row memory, initialised (width 0: stateless)
    nan_to_zero: bool    # a NaN command steers neutral (True) or is passed on (False)


def population_row(law: Any, obs: np.ndarray, i: int, memory: np.ndarray) -> float:
    """Road-wheel angle [rad] of individual ``i`` (observation row ``i``, memory row ``memory``) under ``law``: the
    compiled entry point of every population law, resolved by the law's type inside compiled code
    (``register_population_row``). Not callable from Python."""
    raise TypeError(f"population_row is compiled code only; register a row law for {type(law).__name__}")


def register_population_row(law_type: type, row: Any) -> None:
    """Make compiled ``population_row(law, obs, i, memory)`` call ``row`` (a numba function with that signature,
    returning the road-wheel angle [rad]) for laws of the NamedTuple class ``law_type``. Call once, at import of
    the controller's tuning declaration."""
    from numba.extending import overload

    @overload(population_row)
    def _row_of(law, obs, i, memory):  # numba matches these names, unannotated, against population_row's
        if getattr(law, "instance_class", None) is law_type:
            return lambda law, obs, i, memory: row(law, obs, i, memory)
        return None


PopulationFactory = Callable[[DesignModel, Any, Sequence[Any], ObservationLayout, float], Any]
"""``(design, base config, one config per individual, layout, control period [s]) -> population Policy``."""


@dataclass(frozen=True)
class ControllerTuning:
    """What makes a controller GA-tunable: its spaces and budgets by name, and its batched law."""

    spaces: Mapping[str, SearchSpace]
    budgets: Mapping[str, Budget]
    population: PopulationFactory

    def __post_init__(self) -> None:
        if not self.spaces:
            raise ValueError("ControllerTuning needs at least one search space")
        for key, space in self.spaces.items():
            if not isinstance(space, SearchSpace):
                raise ValueError(f"ControllerTuning.spaces[{key!r}] must be a SearchSpace")


def configs_from_vector(space: SearchSpace, x: np.ndarray, base_config: Any, base_speed: Any) -> tuple[Any, Any]:
    """(controller config, PDFLCConfig) of one GA vector ``x`` (fields not in the space from the bases)."""
    ctrl: dict[str, Any] = {}
    speed: dict[str, float] = {}
    entries: dict[str, list[Any]] = {}  # tuple-valued fields with indexed parameters
    for p, value in zip(space.params, np.asarray(x, dtype=np.float64).tolist(), strict=True):
        if p.target == "speed":
            speed[p.field] = value
        elif p.index is not None:
            entries.setdefault(p.field, list(getattr(base_config, p.field)))[p.index] = value
        else:
            ctrl[p.field] = value
    ctrl.update({name: tuple(values) for name, values in entries.items()})
    return dataclasses.replace(base_config, **ctrl), dataclasses.replace(base_speed, **speed)


def check_population_rows(name: str, rows: int, obs: np.ndarray) -> None:
    """``ValueError`` unless ``obs`` has one row per individual."""
    if obs.shape[0] != rows:
        raise ValueError(f"{name} evaluates a whole population: pass ({rows}, obs_dim) observations "
                         f"(got {obs.shape[0]} rows)")
