"""GA tuning with pymoo: rank-based selection, SBX crossover (0.8), polynomial mutation (0.1 per variable).

Every generation's population is evaluated as ONE batched rollout (``PopulationEvaluator``). pymoo's GA counts
the initial population as generation 1, so ``generations x pop_size`` episodes are evaluated (fewer if the
duplicate elimination cannot find ``pop_size`` distinct offspring). Survival is pymoo's elitist
``FitnessSurvival`` (parents + offspring, best ``pop_size`` kept), so the best fitness never gets worse.
A fixed ``seed`` reproduces the run (pymoo's generator and the deterministic nominal scenario).

``backend="ray"`` evaluates each generation on a Ray cluster instead (``vtrack_gym.tuning.backends``: the
population split row-wise over the workers); the result is bit-identical to ``backend="local"``.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vtrack_gym.tuning.backends import make_evaluator
from vtrack_gym.tuning.population import FitnessConfig, configs_from_vector
from vtrack_gym.tuning.spaces import CROSSOVER_PROB, MUTATION_PROB, Budget, SearchSpace


def _rank_selection_cls() -> type:
    from pymoo.core.selection import Selection

    class RankSelection(Selection):
        """Linear ranking selection (Baker): P(rank r, 0 = best) = (2 - s)/N + 2 r'(s - 1)/(N (N - 1)),
        r' = N - 1 - r, selection pressure ``s`` in [1, 2] (default 1.7)."""

        def __init__(self, pressure: float = 1.7, **kwargs: Any) -> None:
            super().__init__(**kwargs)
            if not 1.0 <= pressure <= 2.0:
                raise ValueError(f"RankSelection.pressure must be in [1, 2] (got {pressure})")
            self.pressure = pressure

        def _do(self, problem: Any, pop: Any, n_select: int, n_parents: int, *args: Any,
                random_state: Any = None, **kwargs: Any) -> np.ndarray:
            f = pop.get("F")[:, 0]
            cv = pop.get("CV")
            key = f + (1e30 * cv[:, 0] if cv is not None and cv.ndim == 2 else 0.0)
            n = len(pop)
            rank = np.empty(n)
            rank[np.argsort(key, kind="stable")] = np.arange(n)
            if n == 1:
                prob = np.ones(1)
            else:
                s = self.pressure
                prob = (2.0 - s) / n + 2.0 * (n - 1 - rank) * (s - 1.0) / (n * (n - 1))
                prob = prob / prob.sum()
            return random_state.choice(n, size=(n_select, n_parents), p=prob)

    return RankSelection


@dataclass
class TuneResult:
    """Best individual found and the run's bookkeeping."""

    space: SearchSpace
    budget: Budget
    seed: int
    best_x: np.ndarray
    best_fitness: float
    best_metrics: dict[str, float]
    best_config: Any
    best_speed_config: Any
    initial_best_fitness: float
    history: list[float] = field(default_factory=list)   # best fitness after each generation
    episodes: int = 0
    car_steps: int = 0
    wall_s: float = 0.0
    backend: str = "local"   # where the populations were evaluated ("local" or "ray")
    workers: int = 1         # processes that evaluated them (Ray actors; 1 for "local")

    @property
    def params(self) -> dict[str, float]:
        return {name: float(v) for name, v in zip(self.space.names, self.best_x.tolist(), strict=True)}


MAX_GENERATIONS = 10_000
MAX_POP_SIZE = 10_000
MAX_SEED = 2**32 - 1
MAX_EPISODE_STEPS = 10**7


def check_tune_args(budget: Budget, seed: int, max_steps: int | None) -> None:
    """``ValueError`` naming the argument unless generations in [1, 10000], pop_size in [2, 10000], seed in
    [0, 2^32 - 1] (pymoo seeds numpy's legacy generator) and ``max_steps`` None or in [1, 1e7]."""
    def check(name: str, value: object, low: int, high: int) -> None:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
            raise ValueError(f"{name} must be an integer in [{low}, {high}] (got {value!r})"[:300])

    check("generations", budget.generations, 1, MAX_GENERATIONS)
    check("pop_size", budget.pop_size, 2, MAX_POP_SIZE)
    check("seed", seed, 0, MAX_SEED)
    if max_steps is not None:
        check("max_steps", max_steps, 1, MAX_EPISODE_STEPS)


def tune(space: SearchSpace, budget: Budget, seed: int = 0, scenario: str = "LateralTracking-v0",
         fitness: FitnessConfig | None = None, progress: bool = True, max_steps: int | None = None,
         also_complete: tuple[str, ...] = (), backend: str = "local", ray_address: str | None = None,
         num_workers: int | None = None) -> TuneResult:
    """Run the GA; returns the best individual (see the module docstring). ``also_complete``: scenarios every
    individual must also complete (e.g. ``("DLC120-v0",)``), else the incomplete-run penalty is added.
    ``backend``: ``"local"`` or ``"ray"``; ``ray_address`` (default: ``$RAY_ADDRESS`` or a local Ray instance)
    and ``num_workers`` (default: the cluster's CPUs, at most the population size) apply to ``"ray"`` only."""
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.operators.sampling.rnd import FloatRandomSampling
    from pymoo.problems.static import StaticProblem

    check_tune_args(budget, seed, max_steps)
    start = time.perf_counter()
    evaluator = make_evaluator(backend, space, ray_address=ray_address, num_workers=num_workers,
                               pop_size=budget.pop_size, scenario=scenario, fitness=fitness, seed=0,
                               max_steps=max_steps, also_complete=also_complete)
    bar = None
    try:
        problem = Problem(n_var=len(space.params), n_obj=1, xl=space.lower, xu=space.upper)
        algorithm = GA(pop_size=budget.pop_size, sampling=FloatRandomSampling(),
                       selection=_rank_selection_cls()(), crossover=SBX(prob=CROSSOVER_PROB, eta=15),
                       mutation=PM(prob=1.0, prob_var=MUTATION_PROB, eta=20), eliminate_duplicates=True)
        algorithm.setup(problem, termination=("n_gen", budget.generations), seed=int(seed), verbose=False)
        if progress:
            from vtrack_gym._progress import progress_bar

            bar = progress_bar(total=budget.generations, desc=f"tune {space.controller}/{space.name}", unit="gen")
        best_f, best_x, best_metrics = np.inf, None, {}
        initial_best = np.nan
        history: list[float] = []
        while algorithm.has_next():
            pop = algorithm.ask()
            X = pop.get("X")
            res = evaluator(X)
            Evaluator().eval(StaticProblem(problem, F=res.fitness[:, None]), pop)
            algorithm.tell(infills=pop)
            i = int(np.argmin(res.fitness))
            if res.fitness[i] < best_f:
                best_f, best_x, best_metrics = float(res.fitness[i]), X[i].copy(), res.row(i)
            if not history:
                initial_best = best_f
            history.append(best_f)
            if bar is not None:
                bar.set_postfix(best=f"{best_f:.4g}", eps=f"{res.fitness.size / max(res.wall_s, 1e-9):.2f}/s")
                bar.update(1)
        base_speed = evaluator.env(budget.pop_size).config.speed_controller
        cfg, speed_cfg = configs_from_vector(space, best_x, evaluator.base_config, base_speed)
        episodes, car_steps = evaluator.episodes, evaluator.car_steps
        workers = getattr(evaluator, "num_workers", 1)
    finally:
        if bar is not None:
            bar.close()
        close = getattr(evaluator, "close", None)
        if close is not None:
            close()
    return TuneResult(space, budget, int(seed), best_x, best_f, best_metrics, cfg, speed_cfg, float(initial_best),
                      history, episodes, car_steps, time.perf_counter() - start, backend, workers)


def config_dict(config: Any) -> dict[str, Any]:
    """JSON-safe dict of a frozen config dataclass (tuples as lists)."""
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(config).items()}
