"""GA search spaces and budgets, looked up by controller name through the tuning protocol.

Each GA-tunable controller declares its spaces, budgets and batched law itself (a ``ControllerTuning``, protocol
``vtrack_gym.baselines.tunable``; the SMC's in ``baselines.smc_tuning``, the MPC's in ``baselines.mpc_tuning``,
linked to the name by ``baselines.registry``); this module only finds them: ``search_space("smc", "working")``,
``budget("mpc", "paper")``. ``SPACES`` and ``BUDGETS`` map (controller, name) to every declared one of the
registered controllers.
"""

from __future__ import annotations

from typing import Any

from vtrack_gym.baselines.tunable import (
    Budget,
    ControllerTuning,
    Parameter,
    SearchSpace,
    configs_from_vector,
)

__all__ = ["CROSSOVER_PROB", "MUTATION_PROB", "Budget", "Parameter", "SearchSpace", "budget",
           "configs_from_vector", "declared_help", "declared_names", "search_space", "tunable_controllers",
           "tuning_of"]

CROSSOVER_PROB = 0.8
"""SBX crossover probability per mating (Table 2)."""
MUTATION_PROB = 0.1
"""Polynomial-mutation probability per variable (Table 2's 0.1, read as a per-gene rate)."""


def tuning_of(controller: str | SearchSpace) -> ControllerTuning:
    """The tuning declaration of a registered controller name, or of a space's controller (its ``policy`` class's
    ``tuning()`` when it names one, else the registry's declaration of ``space.controller``)."""
    from vtrack_gym.baselines.registry import policy_tuning

    if isinstance(controller, SearchSpace) and controller.policy is not None:
        declare = getattr(controller.policy, "tuning", None)
        declared = declare() if callable(declare) else None
        if not isinstance(declared, ControllerTuning):
            raise ValueError(f"{controller.policy.__name__}.tuning() must return a ControllerTuning")
        return declared
    return policy_tuning(controller.controller if isinstance(controller, SearchSpace) else controller)


def tunable_controllers() -> tuple[str, ...]:
    """Registered controller names with a tuning declaration."""
    from vtrack_gym.baselines.registry import tunable_policies

    return tunable_policies()


def search_space(controller: str, name: str = "paper") -> SearchSpace:
    """The declared space (``ValueError`` listing the valid ones if unknown)."""
    spaces = _all("spaces")
    if (controller, name) not in spaces:
        raise ValueError(f"unknown search space {controller}/{name}; valid: "
                         f"{', '.join(f'{c}/{s}' for c, s in spaces)}")
    return spaces[(controller, name)]


def budget(controller: str, name: str) -> Budget:
    """The declared budget (``ValueError`` listing the controller's budgets if unknown)."""
    budgets = _all("budgets")
    if (controller, name) not in budgets:
        raise ValueError(f"unknown budget {name!r} for {controller}; valid: "
                         f"{', '.join(b for c, b in budgets if c == controller)}")
    return budgets[(controller, name)]


def _all(kind: str) -> dict[tuple[str, str], Any]:
    """(controller, name) -> declared space or budget of every tunable registered controller."""
    return {(c, key): value for c in tunable_controllers() for key, value in getattr(tuning_of(c), kind).items()}


def declared_names(kind: str) -> tuple[str, ...]:
    """Every space (``kind="spaces"``) or budget (``"budgets"``) name some tunable controller declares, in order."""
    return tuple(dict.fromkeys(key for _, key in _all(kind)))


def declared_help(kind: str) -> str:
    """``smc: paper, working; mpc: ...`` (budgets with their generations x population), for ``--help`` texts."""
    parts = []
    for c in tunable_controllers():
        declared = getattr(tuning_of(c), kind)
        names = [f"{k} ({v.generations} x {v.pop_size})" if kind == "budgets" else k for k, v in declared.items()]
        parts.append(f"{c}: {', '.join(names)}")
    return "; ".join(parts)


def __getattr__(name: str) -> Any:
    """``SPACES`` and ``BUDGETS``, gathered from the declarations when first asked for."""
    if name in ("SPACES", "BUDGETS"):
        return _all(name.lower())
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
