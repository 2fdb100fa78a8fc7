"""Leaderboard suites: one registry of ``Suite`` objects (``suite_parts.Suite``), read by every command, help text
and error message.

The built-in suites live in ``evaluation.suite.suite_defs`` (one file each, in ``_REGISTRY``; ``suite_names()`` lists
every registered one). A suite of your own is one ``Suite`` and one ``register_suite`` call; an installed package
can also name it in the ``vtrack_gym.suites`` entry-point group (the entry point is a ``Suite``), and every
``vtrack`` command then lists it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from vtrack_gym._plugins import add_named, forget, load_group
from vtrack_gym.evaluation.rollouts.episodes import (  # noqa: F401  (re-exported)
    Episode,
    with_control,
    with_latency,
    with_launch,
    with_numerics,
    with_vehicle,
)
from vtrack_gym.evaluation.suite.suite_defs.highway import HIGHWAY
from vtrack_gym.evaluation.suite.suite_defs.maneuvers import MANEUVER_ENV_IDS, MANEUVERS  # noqa: F401  (re-exported)
from vtrack_gym.evaluation.suite.suite_defs.paper import PAPER
from vtrack_gym.evaluation.suite.suite_defs.race import RACE
from vtrack_gym.evaluation.suite.suite_defs.robust import (  # noqa: F401  (re-exported)
    ROBUST,
    ROBUST_FRICTION,
    ROBUST_SEEDS,
    robust_options,
)
from vtrack_gym.evaluation.suite.suite_defs.trajectory import TRAJECTORY
from vtrack_gym.evaluation.suite.suite_parts import Suite

ENTRY_POINT_GROUP = "vtrack_gym.suites"
"""Entry-point group of suites from installed packages (each entry point loads a ``Suite``)."""
DEFAULT_METRIC = "max_e_y_m"
"""What a board of rows outside any registered suite (``custom``, ``tuning``, ``tracks[...]``) ranks on."""

_REGISTRY: dict[str, Suite] = {s.name: s for s in (PAPER, ROBUST, HIGHWAY, MANEUVERS, TRAJECTORY, RACE)}
_LOADED_ENTRY_POINTS: dict[str, str] = {}  # "name=value" of a loaded entry point -> the suite it registered


def _register_entry_point(suite: Any, where: str) -> str:
    if not isinstance(suite, Suite):
        raise ValueError(f"{where} must be a vtrack_gym.evaluation.suite.suites.Suite (got {type(suite).__name__})")
    return register_suite(suite, replace=True).name


def _load_entry_points() -> None:
    """Register the suites of the ``vtrack_gym.suites`` entry points not loaded yet (once each per process)."""
    load_group(ENTRY_POINT_GROUP, _register_entry_point, _LOADED_ENTRY_POINTS)


def register_suite(suite: Suite, replace: bool = False) -> Suite:
    """Add ``suite`` to the registry (``replace``: over a suite of the same name); returns it."""
    return add_named(_REGISTRY, getattr(suite, "name", ""), suite, Suite, "suite", replace)


def unregister_suite(name: str) -> None:
    """Remove the suite ``name`` (a no-op for an unknown name); an entry point that registered it is loaded again
    when it is still installed."""
    _REGISTRY.pop(name, None)
    forget(_LOADED_ENTRY_POINTS, name)


def suite_names() -> tuple[str, ...]:
    """Every registered suite's name, built-in ones first."""
    _load_entry_points()
    return tuple(_REGISTRY)


def get_suite(name: str) -> Suite:
    """The registered suite ``name`` (``ValueError`` listing the registered ones otherwise)."""
    _load_entry_points()
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown suite {name!r}; valid: {', '.join(_REGISTRY)}") from None


def find_suite(label: str) -> Suite | None:
    """The registered suite a stored suite label belongs to (``base_suite``), or None (``custom``, ``tuning``)."""
    _load_entry_points()
    return _REGISTRY.get(base_suite(label))


def suite_help() -> str:
    """One ``NAME: description`` clause per registered suite, for ``--help`` texts."""
    return "; ".join(f"{s.name}: {s.description}" for s in (get_suite(n) for n in suite_names()))


def quick_suites() -> tuple[str, ...]:
    """The registered suites with a quick variant (``Suite.quick_seeds``)."""
    return tuple(n for n in suite_names() if get_suite(n).quick_seeds is not None)


def seeds_help() -> str:
    """``NAME SEEDS`` per registered suite (``paper 0; robust 101,202,...``), for ``--help`` texts."""
    return "; ".join(f"{n} {_seed_text(get_suite(n).seeds)}" for n in suite_names())


def suite_episodes(name: str, quick: bool = False, seeds: Sequence[int] | None = None) -> list[Episode]:
    """The episodes of suite ``name`` (``quick``: its quick variant's seeds, for smoke tests; ``seeds`` replaces the
    suite's seeds)."""
    return get_suite(name).episodes_for(quick, seeds)


def primary_metric(suite: str) -> str:
    """The metric ``suite``'s leaderboard ranks on after the success rate (``Suite.primary_metric``; a label of a
    non-standard seed set, ``robust[seeds=7]``, ranks like its suite; other labels on ``DEFAULT_METRIC``)."""
    found = find_suite(suite)
    return DEFAULT_METRIC if found is None else found.primary_metric


def then_metrics(suite: str) -> tuple[str, ...]:
    """The metrics ``suite``'s board orders on after its primary metric (``Suite.then_metrics``; none for labels of
    no registered suite)."""
    found = find_suite(suite)
    return () if found is None else found.then_metrics


def primary_metrics() -> frozenset[str]:
    """Every metric some registered suite ranks on (and ``DEFAULT_METRIC``)."""
    return frozenset({DEFAULT_METRIC, *(get_suite(n).primary_metric for n in suite_names())})


def extra_columns(suite: str) -> tuple[str, ...]:
    """The board columns of ``suite`` beyond the common ones (``Suite.columns``; none for unregistered labels)."""
    found = find_suite(suite)
    return () if found is None else found.columns


def base_suite(label: str) -> str:
    """The suite a stored suite label belongs to: ``robust`` for ``robust``, ``robust[seeds=7]``, ``robust[quick]``."""
    return label.partition("[")[0]


def _seed_text(seeds: Sequence[int]) -> str:
    """``0-4,7``: sorted seeds with runs of consecutive ones as ranges."""
    ordered = sorted(set(int(s) for s in seeds))
    parts: list[str] = []
    start = prev = ordered[0]
    for s in [*ordered[1:], None]:
        if s is not None and s == prev + 1:
            prev = s
            continue
        parts.append(str(start) if start == prev else f"{start}-{prev}")
        if s is not None:
            start = prev = s
    return ",".join(parts)


def suite_label(name: str, quick: bool = False, seeds: Sequence[int] | None = None) -> str:
    """The suite name rows of ``suite_episodes(name, quick, seeds)`` are stored under: ``name`` for the standard
    episodes, else ``name[seeds=...]`` (another seed set; ``seeds`` wins over ``quick``) or ``name[quick]``, so a
    subset or another set of seeds is never ranked with the suite's standard board."""
    found = find_suite(name)
    if seeds:
        if found is not None and sorted(set(int(s) for s in seeds)) == sorted(found.seeds):
            return name
        return f"{name}[seeds={_seed_text(seeds)}]"
    if quick and found is not None and found.quick_seeds is not None:
        return f"{name}[quick]"
    return name
