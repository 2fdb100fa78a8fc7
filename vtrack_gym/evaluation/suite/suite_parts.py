"""A leaderboard suite as one object: ``Suite`` (its episodes are ``episodes.Episode``).

A suite is one ``Suite`` object: its episodes for a seed set, its standard and quick seeds, the metric its board
ranks on, its extra board columns, whether ``vtrack dataset`` records it, which figures ``vtrack benchmark``
draws, how an episode is scored and which optional packages it needs. ``evaluation.suite.suites`` keeps them in one
registry; the built-in ones live in ``evaluation.suite.suite_defs`` (one file each).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from vtrack_gym.evaluation.rollouts.episodes import Episode, with_vehicle  # noqa: F401  (with_vehicle re-exported)
from vtrack_gym.evaluation.scoring.row_validation import is_numeric_metric

FIGURE_KINDS: tuple[str, ...] = ("tracking", "maneuver")
"""What ``vtrack benchmark`` draws per env: ``tracking`` (trajectories, signals, SMC-vs-MPC bars) or ``maneuver``
(one ``plots.plot_maneuver`` figure per manoeuvre)."""


def _seed_tuple(seeds: Sequence[int], name: str) -> tuple[int, ...]:
    """``seeds`` as a non-empty tuple of ints >= 0 (``ValueError`` naming the field otherwise)."""
    if isinstance(seeds, (str, bytes)) or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0
                                                  for s in seeds) or not seeds:
        raise ValueError(f"Suite.{name} must be a non-empty sequence of ints >= 0 (got {seeds!r})")
    return tuple(seeds)


@dataclass(frozen=True)
class Suite:
    """A leaderboard suite.

    ``episodes(seeds)`` returns the scored episodes for a seed set (``ValueError`` for seeds it cannot use);
    ``seeds``: its standard seeds (what its board ranks); ``quick_seeds``: the seeds of its ``--quick`` variant
    (``None``: no quick variant); ``primary_metric``: what its board ranks on after the success rate (lower is
    better); ``then_metrics``: further metrics (lower is better) that order policies with the same success rate and
    the same mean primary metric, in turn; ``columns``: board columns beyond the common ones; ``dataset``:
    ``vtrack dataset`` may record it (its episodes drive this package's envs); ``figures``: one of
    ``FIGURE_KINDS``; ``trace_every_seed``: keep the trace of every seed, not only the first; ``scorer(make)``:
    what scores one episode (``None``: ``episode_score.score_episode``); ``needs``: importable modules it needs
    (``highway_env``); ``description``: one line for ``--help`` and the docs.
    """

    name: str
    description: str
    episodes: Callable[[tuple[int, ...]], list[Episode]]
    seeds: tuple[int, ...] = (0,)
    quick_seeds: tuple[int, ...] | None = None
    primary_metric: str = "max_e_y_m"
    columns: tuple[str, ...] = ()
    then_metrics: tuple[str, ...] = ()
    dataset: bool = True
    figures: str = "tracking"
    trace_every_seed: bool = False
    scorer: Callable[[Any], Any] | None = None
    needs: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.replace("_", "").replace("-", "").isalnum():
            raise ValueError(f"Suite.name must be letters, digits, '-' or '_' (got {self.name!r})")
        if not callable(self.episodes):
            raise ValueError(f"Suite.episodes must be callable: seeds -> list[Episode] (got {self.episodes!r})")
        object.__setattr__(self, "seeds", _seed_tuple(self.seeds, "seeds"))
        if self.quick_seeds is not None:
            object.__setattr__(self, "quick_seeds", _seed_tuple(self.quick_seeds, "quick_seeds"))
        if self.figures not in FIGURE_KINDS:
            raise ValueError(f"Suite.figures must be one of {', '.join(FIGURE_KINDS)} (got {self.figures!r})")
        if not isinstance(self.primary_metric, str) or not is_numeric_metric(self.primary_metric):
            raise ValueError("Suite.primary_metric must be a numeric metric: a name with a unit suffix, max_*, rms_* "
                             f"or an error, count or duration metric such as itae (got {self.primary_metric!r})")
        object.__setattr__(self, "columns", tuple(self.columns))
        object.__setattr__(self, "then_metrics", tuple(self.then_metrics))
        bad = [m for m in self.then_metrics if not isinstance(m, str) or not is_numeric_metric(m)]
        if bad:
            raise ValueError(f"Suite.then_metrics must be numeric metrics (names with a unit suffix, max_*, rms_*) "
                             f"(got {bad!r})")
        object.__setattr__(self, "needs", tuple(self.needs))

    def episodes_for(self, quick: bool = False, seeds: Sequence[int] | None = None) -> list[Episode]:
        """The episodes for ``seeds`` (default: the standard seeds, the quick ones when ``quick``)."""
        if seeds:
            return self.episodes(tuple(int(s) for s in seeds))
        return self.episodes(self.quick_seeds if quick and self.quick_seeds is not None else self.seeds)

    def score(self, make: Any) -> Any:
        """What scores one episode of this suite for the policy factory ``make``."""
        if self.scorer is not None:
            return self.scorer(make)
        from vtrack_gym.evaluation.rollouts.episode_score import score_episode

        return score_episode
